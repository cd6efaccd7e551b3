#include "viewer/scene_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <unordered_set>

#include "objscan/pose_t.hpp"
#include "objscan/target_t.hpp"
#include "viewer/gl.h"

namespace objscan {
namespace {

const char* kLineVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 color;
uniform mat4 mvp;
uniform float point_size;
out vec3 v_color;
void main() {
  gl_Position = mvp * vec4(position, 1.0);
  gl_PointSize = point_size;
  v_color = color;
}
)";

const char* kColorFragmentShader = R"(#version 330 core
in vec3 v_color;
out vec4 frag_color;
void main() { frag_color = vec4(v_color, 1.0); }
)";

// One instance per voxel, 18 vertices: the three faces that face the eye (a face of a box is visible exactly when
// the eye is on its outer side). Faces whose neighbour voxel is shown are collapsed outside the clip volume.
const char* kVoxelVertexShader = R"(#version 330 core
layout(location = 0) in vec3 center;
layout(location = 1) in vec3 color;
layout(location = 2) in int neighbours;  // bits: +x -x +y -y +z -z
uniform mat4 mvp;
uniform vec3 eye;
uniform float half_size;
out vec3 v_color;
const vec2 kQuad[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
void main() {
  int face = gl_VertexID / 6;
  vec2 q = kQuad[gl_VertexID % 6];
  vec3 d = eye - center;
  vec3 s = vec3(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0, d.z >= 0.0 ? 1.0 : -1.0);
  vec3 p;
  int bit;
  float shade;
  if (face == 0) { p = vec3(s.x, q.x, q.y); bit = s.x > 0.0 ? 1 : 2; shade = 0.80; }
  else if (face == 1) { p = vec3(q.x, s.y, q.y); bit = s.y > 0.0 ? 4 : 8; shade = 0.64; }
  else { p = vec3(q.x, q.y, s.z); bit = s.z > 0.0 ? 16 : 32; shade = s.z > 0.0 ? 1.0 : 0.45; }
  if ((neighbours & bit) != 0) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
  } else {
    gl_Position = mvp * vec4(center + half_size * p, 1.0);
  }
  v_color = color * shade;
}
)";

// Large or distant models: one screen-aligned square per voxel (or merged cell), sized like it at its depth. In
// software GL a point costs a fraction of a cube; the colour is flat (no interpolation set-up per point).
const char* kVoxelPointVertexShader = R"(#version 330 core
layout(location = 0) in vec3 center;
layout(location = 1) in vec3 color;
uniform mat4 mvp;
uniform float half_size;
uniform float pixels_per_unit;  // projection(1,1) * viewport height / 2
flat out vec3 v_color;
void main() {
  gl_Position = mvp * vec4(center, 1.0);
  gl_PointSize = max(1.0, 2.0 * half_size * pixels_per_unit / max(gl_Position.w, 1e-3));
  v_color = color;
}
)";

const char* kFlatColorFragmentShader = R"(#version 330 core
flat in vec3 v_color;
out vec4 frag_color;
void main() { frag_color = vec4(v_color, 1.0); }
)";

unsigned Compile(unsigned type, const char* source, std::string* error) {
  const unsigned shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
    if (error) *error = std::string("shader: ") + log;
    glDeleteShader(shader);
    return 0;
  }
  return shader;
}

unsigned Link(const char* vertex, const char* fragment, std::string* error) {
  const unsigned vs = Compile(GL_VERTEX_SHADER, vertex, error);
  const unsigned fs = Compile(GL_FRAGMENT_SHADER, fragment, error);
  if (vs == 0 || fs == 0) return 0;
  const unsigned program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(program, sizeof(log), nullptr, log);
    if (error) *error = std::string("link: ") + log;
    glDeleteProgram(program);
    return 0;
  }
  return program;
}

struct Color {
  float r, g, b;
};
Color ToColor(Rgb c) { return {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f}; }

// Green -> yellow -> red for t in [0, 1].
Color Ramp(double t) {
  t = std::clamp(t, 0.0, 1.0);
  if (t < 0.5) return {static_cast<float>(2 * t), 0.9f, 0.1f};
  return {1.0f, static_cast<float>(0.9 * (2 - 2 * t)), 0.1f};
}

class VertexList {
 public:
  void Add(const Eigen::Vector3d& p, Color c) {
    data_.insert(data_.end(),
                 {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()), c.r, c.g, c.b});
  }
  void Segment(const Eigen::Vector3d& a, const Eigen::Vector3d& b, Color c) {
    Add(a, c);
    Add(b, c);
  }
  void Clear() { data_.clear(); }
  const std::vector<float>& data() const { return data_; }

 private:
  std::vector<float> data_;
};

void AddFrustum(VertexList* lines, const Eigen::Isometry3d& world_from_camera, const PinholeCamera* camera,
                double depth_mm, Color color) {
  double half_w = 0.5 / 0.8, half_h = 0.375 / 0.8;  // 4:3 with fx = 0.8 width when the calibration is unknown
  if (camera != nullptr && camera->fx > 0 && camera->fy > 0) {
    half_w = 0.5 * camera->width / camera->fx;
    half_h = 0.5 * camera->height / camera->fy;
  }
  const Eigen::Vector3d c = world_from_camera.translation();
  Eigen::Vector3d corners[4];
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int i = 0; i < 4; ++i)
    corners[i] = world_from_camera * Eigen::Vector3d(sx[i] * half_w * depth_mm, sy[i] * half_h * depth_mm, depth_mm);
  for (int i = 0; i < 4; ++i) {
    lines->Segment(c, corners[i], color);
    lines->Segment(corners[i], corners[(i + 1) % 4], color);
  }
  // A tick on the top edge (camera -y) shows which way is up in the image.
  lines->Segment(0.5 * (corners[0] + corners[1]),
                 world_from_camera * Eigen::Vector3d(0, -half_h * depth_mm * 1.4, depth_mm), color);
}

