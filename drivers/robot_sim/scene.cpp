#include "drivers/robot_sim/scene.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "common/ply.h"

namespace objscan {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kChordToleranceMm = 0.05;  // automatic tessellation: max distance chord <-> true surface

bool IsPowerOfTwo(int n) { return n > 0 && (n & (n - 1)) == 0; }

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r\n");
  return s.substr(a, b - a + 1);
}

std::string Fmt(double v) {
  std::ostringstream out;
  out << std::setprecision(10) << v;
  return out.str();
}
std::string Fmt3(const Eigen::Vector3d& v) { return Fmt(v.x()) + "," + Fmt(v.y()) + "," + Fmt(v.z()); }

const char* TypeName(ShapeType t) {
  switch (t) {
    case ShapeType::kFloor:
      return "floor";
    case ShapeType::kSphere:
      return "sphere";
    case ShapeType::kBox:
      return "box";
    case ShapeType::kCylinder:
      return "cylinder";
    case ShapeType::kMesh:
      return "mesh";
  }
  return "?";
}

// HSV (h in [0,1), s, v in [0,1]) to BGR 0..255.
cv::Scalar HsvToBgr(double h, double s, double v) {
  const double h6 = h * 6.0;
  const int i = static_cast<int>(std::floor(h6)) % 6;
  const double f = h6 - std::floor(h6);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (i) {
    case 0:
      r = v;
      g = t;
      b = p;
      break;
    case 1:
      r = q;
      g = v;
      b = p;
      break;
    case 2:
      r = p;
      g = v;
      b = t;
      break;
    case 3:
      r = p;
      g = q;
      b = v;
      break;
    case 4:
      r = t;
      g = p;
      b = v;
      break;
    default:
      r = v;
      g = p;
      b = q;
      break;
  }
  return cv::Scalar(b * 255.0, g * 255.0, r * 255.0);
}

cv::Mat LeavesTexture(const TextureSpec& spec, SimRng& rng) {
  const int n = spec.size;
  cv::Mat img(n, n, CV_8UC3, cv::Scalar(128, 128, 128));
  const double r_min = 2.5, r_max = std::max(4.0, n / 8.0);
  const double k = 1.0 - (r_min * r_min) / (r_max * r_max);
  double painted = 0;
  const double goal = 5.0 * n * n;
  auto random_colour = [&]() {
    const double hue = rng.Uniform();
    const double sat = spec.saturation * rng.Uniform(0.45, 1.0);
    const double val = 0.5 + spec.contrast * (rng.Uniform() - 0.5) * 0.9;
    return HsvToBgr(hue, sat, std::clamp(val, 0.05, 1.0));
  };
  while (painted < goal) {
    // radius with density ~ r^-3 between r_min and r_max: every octave covers the same area (scale invariant)
    const double r = r_min / std::sqrt(1.0 - rng.Uniform() * k);
    const double x = rng.Uniform(0, n), y = rng.Uniform(0, n);
    const int shape = static_cast<int>(rng.NextU64() % 3);
    const double angle = rng.Uniform(0, 2 * kPi);
    const cv::Scalar colour = random_colour();
    painted += kPi * r * r;
    // Draw the copies that touch the image so that the texture tiles seamlessly.
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const double cx = x + dx * n, cy = y + dy * n;
        if (cx + r < 0 || cx - r >= n || cy + r < 0 || cy - r >= n) continue;
        if (shape == 0) {
          cv::circle(img, cv::Point(static_cast<int>(std::lround(cx * 16)), static_cast<int>(std::lround(cy * 16))),
                     static_cast<int>(std::lround(r * 16)), colour, cv::FILLED, cv::LINE_8, 4);
        } else {
          const int corners = shape == 1 ? 4 : 3;
          std::vector<cv::Point> pts;
          for (int c = 0; c < corners; ++c) {
            const double a = angle + 2 * kPi * c / corners;
            pts.emplace_back(static_cast<int>(std::lround((cx + r * std::cos(a)) * 16)),
                             static_cast<int>(std::lround((cy + r * std::sin(a)) * 16)));
          }
          cv::fillConvexPoly(img, pts, colour, cv::LINE_8, 4);
        }
      }
    }
  }
  // Fine grain so that the interiors of large shapes still carry trackable texture.
  for (int y = 0; y < n; ++y) {
    auto* row = img.ptr<uint8_t>(y);
    for (int x = 0; x < 3 * n; ++x) {
      const int noise = static_cast<int>(rng.NextU64() % 25) - 12;
      row[x] = cv::saturate_cast<uint8_t>(row[x] + noise);
    }
  }
  return img;
}

