#include "processes/dense_modeler/map_consistency.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
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

}  // namespace objscan
