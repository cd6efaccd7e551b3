// The object finder's floor: the lowest near-horizontal plane among the sparse map's landmarks (the planner uses it
// too). Plane type and RANSAC / refit machinery: common/floor_fit.h (FloorPlane: Height(p) = normal . p + offset_mm,
// mm, positive above). Frames: world z up (the pose solver's world; its floor is near z = 0, but nothing here assumes
// it), mm. LCM-free, deterministic (fixed RNG seed, no timing).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/floor_fit.h"

namespace objscan {

struct FloorFitOptions {
  double inlier_mm = 15.0;   // mm, max |height| of a floor point
  double max_tilt_deg = 10;  // deg, max angle between the floor normal and world z
  int min_points = 40;       // floor inliers needed to accept a plane
};

struct FloorFit {
  bool found = false;  // false: fewer than min_points inliers on any near-horizontal plane
  FloorPlane plane;
  int inliers = 0;  // points within inlier_mm of the final plane
};

// Fits the floor to points (world, mm; all finite). RANSAC (common/floor_fit.h MostSupportedPlane: 400 3-point
// samples, seed 24, normals tilted more than max_tilt_deg skipped) on up to 512 evenly spread points, `previous` (may
// be null) scored as one more hypothesis, then two total-least-squares refits on the inliers among all points (a
// refit tilted more than max_tilt_deg: not found). The floor is the lowest such plane: when many points lie
// clearly below the fitted plane (a table top won), the fit is repeated on those points (at most twice).
// Cost O(points). Never throws beyond std::bad_alloc.
FloorFit FitFloor(const std::vector<Eigen::Vector3d>& points, const FloorFitOptions& options,
                  const FloorPlane* previous = nullptr);

}  // namespace objscan