cv::Mat NoiseTexture(const TextureSpec& spec, SimRng& rng) {
  const int n = spec.size;
  cv::Mat acc(n, n, CV_32FC3, cv::Scalar(0, 0, 0));
  double amplitude = 1.0, total = 0;
  for (int cells = 4; cells <= n / 2; cells *= 2) {
    std::vector<float> lattice(static_cast<size_t>(cells * cells * 3));
    for (auto& v : lattice) v = static_cast<float>(rng.Uniform(-1, 1));
    const double scale = static_cast<double>(cells) / n;
    for (int y = 0; y < n; ++y) {
      const double fy = y * scale;
      const int y0 = static_cast<int>(fy) % cells, y1 = (y0 + 1) % cells;
      const double ty = fy - std::floor(fy);
      auto* row = acc.ptr<float>(y);
      for (int x = 0; x < n; ++x) {
        const double fx = x * scale;
        const int x0 = static_cast<int>(fx) % cells, x1 = (x0 + 1) % cells;
        const double tx = fx - std::floor(fx);
        for (int c = 0; c < 3; ++c) {
          const double a = lattice[(y0 * cells + x0) * 3 + c], b = lattice[(y0 * cells + x1) * 3 + c];
          const double d = lattice[(y1 * cells + x0) * 3 + c], e = lattice[(y1 * cells + x1) * 3 + c];
          const double v = (a * (1 - tx) + b * tx) * (1 - ty) + (d * (1 - tx) + e * tx) * ty;
          row[x * 3 + c] += static_cast<float>(amplitude * v);
        }
      }
    }
    total += amplitude;
    amplitude *= 0.8;
  }
  cv::Mat img;
  acc.convertTo(img, CV_8UC3, 127.0 * spec.contrast / total * 1.6, 128.0);
  return img;
}

}  // namespace

uint64_t SimRng::NextU64() {
  // splitmix64
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double SimRng::Uniform() { return static_cast<double>(NextU64() >> 11) * (1.0 / 9007199254740992.0); }

double SimRng::Gaussian() {
  double u1 = Uniform();
  while (u1 <= 1e-300) u1 = Uniform();
  const double u2 = Uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

uint64_t MixSeed(uint64_t a, uint64_t b) {
  SimRng rng(a ^ (b * 0xD1B54A32D192ED03ULL + 0x8CB92BA72F3D8DD7ULL));
  return rng.NextU64();
}

Texture MakeTexture(const cv::Mat& bgr) {
  if (bgr.type() != CV_8UC3 || bgr.rows != bgr.cols || !IsPowerOfTwo(bgr.cols))
    throw std::invalid_argument("texture must be a square power-of-two CV_8UC3 image");
  Texture tex;
  Texture::Level base;
  base.size = bgr.cols;
  base.texels.resize(static_cast<size_t>(base.size) * base.size);
  for (int y = 0; y < base.size; ++y) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    uint32_t* dst = &base.texels[static_cast<size_t>(y) * base.size];
    for (int x = 0; x < base.size; ++x)
      dst[x] = static_cast<uint32_t>(row[3 * x + 2]) | (static_cast<uint32_t>(row[3 * x + 1]) << 8) |
               (static_cast<uint32_t>(row[3 * x + 0]) << 16);
  }
  tex.levels.push_back(std::move(base));
  while (tex.levels.back().size > 1) {
    const Texture::Level& prev = tex.levels.back();
    Texture::Level next;
    next.size = prev.size / 2;
    next.texels.resize(static_cast<size_t>(next.size) * next.size);
    for (int y = 0; y < next.size; ++y) {
      for (int x = 0; x < next.size; ++x) {
        uint32_t packed = 0;
        for (int c = 0; c < 3; ++c) {
          auto at = [&](int yy, int xx) {
            return static_cast<int>((prev.texels[static_cast<size_t>(yy) * prev.size + xx] >> (8 * c)) & 0xff);
          };
          const int sum = at(2 * y, 2 * x) + at(2 * y, 2 * x + 1) + at(2 * y + 1, 2 * x) + at(2 * y + 1, 2 * x + 1);
          packed |= static_cast<uint32_t>((sum + 2) / 4) << (8 * c);
        }
        next.texels[static_cast<size_t>(y) * next.size + x] = packed;
      }
    }
    tex.levels.push_back(std::move(next));
  }
  return tex;
}

cv::Mat MakeProceduralTexture(const TextureSpec& spec) {
  if (!IsPowerOfTwo(spec.size) || spec.size < 16 || spec.size > 4096)
    throw std::invalid_argument("texture_size must be a power of two in 16..4096");
  SimRng rng(MixSeed(spec.seed, 0x7e47));
  if (spec.kind == "leaves") return LeavesTexture(spec, rng);
  if (spec.kind == "noise") return NoiseTexture(spec, rng);
  const cv::Scalar colour(spec.color_bgr.x(), spec.color_bgr.y(), spec.color_bgr.z());
  cv::Mat img(spec.size, spec.size, CV_8UC3, colour);
  if (spec.kind == "checker") {
    const cv::Scalar other(255 - colour[0], 255 - colour[1], 255 - colour[2]);
    const int cell = std::max(1, spec.size / 16);
    for (int y = 0; y < spec.size; y += cell)
      for (int x = 0; x < spec.size; x += cell)
        if (((x / cell) + (y / cell)) % 2) cv::rectangle(img, cv::Rect(x, y, cell, cell), other, cv::FILLED);
    return img;
  }
  if (spec.kind == "solid") return img;
  throw std::invalid_argument("unknown texture kind '" + spec.kind + "' (leaves, noise, checker, solid)");
}

// ---------------------------------------------------------------------------------------------------------------
// Mesh files

namespace {

bool AddPolygon(const std::vector<int64_t>& poly, int64_t num_vertices, RawMesh* out, std::string* error) {
  for (int64_t idx : poly) {
    if (idx < 0 || idx >= num_vertices) {
      *error = "face index " + std::to_string(idx) + " out of range";
      return false;
    }
  }
  for (size_t k = 2; k < poly.size(); ++k)
    out->triangles.emplace_back(static_cast<int>(poly[0]), static_cast<int>(poly[k - 1]), static_cast<int>(poly[k]));
  return true;
}

bool LoadPly(const std::string& data, RawMesh* out, std::string* error) {
  PlyData ply;
  if (!ParsePly(data, &ply, error)) return false;
  for (const auto& p : ply.points)
    if (!p.allFinite()) {
      *error = "PLY vertex not finite";
      return false;
    }
  out->positions = std::move(ply.points);
  out->triangles = std::move(ply.triangles);
  return true;
}

bool LoadObj(const std::string& data, RawMesh* out, std::string* error) {
  std::istringstream in(data);
  std::string line;
  std::vector<std::vector<int64_t>> faces;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream words(line);
    std::string tag;
    words >> tag;
    if (tag == "v") {
      Eigen::Vector3d p;
      if (!(words >> p.x() >> p.y() >> p.z()) || !p.allFinite()) {
        *error = "OBJ line " + std::to_string(line_number) + ": bad vertex";
        return false;
      }
      out->positions.push_back(p);
    } else if (tag == "f") {
      std::vector<int64_t> poly;
      std::string token;
      while (words >> token) {
        const std::string first = token.substr(0, token.find('/'));
        try {
          int64_t idx = std::stoll(first);
          idx = idx < 0 ? static_cast<int64_t>(out->positions.size()) + idx : idx - 1;
          poly.push_back(idx);
        } catch (const std::exception&) {
          *error = "OBJ line " + std::to_string(line_number) + ": bad face index '" + token + "'";
          return false;
        }
      }
      if (poly.size() < 3) {
        *error = "OBJ line " + std::to_string(line_number) + ": face with fewer than 3 vertices";
        return false;
      }
      faces.push_back(poly);
    }
  }
  for (const auto& poly : faces)
    if (!AddPolygon(poly, static_cast<int64_t>(out->positions.size()), out, error)) return false;
  return true;
}

}  // namespace

