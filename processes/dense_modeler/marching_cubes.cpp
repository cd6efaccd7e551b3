#include "processes/dense_modeler/marching_cubes.h"

#include <cmath>

#include <algorithm>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>

#include "common/geometry.h"
#include "common/point_grid.h"

namespace objscan {
namespace {

// Cube corner c has offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). Kuhn split: the 6 monotone paths 0 -> 7.
constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

struct EdgeKeyHash {
  size_t operator()(const std::pair<int64_t, int64_t>& k) const {
    return std::hash<int64_t>()(k.first * 0x9E3779B97F4A7C15LL ^ k.second);
  }
};

}  // namespace

TriangleMesh ExtractIsosurface(const ScalarVolume& vol, float iso) {
  TriangleMesh mesh;
  if (vol.nx < 2 || vol.ny < 2 || vol.nz < 2 || vol.values.size() != static_cast<size_t>(vol.nx) * vol.ny * vol.nz)
    return mesh;
  const bool has_color = vol.bgr.size() == vol.values.size();
  std::unordered_map<std::pair<int64_t, int64_t>, int32_t, EdgeKeyHash> edge_vertex;
  auto position = [&](int64_t idx) {
    const int64_t x = idx % vol.nx, y = (idx / vol.nx) % vol.ny, z = idx / (static_cast<int64_t>(vol.nx) * vol.ny);
    return Eigen::Vector3d(vol.origin + Eigen::Vector3d(x, y, z) * vol.spacing);
  };
  // Vertex on the edge (inside sample a, outside sample b).
  auto vertex = [&](int64_t a, int64_t b) {
    const std::pair<int64_t, int64_t> key(std::min(a, b), std::max(a, b));
    auto it = edge_vertex.find(key);
    if (it != edge_vertex.end()) return it->second;
    const double va = vol.values[a], vb = vol.values[b];
    const double t = va == vb ? 0.5 : std::clamp((iso - va) / (vb - va), 0.0, 1.0);
    const Eigen::Vector3d p = position(a) + t * (position(b) - position(a));
    const int32_t id = static_cast<int32_t>(mesh.vertices.size());
    mesh.vertices.push_back(p.cast<float>());
    mesh.bgr.push_back(has_color ? vol.bgr[a] : std::array<uint8_t, 3>{{160, 160, 160}});
    edge_vertex.emplace(key, id);
    return id;
  };
  // Orientation is decided on the edge midpoints (never degenerate, unlike the interpolated vertices when a sample
  // equals iso): the midpoint triangle/quad of a tetrahedron separates its inside corners from its outside ones.
  using Edge = std::pair<int64_t, int64_t>;
  auto emit = [&](const Edge& e0, const Edge& e1, const Edge& e2, const Eigen::Vector3d& inside,
                  const Eigen::Vector3d& outside) {
    const Eigen::Vector3d m0 = 0.5 * (position(e0.first) + position(e0.second));
    const Eigen::Vector3d m1 = 0.5 * (position(e1.first) + position(e1.second));
    const Eigen::Vector3d m2 = 0.5 * (position(e2.first) + position(e2.second));
    int32_t i0 = vertex(e0.first, e0.second), i1 = vertex(e1.first, e1.second), i2 = vertex(e2.first, e2.second);
    if ((m1 - m0).cross(m2 - m0).dot(outside - inside) < 0) std::swap(i1, i2);
    mesh.triangles.push_back({i0, i1, i2});
  };
  const int64_t sx = 1, sy = vol.nx, sz = static_cast<int64_t>(vol.nx) * vol.ny;
  for (int z = 0; z + 1 < vol.nz; ++z) {
    for (int y = 0; y + 1 < vol.ny; ++y) {
      for (int x = 0; x + 1 < vol.nx; ++x) {
        int64_t corner[8];
        bool any_in = false, any_out = false, undefined = false;
        for (int c = 0; c < 8; ++c) {
          corner[c] = vol.Index(x, y, z) + (c & 1) * sx + ((c >> 1) & 1) * sy + ((c >> 2) & 1) * sz;
          undefined |= !std::isfinite(vol.values[corner[c]]);
          (vol.values[corner[c]] > iso ? any_in : any_out) = true;
        }
        if (undefined || !any_in || !any_out) continue;
        for (const auto& tet : kTets) {
          int64_t in[4], out[4];
          int n_in = 0, n_out = 0;
          for (int k = 0; k < 4; ++k) {
            const int64_t s = corner[tet[k]];
            if (vol.values[s] > iso)
              in[n_in++] = s;
            else
              out[n_out++] = s;
          }
          if (n_in == 0 || n_out == 0) continue;
          Eigen::Vector3d cin = Eigen::Vector3d::Zero(), cout = Eigen::Vector3d::Zero();
          for (int k = 0; k < n_in; ++k) cin += position(in[k]) / n_in;
          for (int k = 0; k < n_out; ++k) cout += position(out[k]) / n_out;
          if (n_in == 1) {
            emit({in[0], out[0]}, {in[0], out[1]}, {in[0], out[2]}, cin, cout);
          } else if (n_out == 1) {
            emit({in[0], out[0]}, {in[1], out[0]}, {in[2], out[0]}, cin, cout);
          } else {  // 2 - 2: quad (in0-out0, in0-out1, in1-out1, in1-out0)
            emit({in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, cin, cout);
            emit({in[0], out[0]}, {in[1], out[1]}, {in[1], out[0]}, cin, cout);
          }
        }
      }
    }
  }
  return mesh;
}

TriangleMesh MeshFromVoxels(const std::vector<CarvedVoxel>& voxels, double voxel_size, int smoothing_passes) {
  if (voxels.empty() || !(voxel_size > 0)) return {};
  Eigen::Vector3i lo = voxels[0].ijk, hi = voxels[0].ijk;
  for (const CarvedVoxel& v : voxels) {
    lo = lo.cwiseMin(v.ijk);
    hi = hi.cwiseMax(v.ijk);
  }
  const int margin = 1 + std::max(0, smoothing_passes);
  lo.array() -= margin;
  hi.array() += margin;
  ScalarVolume vol;
  vol.nx = hi.x() - lo.x() + 1, vol.ny = hi.y() - lo.y() + 1, vol.nz = hi.z() - lo.z() + 1;
  vol.origin = (lo.cast<double>() + Eigen::Vector3d::Constant(0.5)) * voxel_size;
  vol.spacing = voxel_size;
  const size_t n = static_cast<size_t>(vol.nx) * vol.ny * vol.nz;
  vol.values.assign(n, 0.f);
  vol.bgr.assign(n, {{160, 160, 160}});
  std::vector<char> occupied(n, 0);
  for (const CarvedVoxel& v : voxels) {
    const Eigen::Vector3i g = v.ijk - lo;
    const size_t i = vol.Index(g.x(), g.y(), g.z());
    vol.values[i] = 1.f;
    vol.bgr[i] = v.bgr;
    occupied[i] = 1;
  }
  // Colour of unoccupied samples: first occupied sample in the 3x3x3 (then 5x5x5) neighbourhood.
  for (int radius = 1; radius <= 2; ++radius) {
    std::vector<char> has = occupied;
    for (int z = 0; z < vol.nz; ++z)
      for (int y = 0; y < vol.ny; ++y)
        for (int x = 0; x < vol.nx; ++x) {
          const size_t i = vol.Index(x, y, z);
          if (has[i]) continue;
          bool found = false;
          for (int dz = -radius; dz <= radius && !found; ++dz)
            for (int dy = -radius; dy <= radius && !found; ++dy)
              for (int dx = -radius; dx <= radius && !found; ++dx) {
                const int xx = x + dx, yy = y + dy, zz = z + dz;
                if (xx < 0 || yy < 0 || zz < 0 || xx >= vol.nx || yy >= vol.ny || zz >= vol.nz) continue;
                const size_t j = vol.Index(xx, yy, zz);
                if (occupied[j]) {
                  vol.bgr[i] = vol.bgr[j];
                  found = true;
                }
              }
          if (found) has[i] = 2;
        }
    if (radius == 1) {
      for (size_t i = 0; i < n; ++i) occupied[i] = occupied[i] || has[i];
    }
  }
  // Separable [1 2 1] / 4 smoothing.
  std::vector<float> tmp(n);
  const int64_t strides[3] = {1, vol.nx, static_cast<int64_t>(vol.nx) * vol.ny};
  const int dims[3] = {vol.nx, vol.ny, vol.nz};
  for (int pass = 0; pass < smoothing_passes; ++pass) {
    for (int axis = 0; axis < 3; ++axis) {
      for (int z = 0; z < vol.nz; ++z)
        for (int y = 0; y < vol.ny; ++y)
          for (int x = 0; x < vol.nx; ++x) {
            const int c[3] = {x, y, z};
            const size_t i = vol.Index(x, y, z);
            const float left = c[axis] > 0 ? vol.values[i - strides[axis]] : 0.f;
            const float right = c[axis] + 1 < dims[axis] ? vol.values[i + strides[axis]] : 0.f;
            tmp[i] = 0.25f * left + 0.5f * vol.values[i] + 0.25f * right;
          }
      vol.values.swap(tmp);
    }
  }
  return ExtractIsosurface(vol, 0.5f);
}

bool IsClosedOrientedMesh(const TriangleMesh& mesh) {
  std::map<std::pair<int32_t, int32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b) return false;
      if (++directed[{a, b}] > 1) return false;
    }
  }
  for (const auto& [edge, count] : directed) {
    (void)count;
    if (!directed.count({edge.second, edge.first})) return false;
  }
  return !mesh.triangles.empty();
}

