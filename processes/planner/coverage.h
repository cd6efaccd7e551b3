// CoverageModel: which parts of the target's surface have been seen well enough for the dense model, LCM-free.
// Surface samples (rebuilt by Update() when the target or the voxels changed):
//   - the dense model's voxel centres inside the target box grown by region_margin_mm, at least floor_clearance_mm
//     above the floor, thinned to one sample (their mean) per sample_mm cube; normal = the smallest principal axis
//     of the voxel centres within 1.5 sample_mm, oriented away from the box centre (the direction from the centre
//     when fewer than 4 neighbours);
//   - samples of the target box's top and four sides (sample_mm apart, face normals; the bottom and anything lower
//     than floor_clearance_mm left out) that have no voxel sample within 1.5 sample_mm: surface the model has not
//     got yet (a box top never seen) counts as uncovered.
// A camera pose sees a sample when the sample projects into the image (image_margin_px inside), lies within
// max_range_mm, and the angle between its normal and the direction to the camera is <= max_incidence_deg (the
// normal test also stands in for occlusion by the target itself). Views: camera poses kept when the camera moved
// >= min_view_step_mm or turned >= min_view_turn_deg since the last kept one. A sample is covered when >=
// views_needed kept views see it. Fraction = covered / samples (0 without samples).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "processes/planner/planner_geometry.h"

namespace objscan {

// The target's box in world: centre (mm), extents along its own axes (mm), rotation about world z (rad).
struct TargetBox {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();
  double yaw_rad = 0;
  bool IsValid() const;  // finite, sizes > 0
};

// Voxel centres of the dense model (world, mm).
struct VoxelCloud {
  double voxel_size_mm = 0;
  std::vector<Eigen::Vector3d> centres_mm;
};

struct CoverageOptions {
  double sample_mm = 20;           // mm, spacing of the surface samples
  double max_incidence_deg = 60;   // deg, largest angle between a sample's normal and the view direction
  int views_needed = 2;            // kept views that must see a sample for it to be covered
  double max_range_mm = 2000;      // mm, views farther from a sample do not count
  double image_margin_px = 10;     // px
  double region_margin_mm = 60;    // mm, voxels within the target box grown by this are the target's
  double floor_clearance_mm = 10;  // mm, samples lower than this above the floor are not counted
  double min_view_step_mm = 20;    // mm, camera motion that makes a new view ...
  double min_view_turn_deg = 3;    // deg, ... or camera rotation
};

struct SurfaceSample {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, pointing out of the target
  bool from_box = false;                              // a box-face sample (no voxel there yet)
  int views = 0;                                      // kept views that see it (counted up to views_needed)
};

// A camera pose prepared for visibility tests.
struct CameraView {
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  static CameraView From(const Eigen::Isometry3d& world_from_camera);
};

class CoverageModel {
 public:
  explicit CoverageModel(const CoverageOptions& options = {});

  void SetCamera(const CameraIntrinsics& camera);
  // A target that moved less than 5 mm (and changed size less than 5 mm) keeps the samples.
  void SetTarget(const TargetBox& box);
  void SetVoxels(const VoxelCloud& voxels);
  // Keeps the pose as a view when it moved or turned enough since the last kept one; true when kept.
  bool AddView(const Eigen::Isometry3d& world_from_camera);
  // Rebuilds the samples when the target or the voxels changed, then counts the views not yet counted.
  void Update();

  bool has_target() const { return has_target_; }
  const TargetBox& target() const { return target_; }
  const std::vector<SurfaceSample>& samples() const { return samples_; }
  int num_samples() const { return static_cast<int>(samples_.size()); }
  int num_covered() const;
  double Fraction() const;
  int num_views() const { return static_cast<int>(views_.size()); }
  const CameraIntrinsics& camera() const { return camera_; }
  const CoverageOptions& options() const { return options_; }

  bool Sees(const CameraView& view, const SurfaceSample& sample) const;
  // Samples not yet covered that the view would see.
  int CountUncoveredSeen(const CameraView& view) const;
  // Mean position of the uncovered samples (the box centre when none).
  Eigen::Vector3d UncoveredCentroid() const;

 private:
  void RebuildSamples();

  CoverageOptions options_;
  double cos_max_incidence_ = 0.5;
  CameraIntrinsics camera_;
  bool has_target_ = false;
  TargetBox target_;
  VoxelCloud voxels_;
  bool samples_dirty_ = false;
  std::vector<SurfaceSample> samples_;
  std::vector<CameraView> views_;
  size_t views_counted_ = 0;  // views already counted into samples_
};

}  // namespace objscan