void AddBox(VertexList* lines, const Eigen::Isometry3d& world_from_box, const Eigen::Vector3d& half, Color color) {
  Eigen::Vector3d v[8];
  for (int i = 0; i < 8; ++i)
    v[i] = world_from_box *
           Eigen::Vector3d((i & 1 ? 1 : -1) * half.x(), (i & 2 ? 1 : -1) * half.y(), (i & 4 ? 1 : -1) * half.z());
  const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                            {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (const auto& e : edges) lines->Segment(v[e[0]], v[e[1]], color);
}

int64_t VoxelKey(int64_t i, int64_t j, int64_t k) {
  constexpr int64_t kOffset = 1 << 20, kMask = (1 << 21) - 1;
  return ((i + kOffset) & kMask) << 42 | ((j + kOffset) & kMask) << 21 | ((k + kOffset) & kMask);
}

// ceil for |v| < 2^30 without a libm call (x86-64 without SSE4.1 has no inline ceil).
int CeilToInt(float v) {
  const int t = static_cast<int>(v);  // rounds towards zero
  return t + (v > static_cast<float>(t) ? 1 : 0);
}

// Bits of the low 21 bits of v spread to every third bit.
uint64_t SpreadBits(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

uint64_t MortonKey(int64_t i, int64_t j, int64_t k) {
  constexpr int64_t kOffset = 1 << 20;
  return SpreadBits(static_cast<uint64_t>(i + kOffset)) | SpreadBits(static_cast<uint64_t>(j + kOffset)) << 1 |
         SpreadBits(static_cast<uint64_t>(k + kOffset)) << 2;
}

int64_t FloorHalf(int64_t i) { return i >= 0 ? i / 2 : (i - 1) / 2; }

// One vertex of a point buffer: cell centre (mm) and colour (RGBA 0..255), 16 bytes.
struct PointVertex {
  float x, y, z;
  uint8_t rgba[4];
};

// A cell of one level of detail with its colour sums: over the voxels that can be seen (not enclosed) and over all.
struct LodCell {
  uint64_t key;     // Morton key of the level-0 coordinates shifted right by 3 per level: one level up = key >> 3
  int64_t i, j, k;  // integer cell coordinates at its level
  float visible_rgb[3];
  int64_t visible;
  float all_rgb[3];
  int64_t all;
};

uint8_t ToByte(float c) { return static_cast<uint8_t>(std::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f); }

// A set of integer cells: a bitmap over their bounding box (fast, no allocation per cell) unless that box is huge,
// then a hash set.
class CellSet {
 public:
  template <class Cells, class Coords>
  CellSet(const Cells& cells, Coords coords) {
    if (cells.empty()) return;
    for (int a = 0; a < 3; ++a) {
      min_[a] = std::numeric_limits<int64_t>::max();
      max_[a] = std::numeric_limits<int64_t>::lowest();
    }
    for (const auto& cell : cells) {
      const std::array<int64_t, 3> c = coords(cell);
      for (int a = 0; a < 3; ++a) min_[a] = std::min(min_[a], c[a]), max_[a] = std::max(max_[a], c[a]);
    }
    for (int a = 0; a < 3; ++a) size_[a] = max_[a] - min_[a] + 1;
    constexpr int64_t kMaxBits = int64_t{1} << 28;  // 32 MB
    dense_ = size_[0] <= kMaxBits / size_[1] / size_[2];
    if (dense_)
      bits_.assign(static_cast<size_t>((size_[0] * size_[1] * size_[2] + 63) / 64), 0);
    else
      sparse_.reserve(cells.size() * 2);
    for (const auto& cell : cells) {
      const std::array<int64_t, 3> c = coords(cell);
      if (dense_) {
        const int64_t bit = Index(c[0], c[1], c[2]);
        bits_[bit >> 6] |= uint64_t{1} << (bit & 63);
      } else {
        sparse_.insert(VoxelKey(c[0], c[1], c[2]));
      }
    }
  }
  bool Has(int64_t i, int64_t j, int64_t k) const {
    if (!dense_) return sparse_.count(VoxelKey(i, j, k)) > 0;
    if (i < min_[0] || i > max_[0] || j < min_[1] || j > max_[1] || k < min_[2] || k > max_[2]) return false;
    const int64_t bit = Index(i, j, k);
    return (bits_[bit >> 6] >> (bit & 63) & 1) != 0;
  }

 private:
  int64_t Index(int64_t i, int64_t j, int64_t k) const {
    return ((i - min_[0]) * size_[1] + (j - min_[1])) * size_[2] + (k - min_[2]);
  }
  bool dense_ = true;
  int64_t min_[3] = {0, 0, 0}, max_[3] = {-1, -1, -1}, size_[3] = {0, 0, 0};
  std::vector<uint64_t> bits_;
  std::unordered_set<int64_t> sparse_;
};

// Point vertices of the cells of one level, in the cells' (Morton) order: neighbours in the buffer are neighbours in
// space and so on screen, which keeps the CPU depth pass's memory accesses local. Cells enclosed on all six sides
// are left out when cull is set; cells with a neighbour on top are drawn darker (their top face is hidden).
// cell_mm: cell side; origin: of cell (0, 0, 0).
std::vector<PointVertex> LevelPoints(const std::vector<LodCell>& cells, const double origin[3], double cell_mm,
                                     bool cull) {
  const CellSet occupied(cells, [](const LodCell& c) { return std::array<int64_t, 3>{c.i, c.j, c.k}; });
  std::vector<PointVertex> points;
  points.reserve(cells.size());
  for (const LodCell& c : cells) {
    auto has = [&](int di, int dj, int dk) { return occupied.Has(c.i + di, c.j + dj, c.k + dk); };
    const bool top = has(0, 0, 1);
    if (cull && top && has(1, 0, 0) && has(-1, 0, 0) && has(0, 1, 0) && has(0, -1, 0) && has(0, 0, -1)) continue;
    const float* sum = c.visible > 0 ? c.visible_rgb : c.all_rgb;
    const float n = static_cast<float>(c.visible > 0 ? c.visible : std::max<int64_t>(c.all, 1));
    const float shade = top ? 0.8f : 1.0f;
    points.push_back({static_cast<float>(origin[0] + (c.i + 0.5) * cell_mm),
                      static_cast<float>(origin[1] + (c.j + 0.5) * cell_mm),
                      static_cast<float>(origin[2] + (c.k + 0.5) * cell_mm),
                      {ToByte(sum[0] / n * shade), ToByte(sum[1] / n * shade), ToByte(sum[2] / n * shade), 255}});
  }
  return points;
}

// The next coarser level: 2x2x2 cells merged into one, colour sums added. cells sorted by key, so the (up to 8)
// cells of one merged cell are consecutive; the result is sorted by key too.
std::vector<LodCell> MergeCells(const std::vector<LodCell>& cells) {
  std::vector<LodCell> merged;
  merged.reserve(cells.size() / 2);
  for (const LodCell& c : cells) {
    if (merged.empty() || merged.back().key != c.key >> 3)
      merged.push_back({c.key >> 3, FloorHalf(c.i), FloorHalf(c.j), FloorHalf(c.k), {0, 0, 0}, 0, {0, 0, 0}, 0});
    LodCell& m = merged.back();
    for (int a = 0; a < 3; ++a) {
      m.visible_rgb[a] += c.visible_rgb[a];
      m.all_rgb[a] += c.all_rgb[a];
    }
    m.visible += c.visible;
    m.all += c.all;
  }
  return merged;
}

// Per shown voxel of the map (indices `shown`, coloured by votes relative to max_votes or by their own colour): its
// level-0 level-of-detail cell into *cells and, unless enclosed on all six sides by shown voxels (only checked with
// cull_hidden_voxels), its instance (centre mm, RGB 0..1, neighbour bits as a float) into *instances; bounds_min /
// bounds_max: box (mm, world) around the instances' cubes.
void BuildVoxelInstances(const voxel_map_t& map, const std::vector<size_t>& shown, int max_votes,
                         const SceneOptions& options, std::vector<float>* instances, std::vector<LodCell>* cells,
                         float bounds_min[3], float bounds_max[3]) {
  const CellSet occupied(options.cull_hidden_voxels ? shown : std::vector<size_t>(), [&map](size_t i) {
    return std::array<int64_t, 3>{map.ijk[i][0], map.ijk[i][1], map.ijk[i][2]};
  });
  std::vector<float>& buffer = *instances;
  buffer.reserve(shown.size() * 7);
  cells->reserve(shown.size());
  const double size = map.voxel_size_mm;
  for (int a = 0; a < 3; ++a) {
    bounds_min[a] = std::numeric_limits<float>::max();
    bounds_max[a] = std::numeric_limits<float>::lowest();
  }
  for (size_t i : shown) {
    const std::vector<int32_t>& ijk = map.ijk[i];
    Color c;
    if (options.voxel_coloring == VoxelColoring::kVotes) {
      c = Ramp(static_cast<double>(map.votes[i]) / max_votes);
    } else {
      c = {map.rgb[i][0] / 255.0f, map.rgb[i][1] / 255.0f, map.rgb[i][2] / 255.0f};
    }
    int bits = 0;
    if (options.cull_hidden_voxels) {
      const int d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
      for (int f = 0; f < 6; ++f)
        if (occupied.Has(int64_t{ijk[0]} + d[f][0], int64_t{ijk[1]} + d[f][1], int64_t{ijk[2]} + d[f][2]))
          bits |= 1 << f;
    }
    const bool enclosed = bits == 63;  // enclosed on all sides: never visible
    cells->push_back({MortonKey(ijk[0], ijk[1], ijk[2]),
                      ijk[0],
                      ijk[1],
                      ijk[2],
                      {enclosed ? 0 : c.r, enclosed ? 0 : c.g, enclosed ? 0 : c.b},
                      enclosed ? 0 : 1,
                      {c.r, c.g, c.b},
                      1});
    if (enclosed) continue;
    for (int a = 0; a < 3; ++a) {
      const float centre = static_cast<float>(map.origin_mm[a] + (ijk[a] + 0.5) * size);
      bounds_min[a] = std::min(bounds_min[a], centre - static_cast<float>(size / 2));
      bounds_max[a] = std::max(bounds_max[a], centre + static_cast<float>(size / 2));
    }
    float bits_as_float;
    static_assert(sizeof(bits_as_float) == sizeof(bits), "int/float size");
    std::memcpy(&bits_as_float, &bits, sizeof(bits));
    buffer.insert(buffer.end(),
                  {static_cast<float>(map.origin_mm[0] + (ijk[0] + 0.5) * size),
                   static_cast<float>(map.origin_mm[1] + (ijk[1] + 0.5) * size),
                   static_cast<float>(map.origin_mm[2] + (ijk[2] + 0.5) * size), c.r, c.g, c.b, bits_as_float});
  }
}

// Faces of the voxel instances (7 floats each, see BuildVoxelInstances) without a shown neighbour.
int64_t CountExposedFaces(const std::vector<float>& instances) {
  int64_t exposed_faces = 0;
  for (size_t v = 0; v < instances.size() / 7; ++v) {
    int bits;
    std::memcpy(&bits, &instances[v * 7 + 6], sizeof(bits));
    for (int f = 0; f < 6; ++f) exposed_faces += (bits >> f & 1) == 0;
  }
  return exposed_faces;
}

// Triangle mesh (6 floats per vertex: xyz mm, shaded RGB 0..1; counter-clockwise from outside) of the exposed faces
// of the voxel instances (cubes of side size_mm); exposed_faces (CountExposedFaces) only sizes the buffer.
std::vector<float> ExposedFaceMesh(const std::vector<float>& instances, double size_mm, int64_t exposed_faces) {
  // Face f: normal n, in-plane axes u, v with u x v = n (counter-clockwise seen from outside), shade.
  static const float kFace[6][3][3] = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
                                       {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}, {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
                                       {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}};
  static const float kShade[6] = {0.80f, 0.80f, 0.64f, 0.64f, 1.0f, 0.45f};
  static const float kCorner[6][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, -1}, {1, 1}, {-1, 1}};
  const float h = static_cast<float>(size_mm / 2);
  std::vector<float> mesh;
  mesh.reserve(static_cast<size_t>(exposed_faces) * 36);
  for (size_t v = 0; v < instances.size() / 7; ++v) {
    const float* in = &instances[v * 7];
    int bits;
    std::memcpy(&bits, &in[6], sizeof(bits));
    for (int f = 0; f < 6; ++f) {
      if (bits >> f & 1) continue;
      for (const auto& corner : kCorner) {
        for (int axis = 0; axis < 3; ++axis)
          mesh.push_back(in[axis] +
                         h * (kFace[f][0][axis] + corner[0] * kFace[f][1][axis] + corner[1] * kFace[f][2][axis]));
        for (int k = 0; k < 3; ++k) mesh.push_back(in[3 + k] * kShade[f]);
      }
    }
  }
  return mesh;
}

// Creates the vertex array, vertex buffer (PointVertex layout) and index buffer of one point level.
void CreatePointLevelArrays(unsigned* vao, unsigned* vbo, unsigned* ebo) {
  glGenVertexArrays(1, vao);
  glGenBuffers(1, vbo);
  glBindVertexArray(*vao);
  glBindBuffer(GL_ARRAY_BUFFER, *vbo);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(PointVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(PointVertex),
                        reinterpret_cast<void*>(offsetof(PointVertex, rgba)));
  glGenBuffers(1, ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, *ebo);  // part of the vertex array's state
  glBindVertexArray(0);
}

// Floor grid (z = 0) and world axes (mm), as enabled in the options.
void AddGridAndAxes(VertexList* lines, const SceneOptions& options) {
  if (options.layers.grid && options.grid_spacing_mm > 0) {
    const Color c = ToColor(kGridColor);
    const double e = options.grid_extent_mm;
    const int n = static_cast<int>(std::floor(e / options.grid_spacing_mm));
    for (int i = -n; i <= n; ++i) {
      const double t = i * options.grid_spacing_mm;
      lines->Segment({t, -e, 0}, {t, e, 0}, c);
      lines->Segment({-e, t, 0}, {e, t, 0}, c);
    }
  }
  if (options.layers.axes) {
    const double l = options.axes_length_mm;
    lines->Segment({0, 0, 0}, {l, 0, 0}, {0.95f, 0.2f, 0.2f});
    lines->Segment({0, 0, 0}, {0, l, 0}, {0.2f, 0.9f, 0.2f});
    lines->Segment({0, 0, 0}, {0, 0, l}, {0.3f, 0.4f, 1.0f});
  }
}

// Camera frustums along the estimated trajectory (every frustum_every-th pose, the newest twice as deep).
void AddTrajectoryFrustums(VertexList* lines, const ViewerState& state, const PinholeCamera* camera,
                           const SceneOptions& options) {
  const auto& trajectory = state.estimated_trajectory();
  const int every = std::max(options.frustum_every, 1);
  int index = 0;
  for (const auto& [seq, point] : trajectory) {
    if (index++ % every == 0)
      AddFrustum(lines, point.world_from_camera, camera, options.frustum_depth_mm, {0.75f, 0.6f, 0.35f});
  }
  AddFrustum(lines, trajectory.rbegin()->second.world_from_camera, camera, options.frustum_depth_mm * 2,
             ToColor(kEstimatedTrajectoryColor));
}

// The target box (world, mm), coloured by its state.
void AddTargetBox(VertexList* lines, const target_t& t) {
  Color c{0.6f, 0.6f, 0.6f};
  if (t.state == target_t::STATE_CANDIDATE) c = {1.0f, 0.9f, 0.2f};
  if (t.state == target_t::STATE_CONFIRMED) c = {0.2f, 1.0f, 0.3f};
  if (t.state == target_t::STATE_LOST) c = {1.0f, 0.25f, 0.25f};
  Eigen::Isometry3d world_from_box = Eigen::Isometry3d::Identity();
  world_from_box.translate(Eigen::Vector3d(t.center_mm[0], t.center_mm[1], t.center_mm[2]));
  world_from_box.rotate(Eigen::AngleAxisd(t.yaw_rad, Eigen::Vector3d::UnitZ()));
  AddBox(lines, world_from_box, 0.5 * Eigen::Vector3d(t.size_mm[0], t.size_mm[1], t.size_mm[2]), c);
}

// The robot at the odometry pose (world, mm): base box, heading, mast and the camera's frustum.
void AddRobot(VertexList* lines, const OdometryReading& o, const PinholeCamera* camera, const SceneOptions& options) {
  const Color c{0.85f, 0.85f, 0.9f};
  const Eigen::Isometry3d world_from_base = WorldFromBase(o.x_mm, o.y_mm, o.theta_rad);
  const double half_track = options.robot.wheel_base_mm / 2;
  AddBox(lines, world_from_base * Eigen::Translation3d(0, 0, 60), Eigen::Vector3d(half_track, half_track, 60), c);
  lines->Segment(world_from_base * Eigen::Vector3d(0, 0, 120),
                 world_from_base * Eigen::Vector3d(half_track * 1.5, 0, 120), {1.0f, 0.3f, 0.3f});
  const Eigen::Vector3d mast_foot(options.robot.mast_offset_x_mm, options.robot.mast_offset_y_mm, 120);
  const Eigen::Vector3d mast_top(options.robot.mast_offset_x_mm, options.robot.mast_offset_y_mm,
                                 options.robot.mast_height_mm);
  lines->Segment(world_from_base * mast_foot, world_from_base * mast_top, c);
  AddFrustum(lines, WorldFromCamera(options.robot, o.x_mm, o.y_mm, o.theta_rad, o.pan_rad, o.tilt_rad), camera,
             options.frustum_depth_mm * 1.5, c);
}

// A trajectory's camera positions joined by segments, mapped by transform into the drawn frame (mm).
void AddPath(VertexList* lines, const std::map<int64_t, TrajectoryPoint>& path, Color c, const Sim3& transform) {
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  bool first = true;
  for (const auto& entry : path) {
    const Eigen::Vector3d p = transform * entry.second.world_from_camera.translation();
    if (!first) lines->Segment(previous, p, c);
    previous = p;
    first = false;
  }
}

// Ground-truth and estimated trajectories and the newest error segment, in the estimate's frame (mm).
void AddTrajectories(VertexList* lines, const ViewerState& state, const SceneOptions& options) {
  // The truth is drawn in the estimate's frame (ViewerState::estimate_from_truth).
  if (options.layers.ground_truth)
    AddPath(lines, state.ground_truth_trajectory(), ToColor(kGroundTruthTrajectoryColor), state.estimate_from_truth());
  if (options.layers.estimated)
    AddPath(lines, state.estimated_trajectory(), ToColor(kEstimatedTrajectoryColor), Sim3());
  if (options.layers.error && state.latest_error_seq() >= 0) {
    const auto est = state.estimated_trajectory().find(state.latest_error_seq());
    const auto gt = state.ground_truth_trajectory().find(state.latest_error_seq());
    if (est != state.estimated_trajectory().end() && gt != state.ground_truth_trajectory().end())
      lines->Segment(est->second.world_from_camera.translation(),
                     state.estimate_from_truth() * gt->second.world_from_camera.translation(),
                     ToColor(kErrorSegmentColor));
  }
}

// One point per landmark (world, mm), coloured by reprojection error, age or its own colour.
void AddLandmarks(VertexList* points, const ViewerState& state, const landmarks_t& lm, const SceneOptions& options) {
  const size_t n = std::min({static_cast<size_t>(std::max(lm.num_landmarks, 0)), lm.position_mm.size(),
                             lm.reprojection_error_px.size(), lm.rgb.size(), lm.id.size()});
  for (size_t i = 0; i < n; ++i) {
    Color c;
    switch (options.landmark_coloring) {
      case LandmarkColoring::kReprojectionError:
        c = Ramp(lm.reprojection_error_px[i] / std::max(options.max_reprojection_error_px, 1e-6));
        break;
      case LandmarkColoring::kAge: {
        const int64_t first = state.LandmarkFirstSeq(lm.id[i]);
        const double age = first < 0 ? 0.0 : static_cast<double>(lm.seq - first);
        c = Ramp(1.0 - age / std::max(options.max_landmark_age_frames, 1.0));  // new = red, old = green
        break;
      }
      case LandmarkColoring::kRgb:
        c = {lm.rgb[i][0] / 255.0f, lm.rgb[i][1] / 255.0f, lm.rgb[i][2] / 255.0f};
        break;
    }
    points->Add(Eigen::Vector3d(lm.position_mm[i][0], lm.position_mm[i][1], lm.position_mm[i][2]), c);
  }
}

}  // namespace

