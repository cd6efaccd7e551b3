#include "processes/object_finder/floor_plane.h"

#include <algorithm>
#include <cstdint>

namespace objscan {
namespace {

constexpr int kSamplePoints = 512;  // points the RANSAC hypotheses are scored on
constexpr int kIterations = 400;    // 3-point samples
constexpr uint32_t kSeed = 24u;     // fixed: the same input gives the same floor

// One RANSAC + refit on candidates (the retries of FitFloor pass the points below the last fit).
FloorFit FitOnce(const std::vector<Eigen::Vector3d>& candidates, const FloorFitOptions& options,
                 const FloorPlane* previous) {
  FloorFit fit;
  const int n = static_cast<int>(candidates.size());
  if (n < std::max(3, options.min_points)) return fit;
  const int m = std::min(n, kSamplePoints);
  std::vector<Eigen::Vector3d> sample(m);
  for (int k = 0; k < m; ++k) sample[k] = candidates[static_cast<int64_t>(k) * n / m];
  PlaneSampling sampling;
  sampling.max_tilt_deg = options.max_tilt_deg;
  sampling.iterations = kIterations;
  sampling.seed = kSeed;
  PlaneSupport best = MostSupportedPlane(sample, sampling, options.inlier_mm, previous);
  if (best.inliers < 3) return fit;
  for (int pass = 0; pass < 2; ++pass)
    if (!RefitPlaneToInliers(candidates, options.inlier_mm, sampling.up, &best.plane) ||
        !NormalWithinTilt(best.plane, sampling.up, options.max_tilt_deg))
      return fit;
  fit.plane = best.plane;
  fit.inliers = CountPlaneInliers(candidates, best.plane, options.inlier_mm);
  fit.found = fit.inliers >= options.min_points;
  return fit;
}

}  // namespace

FloorFit FitFloor(const std::vector<Eigen::Vector3d>& points, const FloorFitOptions& options,
                  const FloorPlane* previous) {
  std::vector<Eigen::Vector3d> candidates = points;
  FloorFit best = FitOnce(candidates, options, previous);
  // The floor is the lowest horizontal plane: a table top with more landmarks than the floor leaves the floor's
  // points clearly below it. Points below the floor itself are only noise and phantoms (few, not a plane).
  for (int retry = 0; retry < 2 && best.found; ++retry) {
    std::vector<Eigen::Vector3d> below;
    for (const Eigen::Vector3d& p : candidates)
      if (best.plane.Height(p) < -3.0 * options.inlier_mm) below.push_back(p);
    if (static_cast<int>(below.size()) < std::max<double>(options.min_points, 0.25 * best.inliers)) break;
    FloorFit lower = FitOnce(below, options, nullptr);
    if (!lower.found) break;
    lower.inliers = CountPlaneInliers(candidates, lower.plane, options.inlier_mm);
    // A floor under a table top is a plane of its own size; a few dozen noisy points below the floor are not (room_01:
    // a 30 000-landmark map once put the floor 195 mm low on such points).
    if (lower.inliers < 0.25 * best.inliers) break;
    best = lower;
    candidates.swap(below);
  }
  return best;
}

}  // namespace objscan
