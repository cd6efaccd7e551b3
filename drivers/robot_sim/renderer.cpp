#include "drivers/robot_sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace objscan {
namespace {

constexpr int kNoiseTableBits = 20;
constexpr uint32_t kNoiseMask = (1u << kNoiseTableBits) - 1;

// Bilinear sample of one level at (u, v) in that level's texels (texel centres at i + 0.5), wrapping around.
// Fixed point: 8-bit weights summing to 256, R and B filtered together in one 32-bit word (SWAR).
inline void SampleBilinear(const Texture::Level& level, float u, float v, float* rgb) {
  const float x = u - 0.5f, y = v - 0.5f;
  int ix = static_cast<int>(x), iy = static_cast<int>(y);  // floor without a libm call
  ix -= x < static_cast<float>(ix);
  iy -= y < static_cast<float>(iy);
  const uint32_t fx = static_cast<uint32_t>((x - static_cast<float>(ix)) * 256.0f);
  const uint32_t fy = static_cast<uint32_t>((y - static_cast<float>(iy)) * 256.0f);
  const uint32_t wb = (fx * (256 - fy)) >> 8, wc = ((256 - fx) * fy) >> 8, wd = (fx * fy) >> 8;
  const uint32_t wa = 256 - wb - wc - wd;
  const int mask = level.size - 1;
  const int x0 = ix & mask, y0 = iy & mask;
  const int x1 = (x0 + 1) & mask, y1 = (y0 + 1) & mask;
  const uint32_t* row0 = &level.texels[static_cast<size_t>(y0) * level.size];
  const uint32_t* row1 = &level.texels[static_cast<size_t>(y1) * level.size];
  const uint32_t a = row0[x0], b = row0[x1], c = row1[x0], d = row1[x1];
  const uint32_t rb = (a & 0xff00ffu) * wa + (b & 0xff00ffu) * wb + (c & 0xff00ffu) * wc + (d & 0xff00ffu) * wd;
  const uint32_t g =
      ((a >> 8) & 0xffu) * wa + ((b >> 8) & 0xffu) * wb + ((c >> 8) & 0xffu) * wc + ((d >> 8) & 0xffu) * wd;
  rgb[0] = static_cast<float>(rb & 0xffffu) * (1.0f / 256.0f);
  rgb[1] = static_cast<float>(g) * (1.0f / 256.0f);
  rgb[2] = static_cast<float>(rb >> 16) * (1.0f / 256.0f);
}

inline uint8_t ToByte(float value) {
  const int i = static_cast<int>(value + 0.5f);
  return static_cast<uint8_t>(i < 0 ? 0 : (i > 255 ? 255 : i));
}

// Converts a functional V . r with r = ((x - cx) / fx, (y - cy) / fy, 1) into a screen plane a*x + b*y + c.
inline void ToScreenPlane(const Eigen::Vector3d& v, const PinholeCamera& cam, double plane[3]) {
  plane[0] = v.x() / cam.fx;
  plane[1] = v.y() / cam.fy;
  plane[2] = v.z() - v.x() * cam.cx / cam.fx - v.y() * cam.cy / cam.fy;
}

// Z-buffers one screen triangle (a, b, c in pixels, any winding) into qbuffer / setup_index (width x height, row
// major), where its q = 1/z (1/mm, screen plane qp) beats the stored value. Returns whether any pixel was won.
bool ZBufferTriangle(Eigen::Vector2d a, Eigen::Vector2d b, Eigen::Vector2d c, const double qp[3], int width, int height,
                     int setup_id, float* qbuffer, int32_t* setup_index) {
  double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  if (std::abs(area) < 1e-12) return false;
  if (area < 0) std::swap(b, c);
  const Eigen::Vector2d pts[3] = {a, b, c};
  double ea[3], eb[3], ec[3];
  for (int k2 = 0; k2 < 3; ++k2) {
    const Eigen::Vector2d& p = pts[k2];
    const Eigen::Vector2d& q = pts[(k2 + 1) % 3];
    ea[k2] = -(q.y() - p.y());
    eb[k2] = q.x() - p.x();
    ec[k2] = -ea[k2] * p.x() - eb[k2] * p.y();
  }
  bool any = false;
  const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
  const int y_start = std::max(0, static_cast<int>(std::ceil(ymin)));
  const int y_end = std::min(height - 1, static_cast<int>(std::floor(ymax)));
  for (int y = y_start; y <= y_end; ++y) {
    double lo = 0, hi = width - 1;
    for (int k2 = 0; k2 < 3; ++k2) {
      const double kk = eb[k2] * y + ec[k2];
      if (ea[k2] > 0)
        lo = std::max(lo, -kk / ea[k2]);
      else if (ea[k2] < 0)
        hi = std::min(hi, -kk / ea[k2]);
      else if (kk < 0)
        hi = -1;
    }
    if (hi < lo) continue;
    const int x_start = static_cast<int>(std::ceil(lo)), x_end = static_cast<int>(std::floor(hi));
    float* qrow = &qbuffer[static_cast<size_t>(y) * width];
    int32_t* irow = &setup_index[static_cast<size_t>(y) * width];
    const double qrow_c = qp[1] * y + qp[2];
    for (int x = x_start; x <= x_end; ++x) {
      const float q = static_cast<float>(qp[0] * x + qrow_c);
      if (q > qrow[x]) {
        qrow[x] = q;
        irow[x] = setup_id;
        any = true;
      }
    }
  }
  return any;
}

// Colour (R, G, B, 0..255) of a mip chain at (u, v) in level-0 texels for the squared footprint rho2 (level-0
// texels^2 per pixel): nearest level with bilinear filtering, or trilinear between the two nearest levels.
inline void SampleTexture(const Texture::Level* levels, int max_level, bool trilinear, float u, float v, float rho2,
                          float colour[3]) {
  if (!trilinear) {
    // nearest level: round(0.5 * log2(rho2)) = floor(log2(2 * rho2) / 2)
    int level = 0;
    if (rho2 > 0.5f) {
      uint32_t bits;
      const float twice = 2.0f * rho2;
      std::memcpy(&bits, &twice, 4);
      const int exponent = static_cast<int>((bits >> 23) & 0xff) - 127;  // floor(log2(2 rho2))
      level = std::min(max_level, exponent >> 1);
    }
    const float scale = 1.0f / static_cast<float>(1 << level);
    SampleBilinear(levels[level], u * scale, v * scale, colour);
  } else {
    const float lod = rho2 > 1.0f ? std::min(0.5f * std::log2(rho2), static_cast<float>(max_level)) : 0.0f;
    const int l0 = static_cast<int>(lod);
    const int l1 = std::min(l0 + 1, max_level);
    const float t = lod - l0;
    float c0[3], c1[3];
    SampleBilinear(levels[l0], u / static_cast<float>(1 << l0), v / static_cast<float>(1 << l0), c0);
    SampleBilinear(levels[l1], u / static_cast<float>(1 << l1), v / static_cast<float>(1 << l1), c1);
    for (int k = 0; k < 3; ++k) colour[k] = c0[k] + t * (c1[k] - c0[k]);
  }
}

}  // namespace

