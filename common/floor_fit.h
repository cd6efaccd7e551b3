// Floor planes among 3-D points: the project's one plane type and the RANSAC machinery shared by its three floor
// fitters, each of which keeps its own policy (which plane is the floor, what is done with it):
//   - processes/object_finder/floor_plane.h FitFloor: the lowest near-horizontal plane, the previous floor scored too;
//   - processes/dense_modeler/region_of_interest.h FitFloorPlane: the plane with the most landmarks near the object;
//   - processes/pose_solver/pose_estimator.cpp PoseEstimator::DetectFloor: the plane with the most landmarks and
//     almost none beneath it, "up" taken from the odometry or from the cameras.
// Units: mm. Frame: the points' frame (for the robot's world: z up, the floor near z = 0 but never assumed there).
// LCM-free, Eigen only. Deterministic: the samples come from a seeded generator (SampleIndexSequence), no timing, no
// global state. Never throws beyond std::bad_alloc; points must be finite.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <vector>

namespace objscan {

// The plane {p : Height(p) = 0}. Height(p) = normal . p + offset_mm is the signed distance of p above the plane
// (mm, positive on the normal's side). Floors have their normal pointing up (away from the floor, normal.z() > 0 in
// a z-up world), so a point on a floor at z = h has offset_mm = -h.
struct FloorPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit
  double offset_mm = 0.0;                             // mm

  double Height(const Eigen::Vector3d& p) const { return normal.dot(p) + offset_mm; }
  // floor_from_world: the smallest rotation taking normal to +z, then a shift so that z = Height(p). For a level
  // floor at z = 0 it is the identity; x and y stay the world's x and y rotated by the floor's tilt only.
  Eigen::Isometry3d FloorFromWorld() const;
};

// The generator of the sample indices (each in [0, n)). Every fitter keeps the sequence its results were measured
// with: a new sequence is a new random draw, and on issue 27 the pose solver's floor was then missed on an image-only
// test run (scale metric -> arbitrary) and the dense modeler's automatic region changed.
enum class SampleIndexSequence {
  kMt19937Modulo,   // std::mt19937(seed)() % n (object finder); the same on every platform
  kMt19937Uniform,  // std::uniform_int_distribution<int>(0, n - 1) on std::mt19937(seed) (pose solver); the draws
                    // depend on the standard library's distribution
  kLcg,             // (state = state * 6364136223846793005 + 1442695040888963407, from seed) >> 33, % n (dense
                    // modeler); the same on every platform
};

// How the 3-point plane hypotheses are drawn.
struct PlaneSampling {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // unit; hypotheses' normals are turned to this side
  double max_tilt_deg = 10.0;                     // deg, hypotheses whose normal is further from up are skipped
  int iterations = 400;                           // 3-point samples drawn (degenerate and tilted ones included)
  SampleIndexSequence sequence = SampleIndexSequence::kMt19937Modulo;
  uint64_t seed = 24;  // the generator's seed (mt19937: its low 32 bits): the same input gives the same hypotheses
};

struct PlaneSupport {
  FloorPlane plane;
  int inliers = 0;  // points within the inlier distance of plane (0: no admissible hypothesis had any)
};

// RANSAC: draws sampling.iterations samples of 3 point indices from sampling.sequence; each sample of
// distinct, non-collinear points whose normal lies within max_tilt_deg of up gives a hypothesis through them. The
// result is the hypothesis with the most points within inlier_mm (the first on ties); `start` (may be null) is
// scored first, as one more hypothesis; `admissible` (may be empty) rejects hypotheses before they are scored.
// Fewer than 3 points: `start` (or a default plane) with its count. Cost O(iterations x points).
PlaneSupport MostSupportedPlane(const std::vector<Eigen::Vector3d>& points, const PlaneSampling& sampling,
                                double inlier_mm, const FloorPlane* start = nullptr,
                                const std::function<bool(const FloorPlane&)>& admissible = {});

// Points with |Height(p)| <= inlier_mm.
int CountPlaneInliers(const std::vector<Eigen::Vector3d>& points, const FloorPlane& plane, double inlier_mm);
// Points with Height(p) < -depth_mm.
int CountPointsBelow(const std::vector<Eigen::Vector3d>& points, const FloorPlane& plane, double depth_mm);

// Total least squares refit: *plane becomes the plane through the mean of the points with |Height(p)| <= inlier_mm
// whose normal is their covariance's smallest eigenvector, turned to up's side. False (*plane unchanged) with fewer
// than 3 such points. The tilt is not checked (see NormalWithinTilt): what a too tilted refit means is policy.
bool RefitPlaneToInliers(const std::vector<Eigen::Vector3d>& points, double inlier_mm, const Eigen::Vector3d& up,
                         FloorPlane* plane);

// True when plane.normal is within max_tilt_deg of up (both unit).
bool NormalWithinTilt(const FloorPlane& plane, const Eigen::Vector3d& up, double max_tilt_deg);

}  // namespace objscan