bool LoadMeshFile(const std::string& path, RawMesh* out, std::string* error) {
  *out = RawMesh();
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    *error = "cannot read mesh file " + path;
    return false;
  }
  std::ostringstream buffer;
  buffer << file.rdbuf();
  const std::string data = buffer.str();
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  bool ok = false;
  if (ext == ".ply")
    ok = LoadPly(data, out, error);
  else if (ext == ".obj")
    ok = LoadObj(data, out, error);
  else
    *error = "mesh file must end in .ply or .obj";
  if (ok && out->triangles.empty()) {
    *error = "mesh has no faces";
    ok = false;
  }
  if (!ok) *error = path + ": " + *error;
  return ok;
}

bool WritePly(const std::string& path, const std::vector<Eigen::Vector3f>& points,
              const std::vector<Eigen::Vector3f>& normals, const std::vector<Eigen::Vector3i>& faces, bool ascii) {
  const bool with_normals = !normals.empty() && normals.size() == points.size();
  PlyLayout layout;
  layout.binary = !ascii;
  layout.comments = {"objscan robot_sim, mm"};
  layout.vertex_properties = PlyXyz();
  if (with_normals)
    for (const char* n : {"nx", "ny", "nz"}) layout.vertex_properties.push_back({n, PlyScalar::kFloat});
  std::string error;
  return WritePlyFile(
      path, layout, points.size(),
      [&](size_t i, double* row) {
        for (int k = 0; k < 3; ++k) row[k] = points[i][k];
        if (with_normals)
          for (int k = 0; k < 3; ++k) row[3 + k] = normals[i][k];
      },
      faces.empty() ? nullptr : &faces, &error);
}

// ---------------------------------------------------------------------------------------------------------------
// Tessellation

namespace {

Eigen::Matrix3d Yaw(double yaw) { return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

int AutoSegments(double radius) {
  const double step = std::acos(std::max(0.0, 1.0 - kChordToleranceMm / std::max(radius, 1e-3)));
  return std::clamp(static_cast<int>(std::ceil(2 * kPi / std::max(step * 2, 1e-6))), 24, 256);
}

void AddVertex(TriangleMesh* m, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double u, double v) {
  m->positions.push_back(p.cast<float>());
  m->normals.push_back(n.normalized().cast<float>());
  m->uvs.emplace_back(static_cast<float>(u), static_cast<float>(v));
}

void TessellateFloor(const SceneObject& o, TriangleMesh* m) {
  const double h = o.size_mm.x() / 2, t = o.texture.texel_mm;
  const Eigen::Vector3d up(0, 0, 1);
  const double xs[4] = {-h, h, h, -h}, ys[4] = {-h, -h, h, h};
  for (int i = 0; i < 4; ++i) AddVertex(m, Eigen::Vector3d(xs[i], ys[i], 0), up, xs[i] / t, ys[i] / t);
  m->triangles.emplace_back(0, 1, 2);
  m->triangles.emplace_back(0, 2, 3);
  m->closed = true;  // single-sided: seen from above only
}

void TessellateSphere(const SceneObject& o, TriangleMesh* m) {
  const int around = o.segments > 0 ? o.segments : AutoSegments(o.radius_mm);
  const int rings = std::max(3, around / 2);
  const double r = o.radius_mm, t = o.texture.texel_mm, size = o.texture.size;
  const double repeats = std::max(1.0, std::round(2 * kPi * r / (t * size)));
  for (int i = 0; i <= rings; ++i) {
    const double theta = kPi * i / rings;
    for (int j = 0; j <= around; ++j) {
      const double phi = 2 * kPi * j / around;
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      AddVertex(m, o.center_mm + r * n, n, repeats * size * j / around, theta * r / t);
    }
  }
  auto index = [&](int i, int j) { return i * (around + 1) + j; };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < around; ++j) {
      if (i > 0) m->triangles.emplace_back(index(i, j), index(i + 1, j + 1), index(i, j + 1));
      if (i < rings - 1) m->triangles.emplace_back(index(i, j), index(i + 1, j), index(i + 1, j + 1));
    }
  }
  // Fix winding so that the normal points outwards: (v00, v10, v11) has normal +radial with theta downwards.
  m->closed = true;
}

