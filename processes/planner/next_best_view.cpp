#include "processes/planner/next_best_view.h"

#include <algorithm>
#include <cmath>

namespace objscan {

NextViewResult ChooseNextView(const CoverageModel& coverage, const OccupancyMap& map, const CostField& from_robot,
                              const RobotGeometry& robot, const RobotLimits& limits, const NextViewOptions& options,
                              const std::set<int>& excluded) {
  NextViewResult result;
  if (!coverage.has_target() || coverage.num_samples() == 0 || !from_robot.valid()) return result;
  const Eigen::Vector3d centre = coverage.target().centre_mm;
  const Eigen::Vector3d aims[2] = {centre, coverage.UncoveredCentroid()};
  const int steps = std::max(1, static_cast<int>(std::round(360.0 / options.azimuth_step_deg)));
  const double arc = options.capture_arc_deg * M_PI / 180.0;
  for (size_t ring = 0; ring < options.radii_mm.size(); ++ring) {
    const double r = options.radii_mm[ring];
    for (int k = 0; k < steps; ++k) {
      const int key = static_cast<int>(ring) * 1000 + k;
      if (excluded.count(key)) continue;
      const double azimuth = 2 * M_PI * k / steps;
      const Eigen::Vector2d position = centre.head<2>() + r * Eigen::Vector2d(std::cos(azimuth), std::sin(azimuth));
      auto on_ring = [&](double a) { return Eigen::Vector2d(centre.head<2>() + r * Eigen::Vector2d(std::cos(a), std::sin(a))); };
      int index;
      if (!map.IndexOf(position, &index) || !map.Traversable(index) || !from_robot.Reachable(index) ||
          !(map.TraversableAt(on_ring(azimuth + arc)) || map.TraversableAt(on_ring(azimuth - arc))))
        continue;
      const BasePose base{position.x(), position.y(), WrapAngle(azimuth + M_PI / 2)};
      for (int a = 0; a < 2; ++a) {
        if (a == 1 && (aims[1] - aims[0]).norm() < 1.0) break;
        double pan, tilt;
        AimHead(robot, base, aims[a], &pan, &tilt);
        if (std::abs(pan) > limits.max_pan_rad) continue;
        tilt = std::clamp(tilt, limits.min_tilt_rad, limits.max_tilt_rad);
        ++result.candidates;
        const CameraView view = CameraView::From(WorldFromCamera(robot, base, pan, tilt));
        const int gain = coverage.CountUncoveredSeen(view);
        const double path_mm = from_robot.CostMm(index);
        const double score = gain / (1.0 + path_mm / 1000.0);
        if (gain >= options.min_gain && (!result.found || score > result.best.score)) {
          result.found = true;
          result.best = {key, base, pan, tilt, r, azimuth, aims[a], gain, path_mm, score};
        }
      }
    }
  }
  return result;
}

}  // namespace objscan