Renderer::Renderer(const Scene& scene, const RenderOptions& options) : scene_(scene), options_(options) {
  if (!(options_.noise_sigma >= 0) || !std::isfinite(options_.noise_sigma))
    throw std::invalid_argument("noise sigma must be >= 0");
  if (!(options_.near_mm > 0)) throw std::invalid_argument("near plane must be > 0 mm");
  const Eigen::Vector3d light = scene.light.direction.normalized();
  for (const SceneObject& object : scene.objects) {
    const int base = static_cast<int>(vertices_.size());
    const TriangleMesh& m = object.mesh;
    for (size_t i = 0; i < m.positions.size(); ++i) {
      Vertex v;
      v.position = m.positions[i].cast<double>();
      v.u = m.uvs[i].x();
      v.v = m.uvs[i].y();
      const double lambert = std::max(0.0, m.normals[i].cast<double>().dot(light));
      v.shade = static_cast<float>(scene.light.ambient + scene.light.diffuse * lambert);
      vertices_.push_back(v);
    }
    for (const auto& t : m.triangles)
      triangles_.push_back({{base + t[0], base + t[1], base + t[2]}, object.id, m.closed});
    textures_.push_back(object.texture_maps.get());
  }
  noise_table_.resize(size_t{1} << kNoiseTableBits);
  SimRng rng(MixSeed(options_.noise_seed, 0x4e01));
  for (auto& n : noise_table_) n = static_cast<float>(options_.noise_sigma * rng.Gaussian());
}