SceneRenderer::~SceneRenderer() {
  if (!initialized_) return;
  glDeleteProgram(line_program_);
  glDeleteProgram(voxel_program_);
  glDeleteProgram(voxel_point_program_);
  glDeleteBuffers(1, &line_vbo_);
  glDeleteBuffers(1, &voxel_vbo_);
  glDeleteVertexArrays(1, &line_vao_);
  glDeleteVertexArrays(1, &voxel_vao_);
  for (PointLevel& level : point_levels_) {
    glDeleteVertexArrays(1, &level.vao);
    glDeleteBuffers(1, &level.vbo);
    glDeleteBuffers(1, &level.ebo);
  }
  glDeleteVertexArrays(1, &voxel_mesh_vao_);
  glDeleteBuffers(1, &voxel_mesh_vbo_);
}

bool SceneRenderer::Init(std::string* error) {
  line_program_ = Link(kLineVertexShader, kColorFragmentShader, error);
  voxel_program_ = Link(kVoxelVertexShader, kColorFragmentShader, error);
  voxel_point_program_ = Link(kVoxelPointVertexShader, kFlatColorFragmentShader, error);
  if (line_program_ == 0 || voxel_program_ == 0 || voxel_point_program_ == 0) return false;
  point_mvp_location_ = glGetUniformLocation(voxel_point_program_, "mvp");
  point_half_size_location_ = glGetUniformLocation(voxel_point_program_, "half_size");
  point_pixels_location_ = glGetUniformLocation(voxel_point_program_, "pixels_per_unit");
  line_mvp_location_ = glGetUniformLocation(line_program_, "mvp");
  line_point_size_location_ = glGetUniformLocation(line_program_, "point_size");
  voxel_mvp_location_ = glGetUniformLocation(voxel_program_, "mvp");
  voxel_eye_location_ = glGetUniformLocation(voxel_program_, "eye");
  voxel_half_size_location_ = glGetUniformLocation(voxel_program_, "half_size");

  glGenVertexArrays(1, &line_vao_);
  glGenBuffers(1, &line_vbo_);
  glBindVertexArray(line_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));

  glGenVertexArrays(1, &voxel_vao_);
  glGenBuffers(1, &voxel_vbo_);
  glBindVertexArray(voxel_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, voxel_vbo_);
  constexpr int kStride = 7 * sizeof(float);  // centre xyz, colour rgb, neighbour bits (as int bits)
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride, nullptr);
  glVertexAttribDivisor(0, 1);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, kStride, reinterpret_cast<void*>(3 * sizeof(float)));
  glVertexAttribDivisor(1, 1);
  glEnableVertexAttribArray(2);
  glVertexAttribIPointer(2, 1, GL_INT, kStride, reinterpret_cast<void*>(6 * sizeof(float)));
  glVertexAttribDivisor(2, 1);
  glGenVertexArrays(1, &voxel_mesh_vao_);
  glGenBuffers(1, &voxel_mesh_vbo_);
  glBindVertexArray(voxel_mesh_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, voxel_mesh_vbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
  glBindVertexArray(0);

  float range[2] = {1.0f, 1.0f};
  glGetFloatv(GL_ALIASED_LINE_WIDTH_RANGE, range);
  max_line_width_ = std::max(1.0f, range[1]);
  const GLenum gl_error = glGetError();
  if (gl_error != GL_NO_ERROR) {
    if (error) *error = "OpenGL error " + std::to_string(gl_error) + " during set-up";
    return false;
  }
  initialized_ = true;
  return true;
}

