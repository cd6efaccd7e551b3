// The dense modeler's final phase and helpers shared by the node, the tests and the replay tools (LCM-free):
// matching tracks of two frames by id, extracting the seed voxels from the vote grid, carving, meshing and writing
// the model files.
#pragma once

#include <Eigen/Core>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/sensor_data.h"
#include "processes/dense_modeler/affine_dense.h"
#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/mesh_visibility.h"
#include "processes/dense_modeler/pair_matches.h"
#include "processes/dense_modeler/region_of_interest.h"
#include "processes/dense_modeler/space_carving.h"
#include "processes/dense_modeler/surface_extraction.h"
#include "processes/dense_modeler/voxel_votes.h"
#include "processes/dense_modeler/weak_surface_refit.h"

namespace objscan {

struct DenseModelOptions {
  AffineDenseOptions dense;         // dense pair matching
  PairMatchOptions pair_matches;    // the pair's own matches where the tracker left the object bare
  VoxelVoteOptions votes;           // vote grid
  SpaceCarvingOptions carving;      // final photometric carving
  int vote_threshold = 16;          // votes a voxel needs to seed the final model / appear on VOXEL_MAP (>= 1)
  bool carve = true;                // run space carving in the final phase
  RidgeOptions ridge;               // vote ridge extraction (surface_extraction.h)
  double floor_band_mm = 12.0;      // mm, ridge voxels lower than this above the region's floor that face up (normal
                                    // within floor_band_normal_deg of the floor normal) are floor, dropped (0 = off;
                                    // region with a floor): the region's hard floor clearance can
                                    // then stay low enough to keep the object's walls down to the floor
  double floor_band_normal_deg = 45.0;  // deg, see floor_band_mm, (0, 90)
  double crevice_band_mm = 14.0;  // mm, ridge voxels lower than this above the region's floor that face down (normal
                                  // more than crevice_normal_deg below the horizontal) are dropped (0 = off; region
                                  // with a floor): on an object resting on the floor that is the
                                  // crevice under its overhang, seen at grazing angles past the dark underside, where
                                  // the only dense points are chords of floor-junction triangles (the sim sphere's and
                                  // blob's 4-5.4 mm skirts; a wall standing on the floor is vertical and stays)
  double crevice_normal_deg = 30.0;         // deg, see crevice_band_mm, (0, 90)
  MeshVisibilityOptions visibility;  // removal of mesh parts no view sees (inner sheets)
  WeakRefitOptions weak_refit;       // weakly voted mesh vertices refitted to their strong neighbours' surface
                                     // (weak_surface_refit.h)
};

bool ValidateDenseModelOptions(const DenseModelOptions& options, std::string* why);

// Features present in both frames (same track id), in the order of frame a.
std::vector<PointMatch> MatchTracks(const TrackFrame& a, const TrackFrame& b);

// Median reprojection error (px) of the landmarks (track id -> world point, mm) whose tracks are in frame, seen from
// world_from_camera; *count (optional) gets how many took part. Landmarks behind the camera count as infinite.
// Returns 0 with *count 0 when none is in the frame. A pose from an older map (e.g. before the pose solver rescaled
// it) shows up as a large median.
double MedianLandmarkReprojectionPx(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                                    const TrackFrame& frame,
                                    const std::unordered_map<int64_t, Eigen::Vector3d>& landmarks, int* count);

// Wall time of the final phase's stages (s; for logs and benchmarks, never part of the model).
struct FinalPhaseTimes {
  double surface_s = 0;     // seeds and vote ridge
  double carving_s = 0;     // photometric space carving
  double meshing_s = 0;     // surface fit and mesh
  double visibility_s = 0;  // hidden mesh parts (mesh_visibility.h)
  double clean_up_s = 0;    // border rings, small pieces, weak vertices, voxels off the mesh
};

struct FinalModel {
  std::vector<CarvedVoxel> voxels;  // final voxels, sorted by (k, j, i)
  TriangleMesh mesh;
  SpaceCarvingStats carving;
  RidgeStats ridge;
  MeshVisibilityStats visibility;
  WeakRefitStats weak_refit;
  int64_t seeds = 0;                 // voxels over the vote threshold (inside the box)
  int64_t floor_band_dropped = 0;    // ridge voxels dropped as floor (floor_band_mm)
  int64_t crevice_band_dropped = 0;  // ridge voxels dropped as the crevice under an overhang (crevice_band_mm)
  FinalPhaseTimes times;
  int64_t voxels_without_mesh = 0;  // carved voxels dropped because the final mesh has no vertex near them
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();  // mm, world, of the final voxels (zero when empty)
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
};

// Seeds = voxels with votes >= threshold whose centre is inside region (when valid: box and floor half-space).
// Ridge voxels near the floor that face up are dropped as floor (floor_band_mm), those that face down as the crevice
// under an overhang (crevice_band_mm).
// The seeds' vote ridge (one voxel thick, oriented, sub-voxel points) is carved (when options.carve) and meshed
// through its points (open where unseen); mesh parts hidden from every view by the mesh itself are removed
// (mesh_visibility.h), then small mesh pieces; weakly voted vertices move onto the surface of their strong neighbours
// (weak_surface_refit.h), and the voxels keep only the surface the mesh kept (a mesh vertex within 1.5 voxels).
FinalModel BuildFinalModel(const VoxelVoteGrid& grid, const std::vector<CarvingView>& views,
                           const DenseModelOptions& options, const RegionOfInterest& region = RegionOfInterest());

struct ModelPaths {
  std::string voxels_ply, mesh_ply, octomap;
};

// Writes DIR/model_voxels.ply, DIR/model_mesh.ply, DIR/model.bt (creating DIR). False with *error on failure.
bool WriteModelFiles(const std::string& dir, const FinalModel& model, double voxel_size_mm, ScaleSource scale,
                     ModelPaths* paths, std::string* error);

// Downsamples a view by an integer factor (area average) and scales the camera accordingly
// (pixel centres: u' = (u + 0.5) / f - 0.5).
CarvingView MakeCarvingView(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                            const cv::Mat& image, int downsample);

}  // namespace objscan
