// Scene description of the robot simulator: a textured floor and textured objects (sphere, box, cylinder,
// triangle mesh from PLY/OBJ), loaded from a line-based text file, tessellated into triangles for the renderer.
// LCM-free. World frame: z up, floor z = 0, lengths in mm.
//
// Scene file format (one item per line, '#' starts a comment, keys are key=value without spaces, vectors are
// comma-separated; see README.md):
//   scene    seed=N background=b,g,r                       global settings (0..255 background colour)
//   light    direction=x,y,z ambient=A diffuse=D            direction TOWARDS the light (world), Lambert terms
//   floor    size=S texture=... seed=N texel_mm=T ...       square floor of side S mm centred at the origin
//   sphere   center=x,y,z radius=R ...
//   box      center=x,y,z size=sx,sy,sz yaw=deg ...
//   cylinder center=x,y,z radius=R height=H yaw=deg ...    axis along world z, center = middle of the axis
//   mesh     file=PATH center=x,y,z scale=k yaw=deg on_floor=true ...   PLY (ascii / binary_little_endian) or OBJ
//   robot    start=x,y,yaw_deg [pan=deg] [tilt=deg]          the robot's start pose in command mode (at most one line;
//                                                           tilt > 0 = looking down; defaults pan 0, tilt 25)
// Common object keys: name=, target=true|false, seed=N (texture), texture=leaves|noise|checker|solid,
//   texel_mm=T (mm per texel), texture_size=N (power of two), saturation=0..1, contrast=0..1, color=b,g,r (solid),
//   segments=N (tessellation, 0 = automatic from the chord tolerance).
// Exactly one object may carry target=true; without one, the first non-floor object is the target.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace objscan {

// RGB mip chain of a square power-of-two texture (wraps around in both directions).
struct Texture {
  struct Level {
    int size = 0;                  // texels per side
    std::vector<uint32_t> texels;  // row-major, packed R | G << 8 | B << 16
  };
  std::vector<Level> levels;  // level 0 = full resolution, each next level half the size, down to 1x1
};

// Builds the mip chain (2x2 box filter) of a square power-of-two BGR image (CV_8UC3). Throws std::invalid_argument
// for other sizes or types.
Texture MakeTexture(const cv::Mat& bgr);

struct TextureSpec {
  std::string kind = "leaves";  // leaves (multi-scale "dead leaves" shapes + fine noise), noise, checker, solid
  uint64_t seed = 1;            // RNG seed of the pattern
  double texel_mm = 0.5;        // mm per texel on the surface
  int size = 1024;              // texels per side (power of two, 16..4096)
  double saturation = 0.85;     // 0..1 colourfulness of the shapes
  double contrast = 1.0;        // 0..1 spread of the brightness
  Eigen::Vector3d color_bgr{128, 128, 128};  // 0..255, colour of texture=solid (and checker's second colour)
};

// Procedural, tileable texture (deterministic for a spec). CV_8UC3 BGR, spec.size x spec.size.
cv::Mat MakeProceduralTexture(const TextureSpec& spec);

// Triangles in world coordinates. Triangles wind counter-clockwise seen from outside (normal = (b-a)x(c-a)).
struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;  // mm, world
  std::vector<Eigen::Vector3f> normals;    // unit, world, per vertex (used for shading)
  std::vector<Eigen::Vector2f> uvs;        // texels of texture level 0
  std::vector<Eigen::Vector3i> triangles;  // vertex indices
  bool closed = false;                     // true: back faces may be culled (consistent outward winding)
};

// A mesh read from a file (object coordinates, no placement).
struct RawMesh {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3i> triangles;  // polygons are fan-triangulated
};

// Reads PLY (ascii or binary_little_endian; vertex x,y,z of any scalar type; face vertex_indices/vertex_index list)
// or Wavefront OBJ (v and f lines; v/vt/vn face syntax and negative indices). Chooses by extension (.ply/.obj).
// Returns false with *error for unreadable files, unsupported formats and out-of-range indices.
bool LoadMeshFile(const std::string& path, RawMesh* out, std::string* error);

// Writes a binary_little_endian PLY with float x y z [nx ny nz] and, when faces are given, int vertex_indices.
// normals may be empty. Returns false when the file cannot be written.
bool WritePly(const std::string& path, const std::vector<Eigen::Vector3f>& points,
              const std::vector<Eigen::Vector3f>& normals, const std::vector<Eigen::Vector3i>& faces,
              bool ascii = false);

enum class ShapeType { kFloor, kSphere, kBox, kCylinder, kMesh };