void Renderer::Render(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera, RenderOutput* out,
                      uint64_t frame_key) {
  std::string why;
  if (!camera.IsValid(&why)) throw std::invalid_argument("renderer: " + why);
  const int width = camera.width, height = camera.height;
  const size_t num_pixels = static_cast<size_t>(width) * height;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  camera_points_.resize(vertices_.size());
  for (size_t i = 0; i < vertices_.size(); ++i) camera_points_[i] = camera_from_world * vertices_[i].position;
  setups_.clear();
  qbuffer_.assign(num_pixels, 0.0f);
  setup_index_.assign(num_pixels, -1);
  // Frustum side planes through the optical centre (inside: dot >= 0), pixel area [-0.5, size - 0.5].
  const Eigen::Vector3d side_planes[4] = {
      Eigen::Vector3d(camera.fx, 0, camera.cx + 0.5), Eigen::Vector3d(-camera.fx, 0, width - 0.5 - camera.cx),
      Eigen::Vector3d(0, camera.fy, camera.cy + 0.5), Eigen::Vector3d(0, -camera.fy, height - 0.5 - camera.cy)};
  int drawn = 0;
  for (const Triangle& tri : triangles_) {
    Setup setup;
    double qp[3];
    if (!SetUpTriangle(tri, camera, side_planes, &setup, qp)) continue;
    if (RasterizeTriangle(tri, camera, qp, static_cast<int>(setups_.size()))) {
      setups_.push_back(setup);
      ++drawn;
    }
  }
  out->triangles_drawn = drawn;
  ShadePixels(width, height, frame_key, out);
}

bool Renderer::SetUpTriangle(const Triangle& tri, const PinholeCamera& camera, const Eigen::Vector3d side_planes[4],
                             Setup* setup, double qp[3]) const {
  const double near = options_.near_mm;
  const Eigen::Vector3d& p0 = camera_points_[tri.v[0]];
  const Eigen::Vector3d& p1 = camera_points_[tri.v[1]];
  const Eigen::Vector3d& p2 = camera_points_[tri.v[2]];
  if (p0.z() < near && p1.z() < near && p2.z() < near) return false;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d& plane = side_planes[k];
    if (plane.dot(p0) < 0 && plane.dot(p1) < 0 && plane.dot(p2) < 0) return false;
  }
  const Eigen::Vector3d e1 = p1 - p0, e2 = p2 - p0;
  const Eigen::Vector3d n = e1.cross(e2);
  const double d = n.dot(p0);
  if (tri.cull && d >= 0) return false;             // back face (the camera sits at the origin)
  if (std::abs(d) < 1e-9 * n.norm()) return false;  // plane through the optical centre: seen edge-on
  // Perspective-correct planes: for the viewing ray r, q = 1/z = r.n/d, b1*q = -r.(p0 x e2)/d, b2*q = r.(p0 x e1)/d.
  const Eigen::Vector3d q_vec = n / d;
  const Eigen::Vector3d b1_vec = -p0.cross(e2) / d;
  const Eigen::Vector3d b2_vec = p0.cross(e1) / d;
  const Vertex& v0 = vertices_[tri.v[0]];
  const Vertex& v1 = vertices_[tri.v[1]];
  const Vertex& v2 = vertices_[tri.v[2]];
  double up[3], vp[3], sp[3];
  ToScreenPlane(q_vec, camera, qp);
  ToScreenPlane(v0.u * q_vec + (v1.u - v0.u) * b1_vec + (v2.u - v0.u) * b2_vec, camera, up);
  ToScreenPlane(v0.v * q_vec + (v1.v - v0.v) * b1_vec + (v2.v - v0.v) * b2_vec, camera, vp);
  ToScreenPlane(v0.shade * q_vec + (v1.shade - v0.shade) * b1_vec + (v2.shade - v0.shade) * b2_vec, camera, sp);
  for (int k = 0; k < 3; ++k) {
    setup->q[k] = static_cast<float>(qp[k]);
    setup->u[k] = static_cast<float>(up[k]);
    setup->v[k] = static_cast<float>(vp[k]);
    setup->s[k] = static_cast<float>(sp[k]);
  }
  setup->object = tri.object;
  setup->levels = textures_[tri.object]->levels.data();
  setup->max_level = static_cast<int>(textures_[tri.object]->levels.size()) - 1;
  return true;
}