void SceneRenderer::UpdateVoxelInstances(const ViewerState& state, const SceneOptions& options) {
  const int64_t version = state.voxel_map_version();
  if (version == voxel_version_ && options.min_votes == voxel_min_votes_ && options.cull_hidden_voxels == voxel_cull_ &&
      options.voxel_coloring == voxel_coloring_)
    return;
  voxel_version_ = version;
  voxel_min_votes_ = options.min_votes;
  voxel_cull_ = options.cull_hidden_voxels;
  voxel_coloring_ = options.voxel_coloring;
  voxels_shown_ = voxel_instances_ = 0;
  voxel_levels_ = 0;
  voxel_mesh_vertices_ = 0;
  if (!state.voxel_map()) return;
  const voxel_map_t& map = *state.voxel_map();
  const size_t n =
      std::min({static_cast<size_t>(std::max(map.num_voxels, 0)), map.ijk.size(), map.votes.size(), map.rgb.size()});
  std::vector<size_t> shown;
  shown.reserve(n);
  int max_votes = 1;
  for (size_t i = 0; i < n; ++i) {
    if (map.votes[i] < options.min_votes) continue;
    shown.push_back(i);
    max_votes = std::max(max_votes, map.votes[i]);
  }
  std::vector<float> buffer;
  std::vector<LodCell> cells;  // level 0 of the level-of-detail pyramid: every shown voxel
  BuildVoxelInstances(map, shown, max_votes, options, &buffer, &cells, voxel_bounds_min_, voxel_bounds_max_);
  const double size = map.voxel_size_mm;
  voxels_shown_ = static_cast<int64_t>(shown.size());
  voxel_instances_ = static_cast<int64_t>(buffer.size() / 7);
  // Static mesh of the exposed faces (plain triangles, back faces culled by GL): the fastest path in software GL
  // while it stays small; larger models use the instanced cubes or points.
  voxel_mesh_vertices_ = 0;
  const int64_t exposed_faces = CountExposedFaces(buffer);
  if (exposed_faces <= options.max_mesh_faces) {
    const std::vector<float> mesh = ExposedFaceMesh(buffer, size, exposed_faces);
    voxel_mesh_vertices_ = static_cast<int64_t>(mesh.size() / 6);
    glBindBuffer(GL_ARRAY_BUFFER, voxel_mesh_vbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.size() * sizeof(float)), mesh.data(), GL_STATIC_DRAW);
  }
  voxel_half_size_ = static_cast<float>(size / 2);
  glBindBuffer(GL_ARRAY_BUFFER, voxel_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)), buffer.data(), GL_STATIC_DRAW);

  // Point buffers: the voxels, then 2x2x2-merged cells level by level until only a handful are left.
  std::sort(cells.begin(), cells.end(), [](const LodCell& a, const LodCell& b) { return a.key < b.key; });
  constexpr int kMaxLevels = 9;     // cells of up to 256 voxels per side
  constexpr size_t kFewCells = 64;  // no coarser level below this many cells
  int levels = 0;
  for (int level = 0; level < kMaxLevels && !cells.empty(); ++level) {
    if (level > 0) {
      if (cells.size() <= kFewCells) break;
      cells = MergeCells(cells);
    }
    const double cell_mm = size * (int64_t{1} << level);
    const std::vector<PointVertex> points = LevelPoints(cells, map.origin_mm, cell_mm, options.cull_hidden_voxels);
    if (static_cast<int>(point_levels_.size()) <= level) {
      PointLevel created;
      CreatePointLevelArrays(&created.vao, &created.vbo, &created.ebo);
      point_levels_.push_back(created);
    }
    PointLevel& target = point_levels_[level];
    target.count = static_cast<int64_t>(points.size());
    target.half_size = static_cast<float>(cell_mm / 2);
    target.centers.resize(points.size() * 3);
    for (size_t p = 0; p < points.size(); ++p) {
      target.centers[3 * p] = points[p].x;
      target.centers[3 * p + 1] = points[p].y;
      target.centers[3 * p + 2] = points[p].z;
    }
    glBindBuffer(GL_ARRAY_BUFFER, target.vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(points.size() * sizeof(PointVertex)), points.data(),
                 GL_STATIC_DRAW);
    levels = level + 1;
  }
  for (size_t level = levels; level < point_levels_.size(); ++level) {
    point_levels_[level].count = 0;
    point_levels_[level].centers = {};
  }
  voxel_levels_ = levels;
}

