// Evaluation against ground truth (LCM-free): trajectories in TUM format and surfaces as point sets.
// TUM lines: "t tx ty tz qx qy qz qw" (camera-to-world), '#' comments; positions in the file's unit (objscan: mm).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/geometry.h"
#include "common/ply.h"  // ReadPlyPoints, ReadPlyMesh (the evaluation reads both)
#include "common/tum.h"  // StampedPose, ReadTumTrajectory, WriteTumTrajectory

namespace objscan {

struct TrajectoryEvaluation {
  int num_estimated = 0;
  int num_truth = 0;
  int num_matched = 0;             // estimated poses with a true pose within max_dt
  double registered_fraction = 0;  // num_matched / num_truth
  TrajectoryError error;           // after Sim(3) (or SE(3)) alignment of the matched poses
  std::vector<double> matched_t_s;       // s, time of each matched estimated pose, in the estimate's order
  std::vector<double> matched_error;     // position error of that pose after the alignment (input unit)
};

// Pairs poses by timestamp (nearest, |dt| <= max_dt_s) and evaluates them.
bool EvaluateTumTrajectories(const std::vector<StampedPose>& estimated, const std::vector<StampedPose>& truth,
                             bool with_scale, double max_dt_s, TrajectoryEvaluation* out, std::string* error);

// Exact distance from a point to a triangle mesh (the nearest point of any of its triangles), over a uniform grid
// of the triangles (cells about twice the mean edge): exact, not an approximation by samples. Triangles with an
// index out of range or a non-finite vertex are ignored. Units: those of the vertices.
class MeshDistance {
 public:
  MeshDistance(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles);
  // Infinity for an empty mesh or a non-finite q.
  double Distance(const Eigen::Vector3d& q) const;
  bool empty() const { return triangles_.empty(); }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const;
  static uint64_t Key(const Eigen::Vector3i& c);
  double TriangleDistance(const Eigen::Vector3d& q, int i) const;
  std::vector<Eigen::Vector3d> vertices_;
  std::vector<Eigen::Vector3i> triangles_;
  double cell_ = 1.0;
  Eigen::Vector3i bounds_lo_ = Eigen::Vector3i::Zero(), bounds_hi_ = Eigen::Vector3i::Zero();  // cells
  std::unordered_map<uint64_t, std::vector<int>> cells_;  // triangles whose bounding box touches the cell
};

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
// distances (optional) receives every model point's distance, in model order.
SurfaceEvaluation EvaluateSurface(const std::vector<Eigen::Vector3d>& model,
                                  const std::vector<Eigen::Vector3d>& accuracy_truth,
                                  const std::vector<Eigen::Vector3d>& completeness_truth, double completeness_threshold,
                                  std::vector<double>* distances = nullptr);

// Accuracy as the exact distance from every model point to the true surface (truth_mesh: the surface the simulator
// rendered), completeness as in EvaluateSurface (truth points within completeness_threshold of a model point). The
// point-to-sample accuracy of EvaluateSurface carries the samples' spacing: with 1 random sample per mm^2 a model
// lying exactly on the surface scores p50 0.47, p90 0.86 and, over 10^5 points, max ~1.9 (mm). distances (optional)
// receives every model point's distance, in model order (e.g. to see where the errors are).
SurfaceEvaluation EvaluateSurfaceToMesh(const std::vector<Eigen::Vector3d>& model, const MeshDistance& truth_mesh,
                                        const std::vector<Eigen::Vector3d>& completeness_truth,
                                        double completeness_threshold, std::vector<double>* distances = nullptr);

// The first array of n numbers under "key" in a JSON text (objscan's own files: target.json, sim_outcome.json):
// `"key": [a, b, c]` or `"key": a` (n = 1). False when the key is missing or its value is not n finite numbers.
bool JsonNumbers(const std::string& json_text, const std::string& key, int n, std::vector<double>* values);

struct TargetEvaluation {
  double center_error_mm = 0;       // |estimated centre (aligned) - true centre|
  double center_error_xy_mm = 0;    // the same on the floor (x, y)
  Eigen::Vector3d center_aligned_mm = Eigen::Vector3d::Zero();  // estimated centre in the truth frame
  Eigen::Vector3d size_error_mm = Eigen::Vector3d::Zero();  // estimated - true extents (scaled by the alignment):
                                                            // the larger floor extent, the smaller, the height
};

// Compares an object finder's box (centre, extents along its own axes, world mm) with the true one after mapping
// the estimate by truth_from_estimate (the Sim(3) of the trajectories' alignment; identity when none). The floor
// extents are compared larger with larger (box yaw conventions differ by 90 degrees), the heights directly.
TargetEvaluation EvaluateTarget(const Eigen::Vector3d& center_mm, const Eigen::Vector3d& size_mm,
                                const Eigen::Vector3d& true_center_mm, const Eigen::Vector3d& true_size_mm,
                                const Sim3& truth_from_estimate);

// The true box the estimate describes: the extents of the true surface's vertices (truth frame, mm) along the axes of
// a box turned by yaw_rad about +z (truth frame), and its centre. A box's centre depends on its yaw for any shape but
// a box, cylinder or sphere: an irregular mesh's world-axis bounds are centred 25 mm from the bounds along the yaw
// the object finder chose (room_07, 7 Dec). False when there are no vertices.
bool TrueBoxAtYaw(const std::vector<Eigen::Vector3d>& true_vertices_mm, double yaw_rad, Eigen::Vector3d* center_mm,
                  Eigen::Vector3d* size_mm);

// The estimated box's yaw (about +z of the estimate's frame) in the truth frame: its x axis mapped by the
// alignment's rotation, projected onto the floor.
double YawInTruthFrame(double yaw_rad, const Sim3& truth_from_estimate);

}  // namespace objscan