int64_t KeepMeshTriangles(TriangleMesh* mesh, const std::vector<char>& keep, std::vector<int32_t>* new_index_out) {
  std::vector<int32_t> new_index(mesh->vertices.size(), -1);
  TriangleMesh out;
  int64_t dropped = 0;
  for (size_t t = 0; t < mesh->triangles.size(); ++t) {
    if (!keep[t]) {
      ++dropped;
      continue;
    }
    std::array<int32_t, 3> u;
    for (int k = 0; k < 3; ++k) {
      const int32_t v = mesh->triangles[t][k];
      if (new_index[v] < 0) {
        new_index[v] = static_cast<int32_t>(out.vertices.size());
        out.vertices.push_back(mesh->vertices[v]);
        if (!mesh->bgr.empty()) out.bgr.push_back(mesh->bgr[v]);
      }
      u[k] = new_index[v];
    }
    out.triangles.push_back(u);
  }
  if (dropped > 0) *mesh = std::move(out);
  if (new_index_out) {
    if (dropped == 0) std::iota(new_index.begin(), new_index.end(), 0);  // the mesh, unused vertices too, stays
    new_index_out->swap(new_index);
  }
  return dropped;
}

int64_t RemoveSmallMeshPieces(TriangleMesh* mesh, double min_fraction) {
  if (min_fraction <= 0 || mesh->triangles.empty()) return 0;
  const int n = static_cast<int>(mesh->vertices.size());
  std::vector<int> parent(n);
  for (int i = 0; i < n; ++i) parent[i] = i;
  auto find = [&parent](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const auto& t : mesh->triangles) {
    const int a = find(t[0]);
    for (int k = 1; k < 3; ++k) {
      const int b = find(t[k]);
      if (a != b) parent[b] = a;
    }
  }
  std::vector<int64_t> piece_triangles(n, 0);
  for (const auto& t : mesh->triangles) ++piece_triangles[find(t[0])];
  const int64_t largest = *std::max_element(piece_triangles.begin(), piece_triangles.end());
  const double keep_from = min_fraction * static_cast<double>(largest);
  std::vector<char> keep(mesh->triangles.size());
  for (size_t t = 0; t < keep.size(); ++t)
    keep[t] = static_cast<double>(piece_triangles[find(mesh->triangles[t][0])]) >= keep_from;
  return KeepMeshTriangles(mesh, keep);
}