bool Renderer::RasterizeTriangle(const Triangle& tri, const PinholeCamera& camera, const double qp[3], int setup_id) {
  // Clip the polygon at the near plane (Sutherland-Hodgman), project, rasterize as a fan.
  const double near = options_.near_mm;
  Eigen::Vector3d poly[4];
  int count = 0;
  const Eigen::Vector3d in[3] = {camera_points_[tri.v[0]], camera_points_[tri.v[1]], camera_points_[tri.v[2]]};
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d& a = in[k];
    const Eigen::Vector3d& b = in[(k + 1) % 3];
    const bool a_in = a.z() >= near, b_in = b.z() >= near;
    if (a_in) poly[count++] = a;
    if (a_in != b_in) poly[count++] = a + (b - a) * ((near - a.z()) / (b.z() - a.z()));
  }
  if (count < 3) return false;
  Eigen::Vector2d screen[4];
  for (int k = 0; k < count; ++k)
    screen[k] = Eigen::Vector2d(camera.fx * poly[k].x() / poly[k].z() + camera.cx,
                                camera.fy * poly[k].y() / poly[k].z() + camera.cy);
  bool any = false;
  for (int k = 1; k + 1 < count; ++k) {
    if (ZBufferTriangle(screen[0], screen[k], screen[k + 1], qp, camera.width, camera.height, setup_id, qbuffer_.data(),
                        setup_index_.data()))
      any = true;
  }
  return any;
}