void TessellateBox(const SceneObject& o, TriangleMesh* m) {
  const Eigen::Matrix3d rot = Yaw(o.yaw_rad);
  const Eigen::Vector3d h = o.size_mm / 2;
  const double t = o.texture.texel_mm;
  for (int face = 0; face < 6; ++face) {
    const int axis = face / 2;
    const double sign = face % 2 == 0 ? 1.0 : -1.0;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[axis] = sign;
    Eigen::Vector3d a = Eigen::Vector3d::Zero();
    a[(axis + 1) % 3] = 1.0;
    const Eigen::Vector3d b = n.cross(a);  // a x b = n
    const double ha = h[(axis + 1) % 3], hb = h[(axis + 2) % 3];
    const double offset = 173.0 * face;  // texels: every face shows another part of the texture
    const double sa[4] = {-1, 1, 1, -1}, sb[4] = {-1, -1, 1, 1};
    const int first = static_cast<int>(m->positions.size());
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector3d local = n * std::abs(n.dot(h)) + a * sa[c] * ha + b * sb[c] * hb;
      AddVertex(m, o.center_mm + rot * local, rot * n, (sa[c] * ha) / t + offset, (sb[c] * hb) / t + offset);
    }
    m->triangles.emplace_back(first, first + 1, first + 2);
    m->triangles.emplace_back(first, first + 2, first + 3);
  }
  m->closed = true;
}

void TessellateCylinder(const SceneObject& o, TriangleMesh* m) {
  const int around = o.segments > 0 ? o.segments : AutoSegments(o.radius_mm);
  const Eigen::Matrix3d rot = Yaw(o.yaw_rad);
  const double r = o.radius_mm, hh = o.height_mm / 2, t = o.texture.texel_mm, size = o.texture.size;
  const double repeats = std::max(1.0, std::round(2 * kPi * r / (t * size)));
  const int side = static_cast<int>(m->positions.size());
  for (int j = 0; j <= around; ++j) {
    const double phi = 2 * kPi * j / around;
    const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0);
    for (int k = 0; k < 2; ++k) {
      const double z = k == 0 ? -hh : hh;
      AddVertex(m, o.center_mm + rot * (r * radial + Eigen::Vector3d(0, 0, z)), rot * radial,
                repeats * size * j / around, z / t);
    }
  }
  for (int j = 0; j < around; ++j) {
    const int b0 = side + 2 * j, t0 = b0 + 1, b1 = b0 + 2, t1 = b0 + 3;
    m->triangles.emplace_back(b0, b1, t1);
    m->triangles.emplace_back(b0, t1, t0);
  }
  for (int k = 0; k < 2; ++k) {
    const double z = k == 0 ? -hh : hh;
    const Eigen::Vector3d n(0, 0, k == 0 ? -1 : 1);
    const double offset = 311.0 * (k + 1);
    const int centre = static_cast<int>(m->positions.size());
    AddVertex(m, o.center_mm + rot * Eigen::Vector3d(0, 0, z), n, offset, offset);
    for (int j = 0; j <= around; ++j) {
      const double phi = 2 * kPi * j / around;
      const double x = r * std::cos(phi), y = r * std::sin(phi);
      AddVertex(m, o.center_mm + rot * Eigen::Vector3d(x, y, z), n, x / t + offset, y / t + offset);
    }
    for (int j = 0; j < around; ++j) {
      if (k == 1)
        m->triangles.emplace_back(centre, centre + 1 + j, centre + 2 + j);
      else
        m->triangles.emplace_back(centre, centre + 2 + j, centre + 1 + j);
    }
  }
  m->closed = true;
}

// Places the raw mesh (scale, yaw, centre / on_floor) and returns the placed vertices.
std::vector<Eigen::Vector3d> PlaceMesh(const SceneObject& o, std::vector<Eigen::Vector3d>* local_out) {
  const Eigen::Matrix3d rot = Yaw(o.yaw_rad);
  std::vector<Eigen::Vector3d> local, placed;
  Eigen::AlignedBox3d box;
  for (const auto& p : o.raw_mesh.positions) {
    local.push_back(o.mesh_scale * p);
    box.extend(rot * local.back());
  }
  Eigen::Vector3d shift = o.center_mm - box.center();
  if (o.on_floor) shift.z() = -box.min().z();
  for (const auto& p : local) placed.push_back(rot * p + shift);
  if (local_out) *local_out = local;
  return placed;
}

