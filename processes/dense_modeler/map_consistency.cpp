#include "processes/dense_modeler/map_consistency.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace objscan {

namespace {

double Percentile(std::vector<double>* values, double fraction) {
  const size_t k = static_cast<size_t>(std::lround(fraction * static_cast<double>(values->size() - 1)));
  std::nth_element(values->begin(), values->begin() + static_cast<std::ptrdiff_t>(k), values->end());
  return (*values)[k];
}

}  // namespace

FloorThickness MeasureFloorThickness(const std::vector<Eigen::Vector3d>& landmarks, const Eigen::Vector3d& centre,
                                     const FloorPlane& floor,
                                     double min_inner_radius_mm, const FloorThicknessOptions& options) {
  FloorThickness result;
  result.inner_radius_mm = std::max(options.inner_radius_mm, min_inner_radius_mm);
  const double outer = result.inner_radius_mm + options.ring_width_mm;
  if (!centre.allFinite() || !floor.normal.allFinite() || !std::isfinite(floor.offset_mm)) return result;
  std::vector<double> heights;
  std::vector<std::pair<int64_t, double>> by_cell;  // (cell key, height)
  const double cell = options.cell_mm > 0 ? options.cell_mm : 50.0;
  for (const Eigen::Vector3d& p : landmarks) {
    if (!p.allFinite()) continue;
    const double r = (p - centre).head<2>().norm();
    if (r < result.inner_radius_mm || r > outer) continue;
    const double h = floor.Height(p);
    if (!(std::abs(h) <= options.band_mm)) continue;
    heights.push_back(h);
    const int64_t ix = static_cast<int64_t>(std::floor(p.x() / cell)), iy = static_cast<int64_t>(std::floor(p.y() / cell));
    by_cell.emplace_back(ix * 4000003 + iy, h);  // |ix|, |iy| < 2e6 for any room (cells of 50 mm: 100 km)
  }
  result.points = static_cast<int>(heights.size());
  if (result.points < std::max(1, options.min_points)) return result;
  result.measured = true;
  result.p10_mm = Percentile(&heights, 0.1);
  result.p50_mm = Percentile(&heights, 0.5);
  result.p90_mm = Percentile(&heights, 0.9);
  std::sort(by_cell.begin(), by_cell.end());
  std::vector<double> cell_thickness, in_cell;
  for (size_t i = 0; i < by_cell.size();) {
    size_t j = i;
    in_cell.clear();
    while (j < by_cell.size() && by_cell[j].first == by_cell[i].first) in_cell.push_back(by_cell[j++].second);
    if (static_cast<int>(in_cell.size()) >= options.min_cell_points)
      cell_thickness.push_back(Percentile(&in_cell, 0.9) - Percentile(&in_cell, 0.1));
    i = j;
  }
  result.cells = static_cast<int>(cell_thickness.size());
  if (result.cells >= std::max(1, options.min_cells)) result.local_thickness_mm = Percentile(&cell_thickness, 0.5);
  return result;
}

bool FloorThickness::Inconsistent(const FloorThicknessOptions& options) const {
  if (!measured || !(thickness_mm() > options.max_thickness_mm)) return false;
  return local_thickness_mm < 0 || local_thickness_mm > options.max_local_thickness_mm;
}

ModelMapChoice ChooseModelMap(const std::vector<PairFrames>& pairs,
                              const std::unordered_map<int64_t, int64_t>& map_of) {
  ModelMapChoice choice;
  choice.keep.assign(pairs.size(), true);
  auto map_at = [&](int64_t seq) {
    auto it = map_of.find(seq);
    return it == map_of.end() || it->second < 0 ? int64_t{-1} : it->second;
  };
  std::map<int64_t, int64_t> matches_in;  // map -> matches of the pairs within it (ordered: deterministic ties)
  for (const PairFrames& p : pairs) {
    const int64_t a = map_at(p.seq_a), b = map_at(p.seq_b);
    if (a >= 0) matches_in.emplace(a, 0);
    if (b >= 0) matches_in.emplace(b, 0);
    if (a >= 0 && a == b) matches_in[a] += p.matches;
  }
  choice.maps = static_cast<int>(matches_in.size());
  if (choice.maps >= 1) {
    int64_t best = -1;
    for (const auto& [map, matches] : matches_in)
      if (best < 0 || matches >= matches_in[best]) best = map;  // ascending: a tie goes to the later map
    choice.map_start_seq = best;
  }
  for (size_t i = 0; i < pairs.size(); ++i) {
    const int64_t a = map_at(pairs[i].seq_a), b = map_at(pairs[i].seq_b);
    if (choice.map_start_seq >= 0) {
      if (a >= 0 && b >= 0 && a != b) {
        choice.keep[i] = false;
        ++choice.pairs_across_maps;
      } else if ((a >= 0 && a != choice.map_start_seq) || (b >= 0 && b != choice.map_start_seq)) {
        choice.keep[i] = false;  // in another map (a frame without a final pose keeps its live one: that map's too)
        ++choice.pairs_other_map;
      }
    }
    (choice.keep[i] ? choice.matches_kept : choice.matches_dropped) += pairs[i].matches;
  }
  return choice;
}

}  // namespace objscan
