#include "viewer/scene_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
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

// Large models: one screen-aligned square per voxel, sized like the voxel at its depth (much cheaper in software GL).
const char* kVoxelPointVertexShader = R"(#version 330 core
layout(location = 0) in vec3 center;
layout(location = 1) in vec3 color;
layout(location = 2) in int neighbours;
uniform mat4 mvp;
uniform float half_size;
uniform float pixels_per_unit;  // projection(1,1) * viewport height / 2
out vec3 v_color;
void main() {
  gl_Position = mvp * vec4(center, 1.0);
  gl_PointSize = max(1.0, 2.0 * half_size * pixels_per_unit / max(gl_Position.w, 1e-3));
  v_color = color * ((neighbours & 16) != 0 ? 0.8 : 1.0);
}
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
  glDeleteVertexArrays(1, &voxel_point_vao_);
  glDeleteVertexArrays(1, &voxel_mesh_vao_);
  glDeleteBuffers(1, &voxel_mesh_vbo_);
}

bool SceneRenderer::Init(std::string* error) {
  line_program_ = Link(kLineVertexShader, kColorFragmentShader, error);
  voxel_program_ = Link(kVoxelVertexShader, kColorFragmentShader, error);
  voxel_point_program_ = Link(kVoxelPointVertexShader, kColorFragmentShader, error);
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
  // The same buffer read per vertex (no instancing): one point per voxel.
  glGenVertexArrays(1, &voxel_point_vao_);
  glBindVertexArray(voxel_point_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, voxel_vbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, kStride, reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribIPointer(2, 1, GL_INT, kStride, reinterpret_cast<void*>(6 * sizeof(float)));
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
  std::unordered_set<int64_t> occupied;
  if (options.cull_hidden_voxels) {
    occupied.reserve(shown.size() * 2);
    for (size_t i : shown) occupied.insert(VoxelKey(map.ijk[i][0], map.ijk[i][1], map.ijk[i][2]));
  }
  std::vector<float> buffer;
  buffer.reserve(shown.size() * 7);
  const double size = map.voxel_size_mm;
  for (size_t i : shown) {
    const std::vector<int32_t>& ijk = map.ijk[i];
    int bits = 0;
    if (options.cull_hidden_voxels) {
      const int d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
      for (int f = 0; f < 6; ++f)
        if (occupied.count(VoxelKey(int64_t{ijk[0]} + d[f][0], int64_t{ijk[1]} + d[f][1], int64_t{ijk[2]} + d[f][2])))
          bits |= 1 << f;
      if (bits == 63) continue;  // enclosed on all sides: never visible
    }
    Color c;
    if (options.voxel_coloring == VoxelColoring::kVotes) {
      c = Ramp(static_cast<double>(map.votes[i]) / max_votes);
    } else {
      c = {map.rgb[i][0] / 255.0f, map.rgb[i][1] / 255.0f, map.rgb[i][2] / 255.0f};
    }
    float bits_as_float;
    static_assert(sizeof(bits_as_float) == sizeof(bits), "int/float size");
    std::memcpy(&bits_as_float, &bits, sizeof(bits));
    buffer.insert(buffer.end(),
                  {static_cast<float>(map.origin_mm[0] + (ijk[0] + 0.5) * size),
                   static_cast<float>(map.origin_mm[1] + (ijk[1] + 0.5) * size),
                   static_cast<float>(map.origin_mm[2] + (ijk[2] + 0.5) * size), c.r, c.g, c.b, bits_as_float});
  }
  voxels_shown_ = static_cast<int64_t>(shown.size());
  voxel_instances_ = static_cast<int64_t>(buffer.size() / 7);
  // Static mesh of the exposed faces (plain triangles, back faces culled by GL): the fastest path in software GL
  // while it stays small; larger models use the instanced cubes or points.
  voxel_mesh_vertices_ = 0;
  int64_t exposed_faces = 0;
  for (size_t v = 0; v < static_cast<size_t>(voxel_instances_); ++v) {
    int bits;
    std::memcpy(&bits, &buffer[v * 7 + 6], sizeof(bits));
    for (int f = 0; f < 6; ++f) exposed_faces += (bits >> f & 1) == 0;
  }
  if (exposed_faces <= options.max_mesh_faces) {
    // Face f: normal n, in-plane axes u, v with u x v = n (counter-clockwise seen from outside), shade.
    static const float kFace[6][3][3] = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
                                         {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}, {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
                                         {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}};
    static const float kShade[6] = {0.80f, 0.80f, 0.64f, 0.64f, 1.0f, 0.45f};
    static const float kCorner[6][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, -1}, {1, 1}, {-1, 1}};
    const float h = static_cast<float>(size / 2);
    std::vector<float> mesh;
    mesh.reserve(static_cast<size_t>(exposed_faces) * 36);
    for (size_t v = 0; v < static_cast<size_t>(voxel_instances_); ++v) {
      const float* in = &buffer[v * 7];
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
    voxel_mesh_vertices_ = static_cast<int64_t>(mesh.size() / 6);
    glBindBuffer(GL_ARRAY_BUFFER, voxel_mesh_vbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.size() * sizeof(float)), mesh.data(), GL_STATIC_DRAW);
  }
  voxel_half_size_ = static_cast<float>(size / 2);
  glBindBuffer(GL_ARRAY_BUFFER, voxel_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(buffer.size() * sizeof(float)), buffer.data(), GL_STATIC_DRAW);
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
  if (options.layers.voxels) {
    UpdateVoxelInstances(state, options);
    voxels_as_points_ = options.voxel_style == VoxelStyle::kPoints ||
                        (options.voxel_style == VoxelStyle::kAuto && voxel_mesh_vertices_ == 0 &&
                         voxel_instances_ > options.max_cube_instances);
    voxels_as_mesh_ = !voxels_as_points_ && voxel_mesh_vertices_ > 0;
    if (voxels_as_mesh_) {
      glUseProgram(line_program_);
      glUniformMatrix4fv(line_mvp_location_, 1, GL_FALSE, mvp.data());
      glBindVertexArray(voxel_mesh_vao_);
      glEnable(GL_CULL_FACE);
      glCullFace(GL_BACK);
      glFrontFace(GL_CCW);
      glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(voxel_mesh_vertices_));
      glDisable(GL_CULL_FACE);
    } else if (voxel_instances_ > 0 && voxels_as_points_) {
      const Eigen::Matrix4f projection = ProjectionMatrix(view, static_cast<double>(viewport.width) / viewport.height);
      glUseProgram(voxel_point_program_);
      glUniformMatrix4fv(point_mvp_location_, 1, GL_FALSE, mvp.data());
      glUniform1f(point_half_size_location_, voxel_half_size_);
      glUniform1f(point_pixels_location_, projection(1, 1) * viewport.height / 2.0f);
      glBindVertexArray(voxel_point_vao_);
      glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(voxel_instances_));
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

  glUseProgram(line_program_);
  glUniformMatrix4fv(line_mvp_location_, 1, GL_FALSE, mvp.data());
  glBindVertexArray(line_vao_);
  VertexList lines;

  if (options.layers.grid && options.grid_spacing_mm > 0) {
    const Color c = ToColor(kGridColor);
    const double e = options.grid_extent_mm;
    const int n = static_cast<int>(std::floor(e / options.grid_spacing_mm));
    for (int i = -n; i <= n; ++i) {
      const double t = i * options.grid_spacing_mm;
      lines.Segment({t, -e, 0}, {t, e, 0}, c);
      lines.Segment({-e, t, 0}, {e, t, 0}, c);
    }
  }
  if (options.layers.axes) {
    const double l = options.axes_length_mm;
    lines.Segment({0, 0, 0}, {l, 0, 0}, {0.95f, 0.2f, 0.2f});
    lines.Segment({0, 0, 0}, {0, l, 0}, {0.2f, 0.9f, 0.2f});
    lines.Segment({0, 0, 0}, {0, 0, l}, {0.3f, 0.4f, 1.0f});
  }
  const PinholeCamera* camera = state.camera() ? &*state.camera() : nullptr;
  if (options.layers.frustums && !state.estimated_trajectory().empty()) {
    const auto& trajectory = state.estimated_trajectory();
    const int every = std::max(options.frustum_every, 1);
    int index = 0;
    for (const auto& [seq, point] : trajectory) {
      if (index++ % every == 0)
        AddFrustum(&lines, point.world_from_camera, camera, options.frustum_depth_mm, {0.75f, 0.6f, 0.35f});
    }
    AddFrustum(&lines, trajectory.rbegin()->second.world_from_camera, camera, options.frustum_depth_mm * 2,
               ToColor(kEstimatedTrajectoryColor));
  }
  if (options.layers.target && state.target()) {
    const target_t& t = *state.target();
    Color c{0.6f, 0.6f, 0.6f};
    if (t.state == target_t::STATE_CANDIDATE) c = {1.0f, 0.9f, 0.2f};
    if (t.state == target_t::STATE_CONFIRMED) c = {0.2f, 1.0f, 0.3f};
    if (t.state == target_t::STATE_LOST) c = {1.0f, 0.25f, 0.25f};
    Eigen::Isometry3d world_from_box = Eigen::Isometry3d::Identity();
    world_from_box.translate(Eigen::Vector3d(t.center_mm[0], t.center_mm[1], t.center_mm[2]));
    world_from_box.rotate(Eigen::AngleAxisd(t.yaw_rad, Eigen::Vector3d::UnitZ()));
    AddBox(&lines, world_from_box, 0.5 * Eigen::Vector3d(t.size_mm[0], t.size_mm[1], t.size_mm[2]), c);
  }
  if (options.layers.robot && state.odometry()) {
    const OdometryReading& o = *state.odometry();
    const Color c{0.85f, 0.85f, 0.9f};
    const Eigen::Isometry3d world_from_base = WorldFromBase(o.x_mm, o.y_mm, o.theta_rad);
    const double half_track = options.robot.wheel_base_mm / 2;
    AddBox(&lines, world_from_base * Eigen::Translation3d(0, 0, 60), Eigen::Vector3d(half_track, half_track, 60), c);
    lines.Segment(world_from_base * Eigen::Vector3d(0, 0, 120),
                  world_from_base * Eigen::Vector3d(half_track * 1.5, 0, 120), {1.0f, 0.3f, 0.3f});
    const Eigen::Vector3d mast_foot(options.robot.mast_offset_x_mm, options.robot.mast_offset_y_mm, 120);
    const Eigen::Vector3d mast_top(options.robot.mast_offset_x_mm, options.robot.mast_offset_y_mm,
                                   options.robot.mast_height_mm);
    lines.Segment(world_from_base * mast_foot, world_from_base * mast_top, c);
    AddFrustum(&lines, WorldFromCamera(options.robot, o.x_mm, o.y_mm, o.theta_rad, o.pan_rad, o.tilt_rad), camera,
               options.frustum_depth_mm * 1.5, c);
  }
  DrawColored(lines.data(), GL_LINES, 1.0f);

  // Trajectories and the error segment, thicker.
  lines.Clear();
  // The truth is drawn in the estimate's frame (ViewerState::estimate_from_truth).
  auto add_path = [&lines](const std::map<int64_t, TrajectoryPoint>& path, Color c, const Sim3& transform) {
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();
    bool first = true;
    for (const auto& entry : path) {
      const Eigen::Vector3d p = transform * entry.second.world_from_camera.translation();
      if (!first) lines.Segment(previous, p, c);
      previous = p;
      first = false;
    }
  };
  if (options.layers.ground_truth)
    add_path(state.ground_truth_trajectory(), ToColor(kGroundTruthTrajectoryColor), state.estimate_from_truth());
  if (options.layers.estimated) add_path(state.estimated_trajectory(), ToColor(kEstimatedTrajectoryColor), Sim3());
  if (options.layers.error && state.latest_error_seq() >= 0) {
    const auto est = state.estimated_trajectory().find(state.latest_error_seq());
    const auto gt = state.ground_truth_trajectory().find(state.latest_error_seq());
    if (est != state.estimated_trajectory().end() && gt != state.ground_truth_trajectory().end())
      lines.Segment(est->second.world_from_camera.translation(),
                    state.estimate_from_truth() * gt->second.world_from_camera.translation(),
                    ToColor(kErrorSegmentColor));
  }
  DrawColored(lines.data(), GL_LINES, options.trajectory_line_width_px);

  if (options.layers.landmarks && state.landmarks()) {
    const landmarks_t& lm = *state.landmarks();
    lines.Clear();
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
      lines.Add(Eigen::Vector3d(lm.position_mm[i][0], lm.position_mm[i][1], lm.position_mm[i][2]), c);
    }
    DrawColored(lines.data(), GL_POINTS, options.landmark_point_size_px);
  }
  glBindVertexArray(0);
  glUseProgram(0);
  glDisable(GL_DEPTH_TEST);
}

}  // namespace objscan