struct SceneObject {
  int id = 0;        // index in Scene::objects (file order); the renderer's object_id
  std::string name;  // from name= (default "<type><id>")
  ShapeType type = ShapeType::kSphere;
  bool is_target = false;
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  // world; mesh: centre of its placed bounding box
  double yaw_rad = 0;                                   // rotation about world z (box, cylinder, mesh)
  double radius_mm = 100;                               // sphere, cylinder
  double height_mm = 200;                               // cylinder
  Eigen::Vector3d size_mm{200, 200, 200};               // box extents (before yaw); floor uses size_mm.x()
  std::string mesh_path;                                // mesh file (resolved relative to the scene file)
  double mesh_scale = 1.0;                              // mesh file units times this = mm
  bool on_floor = true;                                 // mesh: lift so that its lowest point touches z = 0
  int segments = 0;                                     // tessellation segments around (0 = automatic)
  TextureSpec texture;
  RawMesh raw_mesh;   // mesh objects: the file's contents
  TriangleMesh mesh;  // tessellation in world coordinates
  std::shared_ptr<const Texture> texture_maps;
  Eigen::AlignedBox3d bounds;  // world bounding box of the tessellation

  // Resolved description line in the scene format (all parameters, including defaults).
  std::string Describe() const;
};

struct SceneLight {
  Eigen::Vector3d direction{0.3, 0.2, 1.0};  // world, towards the light (normalized on load)
  double ambient = 0.4;                      // ambient term
  double diffuse = 0.6;                      // Lambert term scale
};

// The robot's start pose from a scene's `robot` line (world frame; used by the command mode, ignored by the orbit).
struct RobotStart {
  double x_mm = 0, y_mm = 0;  // base centre on the floor, |x|, |y| <= kMaxCoordinateMm
  double theta_rad = 0;       // heading (yaw about world z; the line gives degrees in [-360, 360])
  double pan_rad = 0;         // head pan (> 0 = left), the line gives degrees in [-180, 180]
  double tilt_rad = 25.0 * 3.14159265358979323846 / 180.0;  // head tilt (> 0 = down), degrees in [-90, 90]
  static constexpr double kMaxCoordinateMm = 100000;
};

// An object's bounding box in its own yawed frame: box = its size, cylinder = 2r x 2r x h, sphere = 2r, mesh = the
// extents of its placed vertices along its yawed x and y axes and world z.
struct OrientedBox {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  // world
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();    // along the object's x, y (yawed) and world z
  double yaw_rad = 0;                                   // the object's yaw (0 for a sphere)
};
OrientedBox ObjectBox(const SceneObject& object);
// "floor", "sphere", "box", "cylinder" or "mesh".
const char* ShapeName(ShapeType type);

struct Scene {
  std::string path;                               // file it was loaded from ("" for text)
  uint64_t seed = 1;                              // scene seed (scene seed=; reported in scene.txt)
  Eigen::Vector3d background_bgr{190, 195, 200};  // 0..255, colour where no surface is hit
  SceneLight light;
  std::vector<SceneObject> objects;
  int target_index = -1;         // index of the target object
  bool has_robot_start = false;  // the file has a `robot` line
  RobotStart robot_start;        // valid when has_robot_start

  const SceneObject& target() const { return objects.at(static_cast<size_t>(target_index)); }
  // Centre of the target's bounding box (world mm).
  Eigen::Vector3d TargetCenter() const { return target().bounds.center(); }
  // The resolved scene description (scene, light, the robot line if any, one line per object), with a header
  // comment.
  std::string Describe() const;
};

// Parses a scene description. base_dir resolves relative mesh paths. Throws std::runtime_error naming the line on
// syntax errors, unknown types/keys, invalid values (non-finite, out of range), unreadable mesh files, several
// targets, several robot lines or no object.
Scene ParseScene(const std::string& text, const std::string& base_dir, const std::string& path = "");
// Reads and parses a scene file. Throws std::runtime_error (unreadable file or as ParseScene).
Scene LoadScene(const std::string& path);

// A point on an object's true surface with its outward normal (world).
struct SurfaceSample {
  Eigen::Vector3f position;  // mm, world
  Eigen::Vector3f normal;    // unit, outward
};

// Uniform random sample of the object's exact surface (analytic for sphere, box, cylinder; the triangles for a
// mesh) with on average points_per_mm2 points per mm^2 (deterministic for the seed). Points on or below the floor
// (z < 0.5 mm: faces resting on the floor, which no camera can see) are left out.
std::vector<SurfaceSample> SampleSurface(const SceneObject& object, double points_per_mm2, uint64_t seed);

// Small deterministic RNG helpers (same numbers on every platform, unlike std:: distributions).
class SimRng {
 public:
  explicit SimRng(uint64_t seed) : state_(seed * 0x9E3779B97F4A7C15ULL + 0x2545F4914F6CDD1DULL) {}
  uint64_t NextU64();
  double Uniform();  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  double Gaussian();  // N(0, 1), Box-Muller
 private:
  uint64_t state_;
};
// Mixes several values into one seed.
uint64_t MixSeed(uint64_t a, uint64_t b);

}  // namespace objscan