void Renderer::ShadePixels(int width, int height, uint64_t frame_key, RenderOutput* out) const {
  out->rgb.create(height, width, CV_8UC3);
  out->depth_mm.create(height, width, CV_32F);
  out->object_id.create(height, width, CV_32S);
  const float* noise = noise_table_.data();
  uint32_t noise_index = static_cast<uint32_t>(MixSeed(options_.noise_seed, frame_key)) & kNoiseMask;
  const float bg[3] = {static_cast<float>(scene_.background_bgr.x()), static_cast<float>(scene_.background_bgr.y()),
                       static_cast<float>(scene_.background_bgr.z())};
  const bool trilinear = options_.trilinear;
  for (int y = 0; y < height; ++y) {
    uint8_t* rgb_row = out->rgb.ptr<uint8_t>(y);
    float* depth_row = out->depth_mm.ptr<float>(y);
    int32_t* id_row = out->object_id.ptr<int32_t>(y);
    const int32_t* index_row = &setup_index_[static_cast<size_t>(y) * width];
    const float fy = static_cast<float>(y);
    // Plane coefficients of the current run of pixels showing the same triangle (row terms folded in).
    int32_t cached = -1;
    float qa = 0, qr = 0, qb = 0, ua = 0, ur = 0, ub = 0, va = 0, vr = 0, vb = 0, sa = 0, sr = 0;
    const Texture::Level* levels = nullptr;
    int max_level = 0, object = -1;
    for (int x = 0; x < width; ++x) {
      const float n0 = noise[noise_index], n1 = noise[(noise_index + 1) & kNoiseMask],
                  n2 = noise[(noise_index + 2) & kNoiseMask];
      noise_index = (noise_index + 3) & kNoiseMask;
      const int32_t index = index_row[x];
      if (index < 0) {
        rgb_row[3 * x + 0] = ToByte(bg[0] + n0);
        rgb_row[3 * x + 1] = ToByte(bg[1] + n1);
        rgb_row[3 * x + 2] = ToByte(bg[2] + n2);
        depth_row[x] = 0.0f;
        id_row[x] = -1;
        continue;
      }
      if (index != cached) {
        const Setup& s = setups_[index];
        qa = s.q[0], qb = s.q[1], qr = s.q[1] * fy + s.q[2];
        ua = s.u[0], ub = s.u[1], ur = s.u[1] * fy + s.u[2];
        va = s.v[0], vb = s.v[1], vr = s.v[1] * fy + s.v[2];
        sa = s.s[0], sr = s.s[1] * fy + s.s[2];
        levels = s.levels;
        max_level = s.max_level;
        object = s.object;
        cached = index;
      }
      const float fx = static_cast<float>(x);
      const float q = qa * fx + qr;
      const float z = 1.0f / q;
      const float u = (ua * fx + ur) * z, v = (va * fx + vr) * z, shade = (sa * fx + sr) * z;
      // Footprint: derivatives of (u, v) along image x and y, in level-0 texels.
      const float dudx = (ua - u * qa) * z, dvdx = (va - v * qa) * z;
      const float dudy = (ub - u * qb) * z, dvdy = (vb - v * qb) * z;
      const float rho2 = std::max(dudx * dudx + dvdx * dvdx, dudy * dudy + dvdy * dvdy);
      float colour[3];
      SampleTexture(levels, max_level, trilinear, u, v, rho2, colour);
      // texture stores R, G, B; the output is BGR
      rgb_row[3 * x + 0] = ToByte(colour[2] * shade + n0);
      rgb_row[3 * x + 1] = ToByte(colour[1] * shade + n1);
      rgb_row[3 * x + 2] = ToByte(colour[0] * shade + n2);
      depth_row[x] = z;
      id_row[x] = object;
    }
  }
}

bool SurfacePointAt(const RenderOutput& render, const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                    double u, double v, Eigen::Vector3d* point_in_world) {
  if (render.depth_mm.empty() || render.depth_mm.type() != CV_32F || render.object_id.type() != CV_32S) return false;
  if (!std::isfinite(u) || !std::isfinite(v)) return false;
  const int width = render.depth_mm.cols, height = render.depth_mm.rows;
  if (width < 2 || height < 2 || u < 0 || v < 0 || u > width - 1 || v > height - 1) return false;
  const int x0 = std::min(static_cast<int>(std::floor(u)), width - 2);
  const int y0 = std::min(static_cast<int>(std::floor(v)), height - 2);
  const double tx = u - x0, ty = v - y0;
  double depth[4];
  int ids[4];
  for (int k = 0; k < 4; ++k) {
    const int x = x0 + (k & 1), y = y0 + (k >> 1);
    depth[k] = render.depth_mm.at<float>(y, x);
    ids[k] = render.object_id.at<int32_t>(y, x);
    if (!(depth[k] > 0) || ids[k] < 0 || ids[k] != ids[0]) return false;
  }
  const double lo = *std::min_element(depth, depth + 4), hi = *std::max_element(depth, depth + 4);
  if (hi > lo * 1.05 || hi - lo > 20.0) return false;  // depth edge
  const double inv =
      (1 - tx) * (1 - ty) / depth[0] + tx * (1 - ty) / depth[1] + (1 - tx) * ty / depth[2] + tx * ty / depth[3];
  const double z = 1.0 / inv;
  const Eigen::Vector3d point_in_camera(z * (u - camera.cx) / camera.fx, z * (v - camera.cy) / camera.fy, z);
  *point_in_world = world_from_camera * point_in_camera;
  return true;
}

}  // namespace objscan
