// SceneRenderer: draws a ViewerState as a 3-D scene with OpenGL 3.3 core: floor grid and axes, estimated
// trajectory with camera frustums, ground-truth trajectory and the live error segment, landmarks (coloured by
// reprojection error, age or their own colour), the voxel model (cubes showing only the faces that can be seen —
// towards the eye and without a neighbouring voxel — or, when small or very many, points with level of detail and a
// CPU depth pass; see VoxelStyle), the target box and the robot from odometry. Voxel buffers are rebuilt only when the
// map, threshold or colouring change; per frame only the level choice and, for many points, the depth pass run.
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
// Auto also draws points while even the nearest voxel projects at most auto_points_px wide (a cube of a few pixels
// looks like a square, and costs several triangles). Any style: when even the nearest voxel projects smaller than
// lod_pixels, voxels are drawn as points of a coarser
// level of detail (2x2x2, 4x4x4, ... voxels merged into one cell, colour averaged) whose cells still project at most
// lod_pixels wide — the same picture with up to 8x fewer points per level.
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
  double lod_pixels =
      1.0;  // px, merged level-of-detail cells may project this wide at the model's nearest depth (0 = off)
  double auto_points_px = 3.0;  // px, auto style: points while voxels project at most this wide at the nearest depth
  // Points path with at least this many points (0 = never): a CPU depth pass over the points' pixel squares picks the
  // points that are nearest at one pixel or more and only those go to GL — the same picture, and software GL pays
  // per point (~0.25 us of CPU each on llvmpipe) far more than the pass does (~15 ns). Skipped for points wider than
  // max_occlusion_point_px.
  int64_t occlusion_min_points = 20000;
  double max_occlusion_point_px = 8.0;  // px, widest point (at the model's nearest depth) the CPU depth pass handles
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
  int64_t voxel_instances() const { return voxel_instances_; }  // of those, not fully enclosed
  int64_t voxels_drawn() const { return voxels_drawn_; }        // last frame: voxels or merged cells drawn
  int voxel_level() const { return voxel_level_; }              // last frame: level of detail (0 = voxels)
  bool voxels_as_points() const { return voxels_as_points_; }   // last frame drew voxels as points
  bool voxels_as_mesh() const { return voxels_as_mesh_; }       // last frame drew voxels as a static face mesh
  bool voxels_occlusion_culled() const { return voxels_occlusion_culled_; }  // last frame used the CPU depth pass

 private:
  // Point buffer of one level of detail: cells of 2^level voxels per side (level 0 = the voxels).
  struct PointLevel {
    unsigned vao = 0, vbo = 0, ebo = 0;  // ebo: indices of the visible points (CPU depth pass)
    int64_t count = 0;                   // cells (not fully enclosed)
    float half_size = 0;                 // mm, half the cell side
    std::vector<float> centers;          // mm, xyz per cell (CPU copy for the depth pass)
  };

  void UpdateVoxelInstances(const ViewerState& state, const SceneOptions& options);
  // Draws the voxel model (rebuilding its buffers when needed) as a face mesh, points or instanced cubes, per the
  // options and the level of detail; sets the last-frame voxel statistics. mvp: clip from world (mm).
  void DrawVoxels(const ViewerState& state, const OrbitView& view, const Viewport& viewport,
                  const SceneOptions& options, const Eigen::Matrix4f& mvp);
  // Draws one point level, through the CPU depth pass (VisiblePoints) when it is large and its points small enough.
  void DrawVoxelPoints(const PointLevel& level, const OrbitView& view, const Viewport& viewport,
                       const SceneOptions& options, const Eigen::Matrix4f& mvp);
  // Level of detail to draw this frame: the coarsest whose cells project at most lod_pixels at the model's nearest
  // depth; 0 when the voxels themselves are bigger or the eye is at or inside the model's bounds.
  // Also sets nearest_voxel_depth_mm_ and nearest_voxel_px_.
  int ChooseVoxelLevel(const OrbitView& view, const Viewport& viewport, const SceneOptions& options);
  // Indices of the points of `level` that are nearest at one pixel or more, as GL would draw them (square of the
  // point size around the projected centre, depth test LEQUAL in order), plus those whose centre lies outside the
  // clip volume's sides (GL's own business). False (and nothing) when a point is wider than max_point_px.
  bool VisiblePoints(const PointLevel& level, const Eigen::Matrix4f& mvp, const Viewport& viewport,
                     float pixels_per_unit, double max_point_px, std::vector<uint32_t>* visible);
  void DrawColored(const std::vector<float>& vertices, unsigned mode, float size);

  bool initialized_ = false;
  unsigned line_program_ = 0;
  unsigned voxel_program_ = 0;
  unsigned voxel_point_program_ = 0;
  int point_mvp_location_ = -1, point_half_size_location_ = -1, point_pixels_location_ = -1;
  bool voxels_as_points_ = false;
  unsigned line_vao_ = 0, line_vbo_ = 0;
  unsigned voxel_vao_ = 0, voxel_vbo_ = 0;
  std::vector<PointLevel> point_levels_;  // [0] = voxels; GL objects are kept when a map has fewer levels
  int voxel_levels_ = 0;                  // levels of the current map in point_levels_
  float voxel_bounds_min_[3] = {0, 0, 0}, voxel_bounds_max_[3] = {0, 0, 0};  // mm, box around the drawn voxels
  int64_t voxels_drawn_ = 0;
  int voxel_level_ = 0;
  double nearest_voxel_depth_mm_ = 0;  // last frame: depth of the model's nearest bounding-box corner
  double nearest_voxel_px_ = 0;        // last frame: voxel width in pixels there (0 = eye at or inside the model)
  bool voxels_occlusion_culled_ = false;
  struct OcclusionPixel {
    float depth;      // nearest point's depth (NDC z)
    uint32_t winner;  // its index
  };
  std::vector<OcclusionPixel> occlusion_pixels_;  // per viewport pixel, rows bottom-up (GL window coordinates)
  std::vector<uint32_t> occlusion_stamp_;         // per point: frame it was last listed
  std::vector<uint32_t> visible_points_;
  uint32_t occlusion_frame_ = 0;
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
