// The floor of the sparse map: a near-horizontal plane found by RANSAC among the landmarks, refit by least squares.
// Frames: world z up (the pose solver's world; its floor is near z = 0, but nothing here assumes it), mm.
// LCM-free, deterministic (fixed RNG seed, no timing).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace objscan {

// height(p) = normal . p + offset_mm: signed distance of p above the plane (mm, positive on the normal's side).
struct FloorPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, world, normal.z() > 0 (up)
  double offset_mm = 0.0;                             // mm

  double Height(const Eigen::Vector3d& p) const { return normal.dot(p) + offset_mm; }
  // floor_from_world: the smallest rotation taking normal to +z, then a shift so that z = Height(p). For a level
  // floor at z = 0 it is the identity; x and y stay the world's x and y rotated by the floor's tilt only.
  Eigen::Isometry3d FloorFromWorld() const;
};

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

// Fits the floor to points (world, mm; all finite). RANSAC on up to 512 points (3-point samples, fixed seed,
// normals tilted more than max_tilt_deg skipped), `previous` (may be null) scored as one more hypothesis, then two
// least-squares refits on the inliers among all points. The floor is the lowest such plane: when many points lie
// clearly below the fitted plane (a table top won), the fit is repeated on those points (at most twice).
// Cost O(points). Never throws beyond std::bad_alloc.
FloorFit FitFloor(const std::vector<Eigen::Vector3d>& points, const FloorFitOptions& options,
                  const FloorPlane* previous = nullptr);

}  // namespace objscan