void TessellateMesh(const SceneObject& o, TriangleMesh* m) {
  std::vector<Eigen::Vector3d> local;
  const std::vector<Eigen::Vector3d> placed = PlaceMesh(o, &local);
  std::vector<Eigen::Vector3i> tris = o.raw_mesh.triangles;
  // Orient outwards: a negative signed volume means the file winds clockwise.
  double volume = 0;
  for (const auto& f : tris) volume += placed[f[0]].dot(placed[f[1]].cross(placed[f[2]]));
  if (volume < 0)
    for (auto& f : tris) std::swap(f[1], f[2]);
  std::vector<Eigen::Vector3d> vertex_normals(placed.size(), Eigen::Vector3d::Zero());
  for (const auto& f : tris)
    for (int k = 0; k < 3; ++k)
      vertex_normals[f[k]] += (placed[f[1]] - placed[f[0]]).cross(placed[f[2]] - placed[f[0]]);
  const Eigen::Matrix3d rot = Yaw(o.yaw_rad);
  const double t = o.texture.texel_mm;
  for (const auto& f : tris) {
    const Eigen::Vector3d face_normal = (placed[f[1]] - placed[f[0]]).cross(placed[f[2]] - placed[f[0]]);
    if (face_normal.norm() <= 0) continue;
    const Eigen::Vector3d local_normal = rot.transpose() * face_normal;
    int axis = 0;
    local_normal.cwiseAbs().maxCoeff(&axis);  // planar projection along the dominant axis
    const int first = static_cast<int>(m->positions.size());
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& l = local[f[k]];
      const double u = l[(axis + 1) % 3] / t + 211.0 * axis, v = l[(axis + 2) % 3] / t + 97.0 * axis;
      const Eigen::Vector3d n = vertex_normals[f[k]].norm() > 0 ? vertex_normals[f[k]] : face_normal;
      AddVertex(m, placed[f[k]], n, u, v);
    }
    m->triangles.emplace_back(first, first + 1, first + 2);
  }
  m->closed = false;  // files may be open surfaces: no back-face culling
}