// The edges are bucketed by their lower vertex (counting sort) and each bucket sorted: no hash map for the ~10^6 edges.
bool MarkBorderVertices(const TriangleMesh& mesh, const std::vector<char>& keep, std::vector<char>* border) {
  const size_t n = mesh.vertices.size();
  std::vector<int32_t> first(n + 1, 0), upper;
  for (size_t t = 0; t < keep.size(); ++t)
    if (keep[t])
      for (int k = 0; k < 3; ++k) ++first[std::min(mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]) + 1];
  for (size_t v = 0; v < n; ++v) first[v + 1] += first[v];
  upper.resize(first[n]);
  std::vector<int32_t> fill(first.begin(), first.end() - 1);
  for (size_t t = 0; t < keep.size(); ++t)
    if (keep[t])
      for (int k = 0; k < 3; ++k) {
        const int32_t a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
        upper[fill[std::min(a, b)]++] = std::max(a, b);
      }
  border->assign(n, 0);
  bool any = false;
  for (size_t v = 0; v < n; ++v) {
    std::sort(upper.begin() + first[v], upper.begin() + first[v + 1]);
    for (int32_t i = first[v]; i < first[v + 1];) {
      int32_t j = i + 1;
      while (j < first[v + 1] && upper[j] == upper[i]) ++j;
      if (j - i == 1) {
        (*border)[v] = (*border)[upper[i]] = 1;
        any = true;
      }
      i = j;
    }
  }
  return any;
}