int SceneRenderer::ChooseVoxelLevel(const OrbitView& view, const Viewport& viewport, const SceneOptions& options) {
  nearest_voxel_depth_mm_ = nearest_voxel_px_ = 0;
  if (voxel_levels_ < 1) return 0;
  // Nearest depth of the model: the nearest corner of its bounding box along the viewing direction.
  const Eigen::Vector3d eye = EyePosition(view);
  const Eigen::Vector3d forward = (view.target_mm - eye).normalized();
  double nearest = std::numeric_limits<double>::max();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p(corner & 1 ? voxel_bounds_max_[0] : voxel_bounds_min_[0],
                            corner & 2 ? voxel_bounds_max_[1] : voxel_bounds_min_[1],
                            corner & 4 ? voxel_bounds_max_[2] : voxel_bounds_min_[2]);
    nearest = std::min(nearest, forward.dot(p - eye));
  }
  nearest_voxel_depth_mm_ = nearest;
  if (nearest <= view.near_mm) return 0;
  const double pixels_per_mm = ProjectionMatrix(view, static_cast<double>(viewport.width) / viewport.height)(1, 1) *
                               viewport.height / 2.0 / nearest;
  nearest_voxel_px_ = 2.0 * point_levels_[0].half_size * pixels_per_mm;
  if (voxel_levels_ < 2 || !(options.lod_pixels > 0)) return 0;
  int level = 0;
  while (level + 1 < voxel_levels_ && point_levels_[level + 1].count > 0 &&
         2.0 * point_levels_[level + 1].half_size * pixels_per_mm <= options.lod_pixels)
    ++level;
  return level;
}

