#include "processes/dense_modeler/mesh_visibility.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace objscan {

bool ValidateMeshVisibilityOptions(const MeshVisibilityOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.min_seen_views < 0) e << "mesh min_seen_views must be >= 0; ";
  if (!(o.min_seen_fraction >= 0 && o.min_seen_fraction <= 1)) e << "mesh min_seen_fraction must be in [0, 1]; ";
  if (!(o.depth_tolerance_mm > 0)) e << "mesh visibility depth tolerance must be > 0; ";
  if (!(o.min_facing_cos >= -1 && o.min_facing_cos < 1)) e << "mesh visibility min facing cos must be in [-1, 1); ";
  if (o.max_views < 1) e << "mesh visibility max views must be >= 1; ";
  const std::string msg = e.str();
  if (why) *why = msg.empty() ? msg : msg.substr(0, msg.size() - 2);
  return msg.empty();
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Projected {
  float u = 0, v = 0, z = -1;  // px, px, mm (z <= 0: not in front of the camera)
};

// Depth of the mesh's nearest surface at every pixel centre (kInf where none), from the projected vertices.
void RenderDepth(const TriangleMesh& mesh, const std::vector<Projected>& p, int width, int height,
                 std::vector<float>* depth) {
  depth->assign(static_cast<size_t>(width) * height, kInf);
  for (const auto& t : mesh.triangles) {
    const Projected &a = p[t[0]], &b = p[t[1]], &c = p[t[2]];
    if (!(a.z > 0 && b.z > 0 && c.z > 0)) continue;
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({a.u, b.u, c.u}))));
    const int x1 = std::min(width - 1, static_cast<int>(std::floor(std::max({a.u, b.u, c.u}))));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({a.v, b.v, c.v}))));
    const int y1 = std::min(height - 1, static_cast<int>(std::floor(std::max({a.v, b.v, c.v}))));
    if (x0 > x1 || y0 > y1) continue;
    const float area = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
    if (std::abs(area) < 1e-12f) continue;
    const float inv_area = 1.0f / area;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        // Barycentric weights from the edge functions; inclusive on the edges (shared edges covered twice is
        // harmless for a minimum), either winding.
        const float wa = ((b.u - x) * (c.v - y) - (b.v - y) * (c.u - x)) * inv_area;
        const float wb = ((c.u - x) * (a.v - y) - (c.v - y) * (a.u - x)) * inv_area;
        const float wc = 1.0f - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        const float z = 1.0f / (wa / a.z + wb / b.z + wc / c.z);  // 1/z is linear in the image
        float& d = (*depth)[static_cast<size_t>(y) * width + x];
        d = std::min(d, z);
      }
  }
}

