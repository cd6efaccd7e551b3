// Evaluation against ground truth (LCM-free): trajectories in TUM format and surfaces as point sets.
// TUM lines: "t tx ty tz qx qy qz qw" (camera-to-world), '#' comments; positions in the file's unit (objscan: mm).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "common/geometry.h"

namespace objscan {

struct StampedPose {
  double t = 0;  // s
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

// Reads a TUM trajectory. False with *error on an unreadable file or a malformed line.
bool ReadTumTrajectory(const std::string& path, std::vector<StampedPose>* poses, std::string* error);
// Writes a TUM trajectory (header comment lines first, each prefixed with "# ").
bool WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                        const std::vector<std::string>& header, std::string* error);

struct TrajectoryEvaluation {
  int num_estimated = 0;
  int num_truth = 0;
  int num_matched = 0;             // estimated poses with a true pose within max_dt
  double registered_fraction = 0;  // num_matched / num_truth
  TrajectoryError error;           // after Sim(3) (or SE(3)) alignment of the matched poses
};

// Pairs poses by timestamp (nearest, |dt| <= max_dt_s) and evaluates them.
bool EvaluateTumTrajectories(const std::vector<StampedPose>& estimated, const std::vector<StampedPose>& truth,
                             bool with_scale, double max_dt_s, TrajectoryEvaluation* out, std::string* error);

// Reads the vertices (x y z) of an ASCII or binary_little_endian PLY (float or double coordinates). With normals
// non-null, also the vertex normals (nx ny nz); false when the file has none.
bool ReadPlyPoints(const std::string& path, std::vector<Eigen::Vector3d>* points, std::string* error,
                   std::vector<Eigen::Vector3d>* normals = nullptr);

// Pinhole intrinsics of the views used to decide which part of a true surface was visible.
struct ViewIntrinsics {
  double fx = 800, fy = 800;      // px
  double cx = 319.5, cy = 239.5;  // px
  int width = 640, height = 480;  // px
};

// Indices of the surface points (with outward normals) seen by at least min_views of the cameras: in front of the
// camera, inside the image, facing it (cosine between normal and direction to the camera >= min_cos) and, with
// occlusion on, not hidden by the other points. Every camera gets a z-buffer of all points (nearest pixel, nearest
// camera-frame depth z); a point is hidden when its pixel holds a depth closer than its own by more than
// occlusion_tolerance (units of the points; 1.0 = 1 mm for objscan) + footprint × (1 + √2 · min(tan θ, 10)), with
// footprint = z / min(fx, fy) (a pixel's size at the point) and θ the angle between its normal and the direction to
// the camera: within one pixel a surface seen at a grazing angle spans that much depth and must not hide itself
// (points seen from behind, min_cos <= 0, get the bound 10). An occluder that close in depth is missed, and with
// points sparser than the pixels occluded points show through the gaps: in both cases the visible set is an
// over-estimate and completeness on it conservative. Without occlusion the set is exact only for convex objects.
// Points or normals with NaN are never visible. Units: the points', poses world_from_camera, intrinsics in px.
std::vector<int> VisibleSurfacePoints(const std::vector<Eigen::Vector3d>& points,
                                      const std::vector<Eigen::Vector3d>& normals,
                                      const std::vector<StampedPose>& cameras, const ViewIntrinsics& intrinsics,
                                      int min_views, double min_cos, bool occlusion = true,
                                      double occlusion_tolerance = 1.0);

struct SurfaceEvaluation {
  int num_model = 0;
  int num_truth = 0;
  double accuracy_p50 = 0, accuracy_p90 = 0, accuracy_max = 0;  // model -> truth distances
  double completeness = 0;  // fraction of truth points within completeness_threshold of the model
};

// Distances from every model point to the nearest truth point (accuracy) and the fraction of truth points that
// have a model point within completeness_threshold (completeness). Same unit as the inputs. Distances are
// point-to-point: the truth sample must be much denser than the accuracy measured (spacing adds to distances).
SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model, const std::vector<Eigen::Vector3d>& truth,
                                  double completeness_threshold);
// The same with separate truth sets: accuracy against accuracy_truth (the whole true surface: a model point on a
// part no camera saw is still on the surface), completeness over completeness_truth (the part that could be seen).
SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model,
                                  const std::vector<Eigen::Vector3d>& accuracy_truth,
                                  const std::vector<Eigen::Vector3d>& completeness_truth,
                                  double completeness_threshold);

}  // namespace objscan