bool SceneRenderer::VisiblePoints(const PointLevel& level, const Eigen::Matrix4f& mvp, const Viewport& viewport,
                                  float pixels_per_unit, double max_point_px, std::vector<uint32_t>* visible) {
  visible->clear();
  const int width = viewport.width, height = viewport.height;
  const float* m = mvp.data();  // column-major
  // The part of the viewport the model can cover: its projected bounding box (all corners in front of the eye; a
  // perspective image of the box lies in the hull of its corners' images), widened by the widest point.
  int window_x0 = 0, window_x1 = width, window_y0 = 0, window_y1 = height;
  {
    float u0 = std::numeric_limits<float>::max(), u1 = std::numeric_limits<float>::lowest(), v0 = u0, v1 = u1;
    bool all_in_front = true;
    for (int corner = 0; corner < 8 && all_in_front; ++corner) {
      const float x = corner & 1 ? voxel_bounds_max_[0] : voxel_bounds_min_[0];
      const float y = corner & 2 ? voxel_bounds_max_[1] : voxel_bounds_min_[1];
      const float z = corner & 4 ? voxel_bounds_max_[2] : voxel_bounds_min_[2];
      const float cw = m[3] * x + m[7] * y + m[11] * z + m[15];
      if (!(cw > 1e-3f)) {
        all_in_front = false;
        break;
      }
      const float u = ((m[0] * x + m[4] * y + m[8] * z + m[12]) / cw * 0.5f + 0.5f) * width;
      const float v = ((m[1] * x + m[5] * y + m[9] * z + m[13]) / cw * 0.5f + 0.5f) * height;
      u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
    if (all_in_front) {
      const float margin = static_cast<float>(max_point_px) / 2 + 2;
      window_x0 = std::clamp(static_cast<int>(u0 - margin), 0, width);
      window_x1 = std::clamp(static_cast<int>(u1 + margin) + 1, window_x0, width);
      window_y0 = std::clamp(static_cast<int>(v0 - margin), 0, height);
      window_y1 = std::clamp(static_cast<int>(v1 + margin) + 1, window_y0, height);
    }
  }
  const int window_width = window_x1 - window_x0;
  constexpr float kEmpty = std::numeric_limits<float>::max();
  occlusion_pixels_.assign(static_cast<size_t>(window_width) * (window_y1 - window_y0), {kEmpty, 0});
  const size_t n = level.centers.size() / 3;
  if (occlusion_stamp_.size() < n) occlusion_stamp_.resize(n, 0);
  if (++occlusion_frame_ == 0) {  // wrapped: forget the old stamps
    std::fill(occlusion_stamp_.begin(), occlusion_stamp_.end(), 0);
    occlusion_frame_ = 1;
  }
  const float* c = level.centers.data();
  const float size_numerator = 2.0f * level.half_size * pixels_per_unit;
  const float half_width = 0.5f * width, half_height = 0.5f * height;
  for (size_t i = 0; i < n; ++i) {
    const float x = c[3 * i], y = c[3 * i + 1], z = c[3 * i + 2];
    const float cw = m[3] * x + m[7] * y + m[11] * z + m[15];
    const float cz = m[2] * x + m[6] * y + m[10] * z + m[14];
    if (!(cw > 0) || std::abs(cz) > cw) continue;  // clipped by the near or far plane: GL drops it too
    const float cx = m[0] * x + m[4] * y + m[8] * z + m[12];
    const float cy = m[1] * x + m[5] * y + m[9] * z + m[13];
    if (std::abs(cx) > cw || std::abs(cy) > cw) {  // centre off the sides: left to GL
      visible->push_back(static_cast<uint32_t>(i));
      continue;
    }
    const float inv = 1.0f / cw;
    const float half = 0.5f * std::max(1.0f, size_numerator / std::max(cw, 1e-3f));  // as the vertex shader
    if (2 * half > max_point_px) {
      visible->clear();
      return false;
    }
    // The pixels whose centres lie in the point's square (GL window coordinates, y up).
    const float sx = cx * inv * half_width + half_width, sy = cy * inv * half_height + half_height;
    const float depth = cz * inv;
    const int x0 = std::max(window_x0, CeilToInt(sx - half - 0.5f));
    const int x1 = std::min(window_x1, CeilToInt(sx + half - 0.5f));
    const int y0 = std::max(window_y0, CeilToInt(sy - half - 0.5f));
    const int y1 = std::min(window_y1, CeilToInt(sy + half - 0.5f));
    const OcclusionPixel point{depth, static_cast<uint32_t>(i)};
    for (int py = y0; py < y1; ++py) {
      OcclusionPixel* row =
          occlusion_pixels_.data() + static_cast<size_t>(py - window_y0) * window_width + (x0 - window_x0);
      for (int k = 0; k < x1 - x0; ++k) {
        if (depth <= row[k].depth) row[k] = point;  // GL_LEQUAL, drawn in order: the later of equals wins
      }
    }
  }
  for (const uint32_t i : *visible) occlusion_stamp_[i] = occlusion_frame_;
  for (const OcclusionPixel& pixel : occlusion_pixels_) {
    if (pixel.depth == kEmpty || occlusion_stamp_[pixel.winner] == occlusion_frame_) continue;
    occlusion_stamp_[pixel.winner] = occlusion_frame_;
    visible->push_back(pixel.winner);
  }
  return true;
}

void SceneRenderer::DrawColored(const std::vector<float>& vertices, unsigned mode, float size) {
  if (vertices.empty()) return;
  if (mode == GL_LINES) glLineWidth(std::clamp(size, 1.0f, max_line_width_));
  glUniform1f(line_point_size_location_, size);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data(),
               GL_STREAM_DRAW);
  glDrawArrays(mode, 0, static_cast<GLsizei>(vertices.size() / 6));
}

