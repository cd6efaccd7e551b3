// SceneRenderer: draws a ViewerState as a 3-D scene with OpenGL 3.3 core: floor grid and axes, estimated
// trajectory with camera frustums, ground-truth trajectory and the live error segment, landmarks (coloured by
// reprojection error, age or their own colour), the voxel model as instanced cubes (only the faces that can be seen:
// faces towards the eye and without a neighbouring voxel), the target box and the robot from odometry.
// Requires a current OpenGL >= 3.3 core context for Init(), Render() and destruction. Does not throw.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/robot_model.h"
#include "viewer/view_camera.h"
#include "viewer/viewer_state.h"

namespace objscan {

// Fixed colours (RGB 0..255), also used by the screenshot tests.
struct Rgb {
  uint8_t r, g, b;
};
inline constexpr Rgb kBackgroundColor{34, 36, 42};
inline constexpr Rgb kEstimatedTrajectoryColor{255, 160, 0};
inline constexpr Rgb kGroundTruthTrajectoryColor{0, 200, 255};
inline constexpr Rgb kErrorSegmentColor{255, 40, 200};
inline constexpr Rgb kGridColor{70, 72, 80};

enum class LandmarkColoring { kReprojectionError, kAge, kRgb };
enum class VoxelColoring { kRgb, kVotes };
// Cubes: instanced cubes. Points: one square per voxel sized like the voxel (fast for huge models).
// Cubes are drawn as one static mesh of the exposed faces while it has at most max_mesh_faces faces, else as
// instanced cubes. Auto: like cubes, but points when the mesh is too big and more than max_cube_instances voxels show.
enum class VoxelStyle { kAuto, kCubes, kPoints };

struct SceneLayers {
  bool grid = true;          // floor grid (z = 0)
  bool axes = true;          // world axes at the origin (x red, y green, z blue)
  bool estimated = true;     // estimated trajectory
  bool frustums = true;      // camera frustums along the estimated trajectory
  bool ground_truth = true;  // ground-truth trajectory
  bool error = true;         // segment between the newest estimate and its truth
  bool landmarks = true;     // sparse points
  bool voxels = true;        // dense model
  bool target = true;        // target box
  bool robot = true;         // robot from odometry
};

struct SceneOptions {
  SceneLayers layers;
  int min_votes = 0;               // voxels with fewer votes are hidden (display threshold)
  bool cull_hidden_voxels = true;  // skip faces shared with a neighbouring shown voxel
  VoxelColoring voxel_coloring = VoxelColoring::kRgb;
  VoxelStyle voxel_style = VoxelStyle::kAuto;
  int64_t max_cube_instances = 100000;  // auto style: draw points above this many visible voxels
  int64_t max_mesh_faces = 300000;      // cubes as one static mesh of exposed faces up to this many faces
  LandmarkColoring landmark_coloring = LandmarkColoring::kReprojectionError;
  double max_reprojection_error_px = 3.0;  // px, error mapped to full red
  double max_landmark_age_frames = 300;    // frames since first listed, mapped to the end of the ramp
  float landmark_point_size_px = 4.0f;     // px
  int frustum_every = 15;                  // draw a frustum every N estimated poses (plus the newest)
  double frustum_depth_mm = 60.0;          // mm, frustum depth
  double grid_spacing_mm = 100.0;          // mm
  double grid_extent_mm = 2000.0;          // mm, half width of the grid square around the origin
  double axes_length_mm = 300.0;           // mm
  float trajectory_line_width_px = 2.0f;   // px (clamped to what the driver supports)
  RobotGeometry robot;                     // for drawing the head and camera from odometry
};

class SceneRenderer {
 public:
  SceneRenderer() = default;
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // Compiles shaders and creates buffers. False with *error when GL fails.
  bool Init(std::string* error);
  // Clears the viewport (window pixels, top-left origin, of a framebuffer framebuffer_height rows high) and draws.
  void Render(const ViewerState& state, const OrbitView& view, const Viewport& viewport, int framebuffer_height,
              const SceneOptions& options);

  int64_t voxels_shown() const { return voxels_shown_; }        // voxels at or over the threshold
  int64_t voxel_instances() const { return voxel_instances_; }  // of those, drawn (not fully enclosed)
  bool voxels_as_points() const { return voxels_as_points_; }   // last frame drew voxels as points
  bool voxels_as_mesh() const { return voxels_as_mesh_; }       // last frame drew voxels as a static face mesh

 private:
  void UpdateVoxelInstances(const ViewerState& state, const SceneOptions& options);
  void DrawColored(const std::vector<float>& vertices, unsigned mode, float size);

  bool initialized_ = false;
  unsigned line_program_ = 0;
  unsigned voxel_program_ = 0;
  unsigned voxel_point_program_ = 0;
  int point_mvp_location_ = -1, point_half_size_location_ = -1, point_pixels_location_ = -1;
  bool voxels_as_points_ = false;
  unsigned line_vao_ = 0, line_vbo_ = 0;
  unsigned voxel_vao_ = 0, voxel_vbo_ = 0, voxel_point_vao_ = 0;
  unsigned voxel_mesh_vao_ = 0, voxel_mesh_vbo_ = 0;
  int64_t voxel_mesh_vertices_ = 0;
  bool voxels_as_mesh_ = false;
  int line_mvp_location_ = -1, line_point_size_location_ = -1;
  int voxel_mvp_location_ = -1, voxel_eye_location_ = -1, voxel_half_size_location_ = -1;
  // Cache key of the voxel instance buffer.
  int64_t voxel_version_ = -1;
  int voxel_min_votes_ = -1;
  bool voxel_cull_ = false;
  VoxelColoring voxel_coloring_ = VoxelColoring::kRgb;
  int64_t voxels_shown_ = 0;
  int64_t voxel_instances_ = 0;
  float voxel_half_size_ = 0;
  float max_line_width_ = 1.0f;
};

}  // namespace objscan