namespace {

// (*ring_of)[v] = edges on the kept triangles from v to the nearest border vertex (breadth first), max_ring for
// vertices max_ring or more edges away and for unused ones.
void RingsFromBorder(const TriangleMesh& mesh, const std::vector<char>& keep, const std::vector<char>& border,
                     int max_ring, std::vector<int>* ring_of) {
  const size_t n = mesh.vertices.size();
  std::vector<int32_t> first(n + 1, 0), adjacent;  // vertex adjacency of the kept triangles (CSR)
  for (size_t t = 0; t < keep.size(); ++t)
    if (keep[t])
      for (int k = 0; k < 3; ++k) first[mesh.triangles[t][k] + 1] += 2;
  for (size_t v = 0; v < n; ++v) first[v + 1] += first[v];
  adjacent.resize(first[n]);
  std::vector<int32_t> fill(first.begin(), first.end() - 1);
  for (size_t t = 0; t < keep.size(); ++t) {
    if (!keep[t]) continue;
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      adjacent[fill[tri[k]]++] = tri[(k + 1) % 3];
      adjacent[fill[tri[k]]++] = tri[(k + 2) % 3];
    }
  }
  ring_of->assign(n, max_ring);
  std::vector<int32_t> frontier, next;
  for (size_t v = 0; v < n; ++v)
    if (border[v]) {
      (*ring_of)[v] = 0;
      frontier.push_back(static_cast<int32_t>(v));
    }
  for (int r = 1; r < max_ring && !frontier.empty(); ++r) {
    next.clear();
    for (const int32_t v : frontier)
      for (int32_t i = first[v]; i < first[v + 1]; ++i)
        if ((*ring_of)[adjacent[i]] > r) {
          (*ring_of)[adjacent[i]] = r;
          next.push_back(adjacent[i]);
        }
    frontier.swap(next);
  }
}

}  // namespace

void DropTrianglesAt(const TriangleMesh& mesh, const std::vector<char>& flagged, std::vector<char>* keep) {
  for (size_t t = 0; t < keep->size(); ++t)
    if ((*keep)[t] && (flagged[mesh.triangles[t][0]] || flagged[mesh.triangles[t][1]] || flagged[mesh.triangles[t][2]]))
      (*keep)[t] = 0;
}

int64_t TrimMeshBorder(TriangleMesh* mesh, int rings) {
  if (rings <= 0 || mesh->triangles.empty()) return 0;
  std::vector<char> keep(mesh->triangles.size(), 1);
  std::vector<char> border;
  for (int ring = 0; ring < rings; ++ring) {
    if (!MarkBorderVertices(*mesh, keep, &border)) break;
    DropTrianglesAt(*mesh, border, &keep);
  }
  return KeepMeshTriangles(mesh, keep);
}

