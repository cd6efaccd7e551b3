#include "processes/dense_modeler/map_consistency.h"

#include <algorithm>
#include <cmath>

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
  for (const Eigen::Vector3d& p : landmarks) {
    if (!p.allFinite()) continue;
    const double r = (p - centre).head<2>().norm();
    if (r < result.inner_radius_mm || r > outer) continue;
    const double h = floor.Height(p);
    if (std::abs(h) <= options.band_mm) heights.push_back(h);
  }
  result.points = static_cast<int>(heights.size());
  if (result.points < std::max(1, options.min_points)) return result;
  result.measured = true;
  result.p10_mm = Percentile(&heights, 0.1);
  result.p50_mm = Percentile(&heights, 0.5);
  result.p90_mm = Percentile(&heights, 0.9);
  return result;
}

}  // namespace objscan