void Tessellate(SceneObject* o) {
  o->mesh = TriangleMesh();
  switch (o->type) {
    case ShapeType::kFloor:
      TessellateFloor(*o, &o->mesh);
      break;
    case ShapeType::kSphere:
      TessellateSphere(*o, &o->mesh);
      break;
    case ShapeType::kBox:
      TessellateBox(*o, &o->mesh);
      break;
    case ShapeType::kCylinder:
      TessellateCylinder(*o, &o->mesh);
      break;
    case ShapeType::kMesh:
      TessellateMesh(*o, &o->mesh);
      break;
  }
  o->bounds.setEmpty();
  for (const auto& p : o->mesh.positions) o->bounds.extend(p.cast<double>());
  if (o->type == ShapeType::kSphere) {  // exact bounds for the analytic shape
    o->bounds = Eigen::AlignedBox3d(o->center_mm - Eigen::Vector3d::Constant(o->radius_mm),
                                    o->center_mm + Eigen::Vector3d::Constant(o->radius_mm));
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Parsing

double ParseDouble(const std::string& key, const std::string& v) {
  try {
    size_t used = 0;
    const double d = std::stod(v, &used);
    if (used != v.size() || !std::isfinite(d)) throw std::invalid_argument(v);
    return d;
  } catch (const std::exception&) {
    throw std::runtime_error(key + ": '" + v + "' is not a finite number");
  }
}

Eigen::Vector3d ParseVector3(const std::string& key, const std::string& v) {
  std::vector<std::string> parts(1);  // every field, empty ones too ("1,2,3," has four)
  for (char ch : v) {
    if (ch == ',')
      parts.emplace_back();
    else
      parts.back() += ch;
  }
  if (parts.size() != 3) throw std::runtime_error(key + ": expected x,y,z, got '" + v + "'");
  return Eigen::Vector3d(ParseDouble(key, parts[0]), ParseDouble(key, parts[1]), ParseDouble(key, parts[2]));
}

bool ParseBool(const std::string& key, const std::string& v) {
  if (v == "true" || v == "1" || v == "yes") return true;
  if (v == "false" || v == "0" || v == "no") return false;
  throw std::runtime_error(key + ": expected true or false, got '" + v + "'");
}

uint64_t ParseSeed(const std::string& key, const std::string& v) {
  try {
    size_t used = 0;
    const unsigned long long s = std::stoull(v, &used);
    if (used != v.size() || v[0] == '-') throw std::invalid_argument(v);
    return s;
  } catch (const std::exception&) {
    throw std::runtime_error(key + ": '" + v + "' is not a non-negative integer");
  }
}

// The `robot start=x,y,yaw_deg [pan=deg] [tilt=deg]` line; marks the keys it reads in *used.
RobotStart ParseRobotStart(const std::map<std::string, std::string>& kv, std::set<std::string>* used) {
  RobotStart start;
  const auto it = kv.find("start");
  if (it == kv.end()) throw std::runtime_error("robot: start=x,y,yaw_deg is required");
  used->insert("start");
  const Eigen::Vector3d pose = ParseVector3("start", it->second);
  if (std::abs(pose.x()) > RobotStart::kMaxCoordinateMm || std::abs(pose.y()) > RobotStart::kMaxCoordinateMm)
    throw std::runtime_error("robot: start x, y must be within +-" + Fmt(RobotStart::kMaxCoordinateMm) + " mm");
  if (std::abs(pose.z()) > 360) throw std::runtime_error("robot: start yaw must be in [-360, 360] deg");
  start.x_mm = pose.x();
  start.y_mm = pose.y();
  start.theta_rad = std::atan2(std::sin(pose.z() * kPi / 180.0), std::cos(pose.z() * kPi / 180.0));
  if (kv.count("pan")) {
    used->insert("pan");
    const double pan = ParseDouble("pan", kv.at("pan"));
    if (std::abs(pan) > 180) throw std::runtime_error("robot: pan must be in [-180, 180] deg");
    start.pan_rad = pan * kPi / 180.0;
  }
  if (kv.count("tilt")) {
    used->insert("tilt");
    const double tilt = ParseDouble("tilt", kv.at("tilt"));
    if (std::abs(tilt) > 90) throw std::runtime_error("robot: tilt must be in [-90, 90] deg");
    start.tilt_rad = tilt * kPi / 180.0;
  }
  return start;
}

std::string JoinPath(const std::string& dir, const std::string& file) {
  if (file.empty() || file[0] == '/' || dir.empty()) return file;
  return dir + "/" + file;
}

}  // namespace

std::string SceneObject::Describe() const {
  std::ostringstream out;
  out << TypeName(type) << " name=" << name;
  if (type == ShapeType::kFloor) {
    out << " size=" << Fmt(size_mm.x());
  } else {
    out << " center=" << Fmt3(center_mm);
    if (type == ShapeType::kSphere) out << " radius=" << Fmt(radius_mm);
    if (type == ShapeType::kBox) out << " size=" << Fmt3(size_mm);
    if (type == ShapeType::kCylinder) out << " radius=" << Fmt(radius_mm) << " height=" << Fmt(height_mm);
    if (type == ShapeType::kMesh)
      out << " file=" << mesh_path << " scale=" << Fmt(mesh_scale) << " on_floor=" << (on_floor ? "true" : "false");
    if (type != ShapeType::kSphere) out << " yaw=" << Fmt(yaw_rad * 180.0 / kPi);
    out << " target=" << (is_target ? "true" : "false") << " segments=" << segments;
  }
  out << " texture=" << texture.kind << " seed=" << texture.seed << " texel_mm=" << Fmt(texture.texel_mm)
      << " texture_size=" << texture.size << " saturation=" << Fmt(texture.saturation)
      << " contrast=" << Fmt(texture.contrast) << " color=" << Fmt3(texture.color_bgr);
  out << "   # bounds_min=" << Fmt3(bounds.min()) << " bounds_max=" << Fmt3(bounds.max())
      << " triangles=" << mesh.triangles.size();
  return out.str();
}

std::string Scene::Describe() const {
  std::ostringstream out;
  out << "# objscan robot_sim scene (resolved; lengths mm, angles deg, world z up, floor z = 0)\n";
  if (!path.empty()) out << "# source: " << path << "\n";
  out << "scene seed=" << seed << " background=" << Fmt3(background_bgr) << "\n";
  out << "light direction=" << Fmt3(light.direction) << " ambient=" << Fmt(light.ambient)
      << " diffuse=" << Fmt(light.diffuse) << "\n";
  if (has_robot_start)
    out << "robot start=" << Fmt(robot_start.x_mm) << "," << Fmt(robot_start.y_mm) << ","
        << Fmt(robot_start.theta_rad * 180.0 / kPi) << " pan=" << Fmt(robot_start.pan_rad * 180.0 / kPi)
        << " tilt=" << Fmt(robot_start.tilt_rad * 180.0 / kPi) << "\n";
  for (const auto& o : objects) out << o.Describe() << "\n";
  return out.str();
}

const char* ShapeName(ShapeType type) { return TypeName(type); }

OrientedBox ObjectBox(const SceneObject& o) {
  OrientedBox box;
  box.yaw_rad = o.type == ShapeType::kSphere ? 0.0 : o.yaw_rad;
  switch (o.type) {
    case ShapeType::kSphere:
      box.center_mm = o.center_mm;
      box.size_mm = Eigen::Vector3d::Constant(2 * o.radius_mm);
      return box;
    case ShapeType::kBox:
      box.center_mm = o.center_mm;
      box.size_mm = o.size_mm;
      return box;
    case ShapeType::kCylinder:
      box.center_mm = o.center_mm;
      box.size_mm = Eigen::Vector3d(2 * o.radius_mm, 2 * o.radius_mm, o.height_mm);
      return box;
    case ShapeType::kFloor:
      box.size_mm = Eigen::Vector3d(o.size_mm.x(), o.size_mm.x(), 0);
      return box;
    case ShapeType::kMesh:
      break;
  }
  // Mesh: extents of the placed vertices in the yawed frame.
  const Eigen::Matrix3d object_from_world = Yaw(o.yaw_rad).transpose();
  Eigen::AlignedBox3d local;
  for (const Eigen::Vector3f& p : o.mesh.positions) local.extend(object_from_world * p.cast<double>());
  if (local.isEmpty()) return box;
  box.center_mm = Yaw(o.yaw_rad) * local.center();
  box.size_mm = local.sizes();
  return box;
}

Scene ParseScene(const std::string& text, const std::string& base_dir, const std::string& path) {
  Scene scene;
  scene.path = path;
  std::istringstream in(text);
  std::string raw_line;
  int line_number = 0;
  int robot_line = 0;  // line of the robot item (0 = none yet)
  while (std::getline(in, raw_line)) {
    ++line_number;
    const std::string where = (path.empty() ? std::string("scene") : path) + ":" + std::to_string(line_number) + ": ";
    std::string line = raw_line.substr(0, raw_line.find('#'));
    line = Trim(line);
    if (line.empty()) continue;
    std::istringstream words(line);
    std::string type;
    words >> type;
    std::map<std::string, std::string> kv;
    std::string token;
    while (words >> token) {
      const size_t eq = token.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == token.size())
        throw std::runtime_error(where + "expected key=value, got '" + token + "'");
      if (!kv.emplace(token.substr(0, eq), token.substr(eq + 1)).second)
        throw std::runtime_error(where + "key '" + token.substr(0, eq) + "' given twice");
    }
    std::set<std::string> used;
    auto has = [&](const std::string& k) { return kv.count(k) > 0; };
    auto get = [&](const std::string& k) {
      used.insert(k);
      return kv.at(k);
    };
    try {
      if (type == "scene") {
        if (has("seed")) scene.seed = ParseSeed("seed", get("seed"));
        if (has("background")) scene.background_bgr = ParseVector3("background", get("background"));
      } else if (type == "light") {
        if (has("direction")) scene.light.direction = ParseVector3("direction", get("direction"));
        if (has("ambient")) scene.light.ambient = ParseDouble("ambient", get("ambient"));
        if (has("diffuse")) scene.light.diffuse = ParseDouble("diffuse", get("diffuse"));
        if (scene.light.direction.norm() < 1e-9) throw std::runtime_error("direction must not be zero");
        if (scene.light.ambient < 0 || scene.light.diffuse < 0) throw std::runtime_error("ambient/diffuse < 0");
      } else if (type == "robot") {
        if (robot_line > 0)
          throw std::runtime_error("robot: only one robot line is allowed (the first is line " +
                                   std::to_string(robot_line) + ")");
        robot_line = line_number;
        scene.robot_start = ParseRobotStart(kv, &used);
        scene.has_robot_start = true;
      } else {
        SceneObject o;
        if (type == "floor")
          o.type = ShapeType::kFloor;
        else if (type == "sphere")
          o.type = ShapeType::kSphere;
        else if (type == "box")
          o.type = ShapeType::kBox;
        else if (type == "cylinder")
          o.type = ShapeType::kCylinder;
        else if (type == "mesh")
          o.type = ShapeType::kMesh;
        else
          throw std::runtime_error("unknown item '" + type +
                                   "' (scene, light, robot, floor, sphere, box, cylinder, mesh)");
        o.id = static_cast<int>(scene.objects.size());
        o.name = has("name") ? get("name") : type + std::to_string(o.id);
        o.texture.seed = scene.seed * 1000 + static_cast<uint64_t>(o.id) + 1;
        if (o.type == ShapeType::kFloor) {
          o.size_mm.x() = 20000;
          o.texture.texel_mm = 1.5;
          o.texture.saturation = 0.35;
          o.texture.contrast = 0.6;
          if (has("size")) o.size_mm.x() = ParseDouble("size", get("size"));
          if (o.size_mm.x() <= 0) throw std::runtime_error("size must be > 0");
        } else {
          if (has("center"))
            o.center_mm = ParseVector3("center", get("center"));
          else if (o.type != ShapeType::kMesh)
            throw std::runtime_error("center=x,y,z is required");
          if (has("yaw")) o.yaw_rad = ParseDouble("yaw", get("yaw")) * kPi / 180.0;
          if (has("target")) o.is_target = ParseBool("target", get("target"));
          if (has("segments")) o.segments = static_cast<int>(ParseDouble("segments", get("segments")));
          if (o.segments != 0 && (o.segments < 3 || o.segments > 1024))
            throw std::runtime_error("segments must be 0 (automatic) or 3..1024");
        }
        if (o.type == ShapeType::kSphere || o.type == ShapeType::kCylinder) {
          if (has("radius")) o.radius_mm = ParseDouble("radius", get("radius"));
          if (o.radius_mm <= 0) throw std::runtime_error("radius must be > 0");
        }
        if (o.type == ShapeType::kCylinder) {
          if (has("height")) o.height_mm = ParseDouble("height", get("height"));
          if (o.height_mm <= 0) throw std::runtime_error("height must be > 0");
        }
        if (o.type == ShapeType::kBox) {
          if (has("size")) o.size_mm = ParseVector3("size", get("size"));
          if (o.size_mm.minCoeff() <= 0) throw std::runtime_error("size must be > 0");
        }
        if (o.type == ShapeType::kMesh) {
          if (!has("file")) throw std::runtime_error("file= is required");
          o.mesh_path = JoinPath(base_dir, get("file"));
          if (has("scale")) o.mesh_scale = ParseDouble("scale", get("scale"));
          if (o.mesh_scale <= 0) throw std::runtime_error("scale must be > 0");
          if (has("on_floor")) o.on_floor = ParseBool("on_floor", get("on_floor"));
          std::string error;
          if (!LoadMeshFile(o.mesh_path, &o.raw_mesh, &error)) throw std::runtime_error(error);
        }
        if (has("texture")) o.texture.kind = get("texture");
        if (has("seed")) o.texture.seed = ParseSeed("seed", get("seed"));
        if (has("texel_mm")) o.texture.texel_mm = ParseDouble("texel_mm", get("texel_mm"));
        if (has("texture_size")) o.texture.size = static_cast<int>(ParseDouble("texture_size", get("texture_size")));
        if (has("saturation")) o.texture.saturation = ParseDouble("saturation", get("saturation"));
        if (has("contrast")) o.texture.contrast = ParseDouble("contrast", get("contrast"));
        if (has("color")) o.texture.color_bgr = ParseVector3("color", get("color"));
        if (o.texture.texel_mm <= 0) throw std::runtime_error("texel_mm must be > 0");
        if (o.texture.saturation < 0 || o.texture.saturation > 1 || o.texture.contrast < 0 || o.texture.contrast > 1)
          throw std::runtime_error("saturation and contrast must be in 0..1");
        o.texture_maps = std::make_shared<Texture>(MakeTexture(MakeProceduralTexture(o.texture)));
        Tessellate(&o);
        scene.objects.push_back(std::move(o));
      }
      for (const auto& [k, v] : kv)
        if (!used.count(k)) throw std::runtime_error("unknown key '" + k + "' for " + type);
    } catch (const std::exception& e) {
      throw std::runtime_error(where + e.what());
    }
  }
  scene.light.direction.normalize();
  int first_object = -1;
  for (const auto& o : scene.objects) {
    if (o.is_target) {
      if (scene.target_index >= 0) throw std::runtime_error("scene: more than one object has target=true");
      scene.target_index = o.id;
    }
    if (first_object < 0 && o.type != ShapeType::kFloor) first_object = o.id;
  }
  if (first_object < 0) throw std::runtime_error("scene: no object (sphere, box, cylinder or mesh)");
  if (scene.target_index < 0) {
    scene.target_index = first_object;
    scene.objects[first_object].is_target = true;
  }
  if (scene.objects[scene.target_index].type == ShapeType::kFloor)
    throw std::runtime_error("scene: the floor cannot be the target");
  return scene;
}