std::vector<Eigen::Vector3f> VertexNormals(const TriangleMesh& mesh, const std::vector<char>* keep) {
  std::vector<Eigen::Vector3f> normals(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (keep && !(*keep)[i]) continue;
    const auto& t = mesh.triangles[i];
    const Eigen::Vector3f n =
        (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    for (int k = 0; k < 3; ++k) normals[t[k]] += n;
  }
  for (Eigen::Vector3f& n : normals)
    if (n.squaredNorm() > 0) n.normalize();
  return normals;
}

bool ValidateCurledBorderOptions(const CurledBorderOptions& o, std::string* why) {
  std::string e;
  if (o.max_rings < 0 || o.max_rings > 50) e += "curl max_rings must be in 0..50; ";
  if (!(o.max_angle_deg > 0 && o.max_angle_deg < 90)) e += "curl max_angle_deg must be in (0, 90); ";
  if (!(o.radius_mm > 0) || !std::isfinite(o.radius_mm)) e += "curl radius_mm must be > 0; ";
  if (o.interior_rings < 2 || o.interior_rings > 50) e += "curl interior_rings must be in 2..50; ";
  if (!(o.min_offset_mm >= 0) || !std::isfinite(o.min_offset_mm)) e += "curl min_offset_mm must be >= 0; ";
  if (why) *why = e;
  return e.empty();
}

int64_t TrimCurledBorders(TriangleMesh* mesh, const CurledBorderOptions& o) {
  if (o.max_rings <= 0 || mesh->triangles.empty()) return 0;
  const size_t n = mesh->vertices.size();
  const float min_cos = static_cast<float>(std::cos(o.max_angle_deg * kDegToRad));
  std::vector<char> keep(mesh->triangles.size(), 1), border;
  std::vector<int> ring_of;
  for (int pass = 0; pass < o.max_rings; ++pass) {
    if (!MarkBorderVertices(*mesh, keep, &border)) break;
    const std::vector<Eigen::Vector3f> normal = VertexNormals(*mesh, &keep);  // zero for unused vertices
    RingsFromBorder(*mesh, keep, border, o.interior_rings, &ring_of);
    std::vector<Eigen::Vector3d> interior;
    std::vector<Eigen::Vector3f> interior_normal;
    for (size_t v = 0; v < n; ++v)
      if (ring_of[v] >= o.interior_rings && normal[v].squaredNorm() > 0) {
        interior.push_back(mesh->vertices[v].cast<double>());
        interior_normal.push_back(normal[v]);
      }
    const PointGrid grid(interior, o.radius_mm);
    bool any = false;
    for (size_t t = 0; t < keep.size(); ++t) {
      const auto& tri = mesh->triangles[t];
      if (!keep[t] || !(border[tri[0]] || border[tri[1]] || border[tri[2]])) continue;
      const Eigen::Vector3f& p0 = mesh->vertices[tri[0]];
      const Eigen::Vector3f face = (mesh->vertices[tri[1]] - p0).cross(mesh->vertices[tri[2]] - p0);
      if (face.squaredNorm() == 0) continue;
      const Eigen::Vector3f nf = face.normalized();
      const Eigen::Vector3d centroid = ((p0 + mesh->vertices[tri[1]] + mesh->vertices[tri[2]]) / 3.0f).cast<double>();
      bool agrees = false;  // some interior vertex within the radius has a normal near the triangle's
      int nearest = -1;     // the nearest interior vertex
      double nearest_d2 = 0;
      grid.ForEachWithin(centroid, o.radius_mm, [&](int i) {
        agrees = agrees || interior_normal[i].dot(nf) >= min_cos;
        const double d2 = (interior[i] - centroid).squaredNorm();
        if (nearest < 0 || d2 < nearest_d2) {
          nearest = i;
          nearest_d2 = d2;
        }
      });
      if (nearest >= 0 && !agrees &&
          std::abs(interior_normal[nearest].cast<double>().dot(centroid - interior[nearest])) >= o.min_offset_mm) {
        keep[t] = 0;
        any = true;
      }
    }
    if (!any) break;
  }
  return KeepMeshTriangles(mesh, keep);
}

}  // namespace objscan