void SceneRenderer::DrawVoxels(const ViewerState& state, const OrbitView& view, const Viewport& viewport,
                               const SceneOptions& options, const Eigen::Matrix4f& mvp) {
  UpdateVoxelInstances(state, options);
  voxel_level_ = ChooseVoxelLevel(view, viewport, options);
  voxels_occlusion_culled_ = false;
  const bool small = nearest_voxel_px_ > 0 && nearest_voxel_px_ <= options.auto_points_px;
  voxels_as_points_ = voxel_level_ > 0 || options.voxel_style == VoxelStyle::kPoints ||
                      (options.voxel_style == VoxelStyle::kAuto &&
                       (small || (voxel_mesh_vertices_ == 0 && voxel_instances_ > options.max_cube_instances)));
  voxels_as_mesh_ = !voxels_as_points_ && voxel_mesh_vertices_ > 0;
  voxels_drawn_ =
      voxels_as_points_ && voxel_level_ < voxel_levels_ ? point_levels_[voxel_level_].count : voxel_instances_;
  if (voxels_as_mesh_) {
    glUseProgram(line_program_);
    glUniformMatrix4fv(line_mvp_location_, 1, GL_FALSE, mvp.data());
    glBindVertexArray(voxel_mesh_vao_);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(voxel_mesh_vertices_));
    glDisable(GL_CULL_FACE);
  } else if (voxels_as_points_) {
    if (voxel_level_ < voxel_levels_ && point_levels_[voxel_level_].count > 0)
      DrawVoxelPoints(point_levels_[voxel_level_], view, viewport, options, mvp);
  } else if (voxel_instances_ > 0) {
    const Eigen::Vector3f eye = EyePosition(view).cast<float>();
    glUseProgram(voxel_program_);
    glUniformMatrix4fv(voxel_mvp_location_, 1, GL_FALSE, mvp.data());
    glUniform3f(voxel_eye_location_, eye.x(), eye.y(), eye.z());
    glUniform1f(voxel_half_size_location_, voxel_half_size_);
    glBindVertexArray(voxel_vao_);
    glDrawArraysInstanced(GL_TRIANGLES, 0, 18, static_cast<GLsizei>(voxel_instances_));
  }
}