Scene LoadScene(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error("cannot read scene file " + path);
  std::ostringstream buffer;
  buffer << file.rdbuf();
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash);
  return ParseScene(buffer.str(), dir, path);
}

// ---------------------------------------------------------------------------------------------------------------
// Surface sampling

std::vector<SurfaceSample> SampleSurface(const SceneObject& o, double points_per_mm2, uint64_t seed) {
  std::vector<SurfaceSample> out;
  SimRng rng(MixSeed(seed, 0x5a3f));
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    if (p.z() < 0.5) return;
    out.push_back({p.cast<float>(), n.normalized().cast<float>()});
  };
  auto count_for = [&](double area) {
    const double expected = area * points_per_mm2;
    int64_t n = static_cast<int64_t>(std::floor(expected));
    if (rng.Uniform() < expected - n) ++n;
    return n;
  };
  const Eigen::Matrix3d rot = Yaw(o.yaw_rad);
  switch (o.type) {
    case ShapeType::kFloor:
      break;
    case ShapeType::kSphere: {
      const int64_t n = count_for(4 * kPi * o.radius_mm * o.radius_mm);
      for (int64_t i = 0; i < n; ++i) {
        const double z = rng.Uniform(-1, 1), phi = rng.Uniform(0, 2 * kPi), s = std::sqrt(1 - z * z);
        const Eigen::Vector3d d(s * std::cos(phi), s * std::sin(phi), z);
        add(o.center_mm + o.radius_mm * d, d);
      }
      break;
    }
    case ShapeType::kBox: {
      const Eigen::Vector3d h = o.size_mm / 2;
      for (int axis = 0; axis < 3; ++axis) {
        const int a = (axis + 1) % 3, b = (axis + 2) % 3;
        for (double sign : {1.0, -1.0}) {
          const int64_t n = count_for(4 * h[a] * h[b]);
          for (int64_t i = 0; i < n; ++i) {
            Eigen::Vector3d local, normal = Eigen::Vector3d::Zero();
            local[axis] = sign * h[axis];
            local[a] = rng.Uniform(-h[a], h[a]);
            local[b] = rng.Uniform(-h[b], h[b]);
            normal[axis] = sign;
            add(o.center_mm + rot * local, rot * normal);
          }
        }
      }
      break;
    }
    case ShapeType::kCylinder: {
      const double r = o.radius_mm, hh = o.height_mm / 2;
      const int64_t n_side = count_for(2 * kPi * r * o.height_mm);
      for (int64_t i = 0; i < n_side; ++i) {
        const double phi = rng.Uniform(0, 2 * kPi);
        const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0);
        add(o.center_mm + rot * (r * radial + Eigen::Vector3d(0, 0, rng.Uniform(-hh, hh))), rot * radial);
      }
      for (double sign : {1.0, -1.0}) {
        const int64_t n_cap = count_for(kPi * r * r);
        for (int64_t i = 0; i < n_cap; ++i) {
          const double rr = r * std::sqrt(rng.Uniform()), phi = rng.Uniform(0, 2 * kPi);
          add(o.center_mm + rot * Eigen::Vector3d(rr * std::cos(phi), rr * std::sin(phi), sign * hh),
              Eigen::Vector3d(0, 0, sign));
        }
      }
      break;
    }
    case ShapeType::kMesh: {
      const auto& m = o.mesh;
      std::vector<double> cumulative;
      double total = 0;
      for (const auto& f : m.triangles) {
        const Eigen::Vector3d a = m.positions[f[0]].cast<double>(), b = m.positions[f[1]].cast<double>(),
                              c = m.positions[f[2]].cast<double>();
        total += 0.5 * (b - a).cross(c - a).norm();
        cumulative.push_back(total);
      }
      const int64_t n = count_for(total);
      for (int64_t i = 0; i < n; ++i) {
        const double pick = rng.Uniform() * total;
        const size_t t = std::min(
            cumulative.size() - 1,
            static_cast<size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin()));
        const auto& f = m.triangles[t];
        const Eigen::Vector3d a = m.positions[f[0]].cast<double>(), b = m.positions[f[1]].cast<double>(),
                              c = m.positions[f[2]].cast<double>();
        double s = rng.Uniform(), q = rng.Uniform();
        if (s + q > 1) {
          s = 1 - s;
          q = 1 - q;
        }
        add(a + s * (b - a) + q * (c - a), (b - a).cross(c - a));
      }
      break;
    }
  }
  return out;
}

}  // namespace objscan
