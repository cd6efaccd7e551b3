// Photometric space carving of a voxel set (LCM-free).
// The seed voxels (e.g. those over the vote threshold) are carved iteratively: in each pass the surface voxels
// (at least one empty 6-neighbour) are projected into every view; visibility comes from a per-view z-buffer of the
// current surface voxels (each voxel splatted over its projected footprint) and, optionally, from the voxel's
// outward normal (sum of directions to its empty 6-neighbours; isolated voxels count as facing every view) facing
// the camera. Surface voxels seen by at least
// min_views views whose colour standard deviation across those views exceeds max_color_stddev are removed; passes
// repeat until nothing changes (or less than min_removed_fraction of the seeds) or max_iterations. Kept voxels get the
// mean colour of the views that see them. Voxel (i, j, k) has its centre at (i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm
// (world, mm). Views may be downsampled: the camera must describe the image as stored. Distortion is honoured via
// PinholeCamera::Project. Never throws; views with an empty image or a camera/image size mismatch are ignored.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "processes/dense_modeler/voxel_votes.h"

namespace objscan {

struct CarvingView {
  PinholeCamera camera;  // intrinsics of image as stored (scaled when downsampled)
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  cv::Mat image;                                                        // CV_8UC3 BGR or CV_8UC1
};

struct SpaceCarvingOptions {
  double max_color_stddev = 20.0;       // gray levels, RMS over B, G, R of the per-channel std-dev across views
  int min_views = 3;                    // a voxel is judged only when this many views see it (>= 2)
  int max_iterations = 8;               // carving passes (>= 1)
  double min_removed_fraction = 0.001;  // passes stop once one removes fewer than this fraction of the seeds (the
                                        // rest is stable: on the sim orbits 169, 36, 7, 1, 0 of 30 000), [0, 1)
  double depth_tolerance_voxels = 1.0;  // voxel sizes behind the z-buffer depth still counted as visible (> 0)
  double footprint_scale = 1.0;         // splat half-size = scale * 0.87 * voxel projected size (> 0)
  bool use_normals = true;              // also require the voxel's outward normal to face the camera
  double min_normal_cos = 0.0;          // cos of the largest angle between the normal and the view ray
};

bool ValidateSpaceCarvingOptions(const SpaceCarvingOptions& options, std::string* why);

struct CarvedVoxel {
  Eigen::Vector3i ijk = Eigen::Vector3i::Zero();
  int32_t votes = 0;                            // copied from the seed
  std::array<uint8_t, 3> bgr{{128, 128, 128}};  // mean colour over the views that see it (seed colour if none)
  int32_t views = 0;                            // views that saw it in the last pass that evaluated it
  float color_stddev = 0;                       // gray levels, in that pass
};

struct SpaceCarvingStats {
  int iterations = 0;
  int64_t seeds = 0;
  int64_t removed = 0;
  int64_t kept = 0;
  std::vector<int64_t> removed_per_iteration;
  int64_t projections = 0;  // voxel-view projections done (cost measure)
};

// Carves the seeds (duplicates are merged). Result sorted by (k, j, i). seed_normals (optional, one per seed,
// outward unit vectors) replace the normals estimated from the empty 6-neighbours: a one-voxel-thin surface has
// empty neighbours on both sides, so its normals must come from elsewhere (e.g. ExtractVoteRidge).
std::vector<CarvedVoxel> CarveVoxels(const std::vector<VoxelRecord>& seeds, double voxel_size_mm,
                                     const std::vector<CarvingView>& views, const SpaceCarvingOptions& options,
                                     SpaceCarvingStats* stats = nullptr,
                                     const std::vector<Eigen::Vector3d>* seed_normals = nullptr);

}  // namespace objscan