// Calls fn(vertex, view index, seen) for every vertex (with (*wanted)[vertex] when wanted is given) and every used
// view it faces, in front of the camera and inside the image; seen: not hidden by the mesh (see the header). Returns
// the views used.
template <typename Fn>
int VisitFacingViews(const TriangleMesh& mesh, const std::vector<CarvingView>& views, const MeshVisibilityOptions& o,
                     const std::vector<char>* wanted, Fn&& fn) {
  if (mesh.vertices.empty() || views.empty() || !ValidateMeshVisibilityOptions(o, nullptr)) return 0;
  const std::vector<Eigen::Vector3f> normals = VertexNormals(mesh);
  const size_t stride = (views.size() + static_cast<size_t>(o.max_views) - 1) / static_cast<size_t>(o.max_views);
  std::vector<Projected> projected(mesh.vertices.size());
  std::vector<float> depth;
  int used = 0;
  for (size_t vi = 0; vi < views.size(); vi += stride) {
    const CarvingView& view = views[vi];
    const PinholeCamera& cam = view.camera;
    if (!cam.IsValid()) continue;
    const Eigen::Isometry3d camera_from_world = view.world_from_camera.inverse();
    const Eigen::Vector3f centre = view.world_from_camera.translation().cast<float>();
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      const Eigen::Vector3d pc = camera_from_world * mesh.vertices[i].cast<double>();
      Eigen::Vector2d uv;
      Projected& pr = projected[i];
      pr.z = -1;
      if (!cam.Project(pc, &uv)) continue;
      pr.u = static_cast<float>(uv.x());
      pr.v = static_cast<float>(uv.y());
      pr.z = static_cast<float>(pc.z());
    }
    RenderDepth(mesh, projected, cam.width, cam.height, &depth);
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      if (wanted && !(*wanted)[i]) continue;
      const Projected& pr = projected[i];
      if (!(pr.z > 0) || !cam.InImage(Eigen::Vector2d(pr.u, pr.v))) continue;
      const Eigen::Vector3f to_camera = centre - mesh.vertices[i];
      if (normals[i].squaredNorm() > 0 && normals[i].dot(to_camera) < o.min_facing_cos * to_camera.norm()) continue;
      // The farthest rendered depth of the pixel centres around the vertex: a vertex on the surface is level with
      // its own neighbourhood whatever the slope; an empty pixel (no surface there) hides nothing.
      const int x0 = static_cast<int>(std::floor(pr.u)), y0 = static_cast<int>(std::floor(pr.v));
      float around = 0;
      for (int dy = 0; dy <= 1; ++dy)
        for (int dx = 0; dx <= 1; ++dx) {
          const int x = std::clamp(x0 + dx, 0, cam.width - 1), y = std::clamp(y0 + dy, 0, cam.height - 1);
          around = std::max(around, depth[static_cast<size_t>(y) * cam.width + x]);
        }
      fn(i, static_cast<int>(vi), pr.z <= around + static_cast<float>(o.depth_tolerance_mm));
    }
    ++used;
  }
  return used;
}

}  // namespace

std::vector<VertexViews> CountSeeingViews(const TriangleMesh& mesh, const std::vector<CarvingView>& views,
                                          const MeshVisibilityOptions& o, int* views_used) {
  std::vector<VertexViews> seen(mesh.vertices.size());
  const int used = VisitFacingViews(mesh, views, o, nullptr, [&](size_t i, int, bool is_seen) {
    ++seen[i].facing;
    if (is_seen) ++seen[i].seen;
  });
  if (views_used) *views_used = used;
  return seen;
}

std::vector<std::vector<int>> SeeingViews(const TriangleMesh& mesh, const std::vector<CarvingView>& views,
                                          const MeshVisibilityOptions& o, const std::vector<char>* wanted,
                                          int* views_used) {
  std::vector<std::vector<int>> seeing(mesh.vertices.size());
  const int used = VisitFacingViews(mesh, views, o, wanted, [&](size_t i, int view, bool is_seen) {
    if (is_seen) seeing[i].push_back(view);
  });
  if (views_used) *views_used = used;
  return seeing;
}

MeshVisibilityStats RemoveOccludedMeshParts(TriangleMesh* mesh, const std::vector<CarvingView>& views,
                                            const MeshVisibilityOptions& o) {
  MeshVisibilityStats stats;
  if ((o.min_seen_views <= 0 && o.min_seen_fraction <= 0) || views.empty() || mesh->vertices.empty()) return stats;
  const std::vector<VertexViews> seen = CountSeeingViews(*mesh, views, o, &stats.views);
  if (stats.views == 0) return stats;
  std::vector<char> keep(mesh->vertices.size());
  for (size_t i = 0; i < keep.size(); ++i) {
    keep[i] = seen[i].seen >= o.min_seen_views && seen[i].seen >= o.min_seen_fraction * seen[i].facing;
    if (!keep[i]) ++stats.vertices_removed;
  }
  if (stats.vertices_removed == 0) return stats;
  // Triangles of seen vertices only (KeepMeshTriangles drops the vertices no kept triangle uses).
  std::vector<char> keep_triangle(mesh->triangles.size());
  for (size_t t = 0; t < keep_triangle.size(); ++t) {
    const auto& tri = mesh->triangles[t];
    keep_triangle[t] = keep[tri[0]] && keep[tri[1]] && keep[tri[2]];
  }
  stats.triangles_removed = KeepMeshTriangles(mesh, keep_triangle);
  return stats;
}

}  // namespace objscan