void SceneRenderer::DrawVoxelPoints(const PointLevel& level, const OrbitView& view, const Viewport& viewport,
                                    const SceneOptions& options, const Eigen::Matrix4f& mvp) {
  const Eigen::Matrix4f projection = ProjectionMatrix(view, static_cast<double>(viewport.width) / viewport.height);
  glUseProgram(voxel_point_program_);
  glUniformMatrix4fv(point_mvp_location_, 1, GL_FALSE, mvp.data());
  glUniform1f(point_half_size_location_, level.half_size);
  glUniform1f(point_pixels_location_, projection(1, 1) * viewport.height / 2.0f);
  glBindVertexArray(level.vao);
  const float pixels_per_unit = projection(1, 1) * viewport.height / 2.0f;
  voxels_occlusion_culled_ =
      options.occlusion_min_points > 0 && level.count >= options.occlusion_min_points &&
      nearest_voxel_depth_mm_ > view.near_mm &&
      2.0 * level.half_size * pixels_per_unit / nearest_voxel_depth_mm_ <= options.max_occlusion_point_px &&
      VisiblePoints(level, mvp, viewport, pixels_per_unit, options.max_occlusion_point_px, &visible_points_);
  if (voxels_occlusion_culled_) {
    voxels_drawn_ = static_cast<int64_t>(visible_points_.size());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(visible_points_.size() * sizeof(uint32_t)),
                 visible_points_.data(), GL_STREAM_DRAW);
    glDrawElements(GL_POINTS, static_cast<GLsizei>(visible_points_.size()), GL_UNSIGNED_INT, nullptr);
  } else {
    glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(level.count));
  }
}

void SceneRenderer::Render(const ViewerState& state, const OrbitView& view, const Viewport& viewport,
                           int framebuffer_height, const SceneOptions& options) {
  if (!initialized_ || viewport.width <= 0 || viewport.height <= 0) return;
  const int gl_y = framebuffer_height - (viewport.y + viewport.height);
  glViewport(viewport.x, gl_y, viewport.width, viewport.height);
  glEnable(GL_SCISSOR_TEST);
  glScissor(viewport.x, gl_y, viewport.width, viewport.height);
  const Color bg = ToColor(kBackgroundColor);
  glClearColor(bg.r, bg.g, bg.b, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glEnable(GL_PROGRAM_POINT_SIZE);

  const Eigen::Matrix4f mvp =
      ProjectionMatrix(view, static_cast<double>(viewport.width) / viewport.height) * ViewMatrix(view);

  // Voxels first (opaque, largest depth complexity).
  if (options.layers.voxels) DrawVoxels(state, view, viewport, options, mvp);

  glUseProgram(line_program_);
  glUniformMatrix4fv(line_mvp_location_, 1, GL_FALSE, mvp.data());
  glBindVertexArray(line_vao_);
  VertexList lines;
  AddGridAndAxes(&lines, options);
  const PinholeCamera* camera = state.camera() ? &*state.camera() : nullptr;
  if (options.layers.frustums && !state.estimated_trajectory().empty())
    AddTrajectoryFrustums(&lines, state, camera, options);
  if (options.layers.target && state.target()) AddTargetBox(&lines, *state.target());
  if (options.layers.robot && state.odometry()) AddRobot(&lines, *state.odometry(), camera, options);
  DrawColored(lines.data(), GL_LINES, 1.0f);

  // Trajectories and the error segment, thicker.
  lines.Clear();
  AddTrajectories(&lines, state, options);
  DrawColored(lines.data(), GL_LINES, options.trajectory_line_width_px);

  if (options.layers.landmarks && state.landmarks()) {
    lines.Clear();
    AddLandmarks(&lines, state, *state.landmarks(), options);
    DrawColored(lines.data(), GL_POINTS, options.landmark_point_size_px);
  }
  glBindVertexArray(0);
  glUseProgram(0);
  glDisable(GL_DEPTH_TEST);
}

}  // namespace objscan
