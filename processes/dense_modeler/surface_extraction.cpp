#include "processes/dense_modeler/surface_extraction.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "common/geometry.h"
#include "common/point_grid.h"

namespace objscan {
namespace {

// Unit smallest principal axis (eigenvector of the smallest eigenvalue) of a weighted point set, from its weighted
// mean, the sum of w d d^T and the sum of weights; false when the solver gives no usable vector.
bool ThinAxis(const Eigen::Vector3d& mean, const Eigen::Matrix3d& second, double wsum, Eigen::Vector3d* axis) {
  const Eigen::Matrix3d cov = second / wsum - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (!n.allFinite() || n.norm() < 0.5) return false;
  *axis = n.normalized();
  return true;
}

// Votes around the seeds: a dense copy of the grid over the seeds' bounding box when it is small enough (the
// normal and ridge tests read each voxel many times), grid lookups otherwise.
class VoteField {
 public:
  VoteField(const VoxelVoteGrid& grid, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) : grid_(grid), lo_(lo) {
    dims_ = (hi - lo + Eigen::Vector3i::Ones()).cast<int64_t>();
    const int64_t n = dims_.prod();
    if (n <= 0 || n > kMaxDense) return;
    dense_.resize(static_cast<size_t>(n));
    for (int64_t z = 0; z < dims_.z(); ++z)
      for (int64_t y = 0; y < dims_.y(); ++y)
        for (int64_t x = 0; x < dims_.x(); ++x)
          dense_[static_cast<size_t>((z * dims_.y() + y) * dims_.x() + x)] =
              grid.Votes(lo + Eigen::Vector3i(static_cast<int>(x), static_cast<int>(y), static_cast<int>(z)));
  }
  int32_t operator()(const Eigen::Vector3i& ijk) const {
    if (dense_.empty()) return grid_.Votes(ijk);
    const Eigen::Matrix<int64_t, 3, 1> d = (ijk - lo_).cast<int64_t>();
    if ((d.array() < 0).any() || (d.array() >= dims_.array()).any()) return 0;
    return dense_[static_cast<size_t>((d.z() * dims_.y() + d.y()) * dims_.x() + d.x())];
  }
  // Trilinear interpolation; position in voxel-index units (voxel ijk's centre at ijk).
  double Sample(const Eigen::Vector3d& pos) const {
    const Eigen::Vector3d f = pos.array().floor();
    const Eigen::Vector3i base = f.cast<int>();
    const Eigen::Vector3d t = pos - f;
    double v = 0;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3i o((c & 1), (c >> 1) & 1, (c >> 2) & 1);
      const double w = (o.x() ? t.x() : 1 - t.x()) * (o.y() ? t.y() : 1 - t.y()) * (o.z() ? t.z() : 1 - t.z());
      if (w > 0) v += w * (*this)(base + o);
    }
    return v;
  }

 private:
  static constexpr int64_t kMaxDense = int64_t{32} << 20;  // voxels (128 MB of counts)
  const VoxelVoteGrid& grid_;
  Eigen::Vector3i lo_;
  Eigen::Matrix<int64_t, 3, 1> dims_;
  std::vector<int32_t> dense_;
};

// The surface points' positions, for a PointGrid over them.
std::vector<Eigen::Vector3d> PositionsOf(const std::vector<SurfaceVoxel>& surface) {
  std::vector<Eigen::Vector3d> positions;
  positions.reserve(surface.size());
  for (const SurfaceVoxel& s : surface) positions.push_back(s.point_in_world);
  return positions;
}

}  // namespace

bool ValidateCreaseOptions(const CreaseOptions& o, std::string* why) {
  std::ostringstream e;
  if (!(o.radius_voxels == 0 || (o.radius_voxels >= 2 && o.radius_voxels <= 12)))
    e << "crease radius_voxels must be 0 or in [2, 12]; ";
  if (!(o.min_angle_deg > 0 && o.min_angle_deg < 180)) e << "crease min_angle_deg must be in (0, 180); ";
  if (!(o.core_angle_deg > 0 && o.core_angle_deg <= 45)) e << "crease core_angle_deg must be in (0, 45]; ";
  if (o.min_face_points < 3) e << "crease min_face_points must be >= 3; ";
  if (!(o.max_move_voxels > 0)) e << "crease max_move_voxels must be > 0; ";
  if (why) *why = e.str();
  return e.str().empty();
}

bool ValidateRidgeOptions(const RidgeOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.normal_radius < 1 || o.normal_radius > 4) e << "ridge normal_radius must be in 1..4; ";
  if (!(o.ridge_tolerance > 0 && o.ridge_tolerance <= 1)) e << "ridge_tolerance must be in (0, 1]; ";
  if (o.min_component_voxels < 0) e << "min_component_voxels must be >= 0; ";
  if (!(o.min_component_fraction >= 0 && o.min_component_fraction < 1))
    e << "min_component_fraction must be in [0, 1); ";
  if (o.border_rings < 0 || o.border_rings > 10) e << "ridge border_rings must be in 0..10; ";
  std::string curl_why;
  if (!ValidateCurledBorderOptions(o.curled_borders, &curl_why)) e << curl_why;
  if (!(o.smoothing_min_normal_cos >= -1 && o.smoothing_min_normal_cos < 1))
    e << "ridge smoothing_min_normal_cos must be in [-1, 1); ";
  std::string crease_why;
  if (!ValidateCreaseOptions(o.creases, &crease_why)) e << crease_why;
  if (!(o.smoothing_radius == 0 || (o.smoothing_radius >= 1 && o.smoothing_radius <= 12)))
    e << "ridge smoothing_radius must be 0 or in [1, 12]; ";
  if (why) *why = e.str();
  return e.str().empty();
}

std::vector<SurfaceVoxel> ExtractVoteRidge(const VoxelVoteGrid& grid, const std::vector<VoxelRecord>& seeds,
                                           const RidgeOptions& o, RidgeStats* stats_out) {
  RidgeStats stats;
  stats.seeds = static_cast<int64_t>(seeds.size());
  std::vector<SurfaceVoxel> out;
  if (seeds.empty()) {
    if (stats_out) *stats_out = stats;
    return out;
  }
  Eigen::Vector3i lo = seeds[0].ijk, hi = lo;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const VoxelRecord& s : seeds) {
    lo = lo.cwiseMin(s.ijk);
    hi = hi.cwiseMax(s.ijk);
    centroid += s.ijk.cast<double>();
  }
  centroid /= static_cast<double>(seeds.size());
  const int pad = o.normal_radius + 2;
  const VoteField votes(grid, lo - Eigen::Vector3i::Constant(pad), hi + Eigen::Vector3i::Constant(pad));
  const int r = o.normal_radius;

  std::vector<SurfaceVoxel> ridge;
  for (const VoxelRecord& s : seeds) {
    // Normal: thin axis of the vote-weighted neighbourhood.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    double wsum = 0;
    for (int dz = -r; dz <= r; ++dz)
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const double w = votes(s.ijk + Eigen::Vector3i(dx, dy, dz));
          if (w <= 0) continue;
          const Eigen::Vector3d d(dx, dy, dz);
          mean += w * d;
          second += w * d * d.transpose();
          wsum += w;
        }
    if (wsum <= 0) continue;
    mean /= wsum;
    Eigen::Vector3d n;
    if (!ThinAxis(mean, second, wsum, &n)) continue;
    Eigen::Vector3d outward = s.toward_camera.cast<double>();
    if (outward.squaredNorm() < 1e-12) outward = s.ijk.cast<double>() - centroid;
    if (n.dot(outward) < 0) n = -n;

    const Eigen::Vector3d c = s.ijk.cast<double>();
    const double v0 = s.votes;
    const double vp = votes.Sample(c + n), vm = votes.Sample(c - n);
    if (v0 < o.ridge_tolerance * vp || v0 < o.ridge_tolerance * vm) continue;
    const double denom = vm - 2 * v0 + vp;
    double t = denom < 0 ? 0.5 * (vm - vp) / denom : 0.0;
    t = std::clamp(t, -0.5, 0.5);
    SurfaceVoxel sv;
    sv.voxel = s;
    sv.normal = n;
    sv.point_in_world = grid.CenterOf(s.ijk) + t * grid.voxel_size() * n;
    ridge.push_back(sv);
  }
  stats.ridge = static_cast<int64_t>(ridge.size());

  // Drop small 26-connected fragments: absolute and relative to the largest.
  std::vector<char> keep(ridge.size(), 1);
  if (o.min_component_voxels > 1 || o.min_component_fraction > 0) {
    std::unordered_map<uint64_t, size_t> index;
    index.reserve(ridge.size() * 2);
    for (size_t i = 0; i < ridge.size(); ++i) index.emplace(VoxelKey(ridge[i].voxel.ijk), i);
    std::vector<int> component(ridge.size(), -1);
    std::vector<size_t> component_size;
    std::vector<size_t> stack;
    for (size_t i = 0; i < ridge.size(); ++i) {
      if (component[i] >= 0) continue;
      const int id = static_cast<int>(component_size.size());
      size_t members = 0;
      stack.assign(1, i);
      component[i] = id;
      while (!stack.empty()) {
        const size_t k = stack.back();
        stack.pop_back();
        ++members;
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              auto it = index.find(VoxelKey(ridge[k].voxel.ijk + Eigen::Vector3i(dx, dy, dz)));
              if (it == index.end() || component[it->second] >= 0) continue;
              component[it->second] = id;
              stack.push_back(it->second);
            }
      }
      component_size.push_back(members);
    }
    const size_t largest = component_size.empty() ? 0 : *std::max_element(component_size.begin(), component_size.end());
    const double min_size =
        std::max(static_cast<double>(o.min_component_voxels), o.min_component_fraction * static_cast<double>(largest));
    for (size_t i = 0; i < ridge.size(); ++i) {
      if (static_cast<double>(component_size[static_cast<size_t>(component[i])]) >= min_size) continue;
      keep[i] = 0;
      ++stats.fragments_dropped;
    }
  }
  for (size_t i = 0; i < ridge.size(); ++i)
    if (keep[i]) out.push_back(ridge[i]);
  stats.kept = static_cast<int64_t>(out.size());
  if (stats_out) *stats_out = stats;
  return out;
}

std::vector<SurfaceVoxel> SmoothSurfacePoints(const std::vector<SurfaceVoxel>& surface, double voxel_size,
                                              double radius_voxels, double min_normal_cos) {
  std::vector<SurfaceVoxel> out = surface;
  if (surface.empty() || !(voxel_size > 0) || !(radius_voxels > 0)) return out;
  const double radius = radius_voxels * voxel_size, sigma = 0.5 * radius;
  const std::vector<Eigen::Vector3d> positions = PositionsOf(surface);
  const PointGrid cells(positions, radius);
  std::vector<std::pair<Eigen::Vector3d, double>> near;  // neighbour offset from the point, weight
  for (size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3d p = surface[i].point_in_world;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    double wsum = 0;
    near.clear();
    cells.ForEachWithin(p, radius, [&](int j) {
      if (surface[j].normal.dot(surface[i].normal) < min_normal_cos) return;
      const Eigen::Vector3d d = positions[j] - p;
      const double w = std::max(surface[j].voxel.votes, 1) * std::exp(-0.5 * d.squaredNorm() / (sigma * sigma));
      mean += w * d;
      second += w * d * d.transpose();
      wsum += w;
      near.emplace_back(d, w);
    });
    if (!(wsum > 0)) continue;
    mean /= wsum;
    Eigen::Vector3d n;
    if (!ThinAxis(mean, second, wsum, &n)) continue;
    if (n.dot(surface[i].normal) < 0) n = -n;
    // Plane through the weighted centroid: on a curved surface the centroid lies inside by about the mean squared
    // neighbour distance / (2 x radius of curvature) (0.16 mm on the 100 mm sphere with the default radius). A
    // weighted quadratic height field over the plane, h(u, v) = a + b u + c v + d u^2 + e uv + f v^2 in the point's
    // tangent frame, has no such bias: the point moves to h(0, 0) and takes the field's normal there.
    Eigen::Vector3d moved = p + n.dot(mean) * n, normal = n;
    if (near.size() >= 12) {
      const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
      Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> atb = Eigen::Matrix<double, 6, 1>::Zero();
      for (const auto& [d, w] : near) {
        const double u = t1.dot(d) / radius, v = t2.dot(d) / radius;  // scaled for conditioning
        Eigen::Matrix<double, 6, 1> row;
        row << 1, u, v, u * u, u * v, v * v;
        ata += w * row * row.transpose();
        atb += w * n.dot(d) * row;
      }
      const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(ata);
      if (ldlt.info() == Eigen::Success && ldlt.rcond() > 1e-9) {
        const Eigen::Matrix<double, 6, 1> q = ldlt.solve(atb);
        if (q.allFinite() && std::abs(q(0)) < radius) {
          moved = p + q(0) * n;
          normal = (n - (q(1) / radius) * t1 - (q(2) / radius) * t2).normalized();
        }
      }
    }
    out[i].normal = normal;
    out[i].point_in_world = moved;
  }
  return out;
}

std::vector<SurfaceVoxel> SharpenCreases(const std::vector<SurfaceVoxel>& surface, double voxel_size,
                                         const CreaseOptions& o, int64_t* moved) {
  std::vector<SurfaceVoxel> out = surface;
  if (moved) *moved = 0;
  if (surface.empty() || !(voxel_size > 0) || !(o.radius_voxels > 0)) return out;
  const double radius = o.radius_voxels * voxel_size, max_move = o.max_move_voxels * voxel_size;
  const double cos_apart = std::cos(o.min_angle_deg * kDegToRad), cos_core = std::cos(o.core_angle_deg * kDegToRad);
  const size_t min_points = static_cast<size_t>(std::max(o.min_face_points, 3));
  const std::vector<Eigen::Vector3d> positions = PositionsOf(surface);
  const PointGrid cells(positions, radius);
  std::vector<size_t> near;
  std::vector<std::pair<double, size_t>> order;  // far_side's buffer: (dot with the other group's mean, point)
  for (size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3d p = surface[i].point_in_world, own = surface[i].normal;
    near.clear();
    cells.ForEachWithin(p, radius, [&](int j) { near.push_back(static_cast<size_t>(j)); });
    if (near.size() < 2 * min_points) continue;
    // 2-means of the normals, seeded by the normal farthest from the point's own and the one farthest from that.
    auto farthest_from = [&](const Eigen::Vector3d& n) {
      size_t best = near[0];
      for (size_t j : near)
        if (surface[j].normal.dot(n) < surface[best].normal.dot(n)) best = j;
      return surface[best].normal;
    };
    Eigen::Vector3d m1 = farthest_from(own);
    Eigen::Vector3d m2 = farthest_from(m1);
    if (m1.dot(m2) > cos_apart) continue;  // one face (the common case)
    bool split = true;
    for (int iteration = 0; iteration < 5 && split; ++iteration) {
      Eigen::Vector3d s1 = Eigen::Vector3d::Zero(), s2 = Eigen::Vector3d::Zero();
      for (size_t j : near) (surface[j].normal.dot(m1) >= surface[j].normal.dot(m2) ? s1 : s2) += surface[j].normal;
      split = s1.norm() > 1e-9 && s2.norm() > 1e-9;
      if (split) m1 = s1.normalized(), m2 = s2.normalized();
    }
    if (!split || m1.dot(m2) > cos_apart) continue;
    // Each face's core: the group's normals within core_angle_deg of the group's far side (the normal at the 10th
    // percentile of the dot product with the other group's mean: on the face, not on the bevel in between, and no
    // single stray normal). Its plane goes through the core's vote-weighted centroid along its mean normal.
    auto far_side = [&](const Eigen::Vector3d& own_mean, const Eigen::Vector3d& other_mean) {
      order.clear();
      for (size_t j : near)
        if (surface[j].normal.dot(own_mean) >= surface[j].normal.dot(other_mean))
          order.emplace_back(surface[j].normal.dot(other_mean), j);
      if (order.empty()) return own_mean;  // (the 2-means groups are not empty; kept for safety)
      const size_t k = order.size() / 10;
      std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end());
      return surface[order[k].second].normal;
    };
    // A face's plane: vote-weighted centroid and mean normal of the normals within core_angle_deg of a seed: the
    // group's far side, which avoids the bevel's normals (they pull the mean towards the other face), or its mean
    // when fewer than min_face_points lie near the far side (a stray one: on the sim box, 10 normals of the
    // underside of a flap the top face ran on past the edge).
    struct Face {
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
      size_t count = 0;
    };
    auto face_around = [&](const Eigen::Vector3d& seed) {
      Face f;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (size_t j : near) {
        const Eigen::Vector3d& nj = surface[j].normal;
        if (nj.dot(seed) < cos_core) continue;
        const double w = std::max(surface[j].voxel.votes, 1);
        f.centroid += w * surface[j].point_in_world;
        sum += w * nj;
        wsum += w;
        ++f.count;
      }
      if (f.count > 0) f.centroid /= wsum, f.normal = sum.normalized();
      return f;
    };
    auto face_of = [&](const Eigen::Vector3d& mean, const Eigen::Vector3d& other_mean) {
      const Face far = face_around(far_side(mean, other_mean));
      return far.count >= min_points ? far : face_around(mean);
    };
    const Face f1 = face_of(m1, m2), f2 = face_of(m2, m1);
    if (f1.count < min_points || f2.count < min_points) continue;
    const Eigen::Vector3d c1 = f1.centroid, c2 = f2.centroid;
    m1 = f1.normal;
    m2 = f2.normal;
    if (m1.dot(m2) > cos_apart) continue;
    // Convex: each face's centroid lies behind the other's plane; the solid is the wedge {m1.(x - c1) <= 0,
    // m2.(x - c2) <= 0}. Concave: both in front; the space outside the solid is the wedge of -m1, -m2. Either way
    // the surface is the boundary of the wedge W = {n1.(x - c1) <= 0, n2.(x - c2) <= 0}.
    const double side12 = m1.dot(c2 - c1), side21 = m2.dot(c1 - c2);
    const bool convex = side12 < 0 && side21 < 0;
    if (!convex && !(side12 > 0 && side21 > 0)) continue;
    const Eigen::Vector3d n1 = convex ? m1 : Eigen::Vector3d(-m1), n2 = convex ? m2 : Eigen::Vector3d(-m2);
    constexpr double kOnFace = 1e-9;  // mm
    // Candidates: the projections onto each plane that lie on W's face, and the nearest point of the edge line.
    Eigen::Vector3d best = p, best_normal = own;
    double best_dist = std::numeric_limits<double>::infinity();
    const Eigen::Vector3d q1 = p - n1.dot(p - c1) * n1, q2 = p - n2.dot(p - c2) * n2;
    auto consider = [&](const Eigen::Vector3d& q, const Eigen::Vector3d& normal) {
      if ((q - p).norm() < best_dist) best = q, best_normal = normal, best_dist = (q - p).norm();
    };
    if (n2.dot(q1 - c2) <= kOnFace) consider(q1, m1);
    if (n1.dot(q2 - c1) <= kOnFace) consider(q2, m2);
    const Eigen::Vector3d e = n1.cross(n2);
    if (e.norm() > 1e-6) {  // (antiparallel faces, a thin plate's two sides, have no edge)
      Eigen::Matrix3d a;
      a.row(0) = n1.transpose();
      a.row(1) = n2.transpose();
      a.row(2) = e.normalized().transpose();
      consider(a.inverse() * Eigen::Vector3d(n1.dot(c1), n2.dot(c2), e.normalized().dot(p)),
               own.dot(m1) >= own.dot(m2) ? m1 : m2);
    }
    if (!(best_dist <= max_move)) continue;
    out[i].point_in_world = best;
    out[i].normal = best_normal;
    if (moved) ++*moved;
  }
  return out;
}

TriangleMesh MeshFromSurfacePoints(const std::vector<SurfaceVoxel>& surface, double voxel_size_mm) {
  if (surface.empty() || !(voxel_size_mm > 0)) return TriangleMesh();
  Eigen::Vector3d lo = surface[0].point_in_world, hi = lo;
  for (const SurfaceVoxel& s : surface) {
    lo = lo.cwiseMin(s.point_in_world);
    hi = hi.cwiseMax(s.point_in_world);
  }
  // Grid of spacing h over the points plus a 3-sample margin; coarser when the box would be huge.
  double h = voxel_size_mm;
  constexpr int64_t kMaxSamples = int64_t{16} << 20;
  ScalarVolume vol;
  for (;;) {
    vol.origin = ((lo / h).array().floor() - 3).matrix() * h;
    const Eigen::Vector3d extent = (hi - vol.origin) / h;
    vol.nx = static_cast<int>(std::ceil(extent.x())) + 4;
    vol.ny = static_cast<int>(std::ceil(extent.y())) + 4;
    vol.nz = static_cast<int>(std::ceil(extent.z())) + 4;
    if (static_cast<int64_t>(vol.nx) * vol.ny * vol.nz <= kMaxSamples) break;
    h *= 2;
  }
  vol.spacing = h;
  const size_t n = static_cast<size_t>(vol.nx) * vol.ny * vol.nz;
  std::vector<float> wsum(n, 0.f), dsum(n, 0.f), nearest(n, std::numeric_limits<float>::infinity());
  vol.bgr.assign(n, {{160, 160, 160}});
  const double sigma = h, radius = 2 * h;
  for (const SurfaceVoxel& s : surface) {
    const Eigen::Vector3d g = (s.point_in_world - vol.origin) / h;
    const Eigen::Vector3i g0 = (g.array() - 2).ceil().cast<int>().max(0), g1 = (g.array() + 2).floor().cast<int>();
    for (int z = g0.z(); z <= std::min(g1.z(), vol.nz - 1); ++z)
      for (int y = g0.y(); y <= std::min(g1.y(), vol.ny - 1); ++y)
        for (int x = g0.x(); x <= std::min(g1.x(), vol.nx - 1); ++x) {
          const Eigen::Vector3d pos = vol.origin + Eigen::Vector3d(x, y, z) * h;
          const Eigen::Vector3d d = pos - s.point_in_world;
          const double dist = d.norm();
          if (dist > radius) continue;
          const size_t i = vol.Index(x, y, z);
          const double w = std::exp(-0.5 * dist * dist / (sigma * sigma));
          wsum[i] += static_cast<float>(w);
          dsum[i] += static_cast<float>(w * s.normal.dot(d));
          if (dist < nearest[i]) {
            nearest[i] = static_cast<float>(dist);
            vol.bgr[i] = s.voxel.bgr;
          }
        }
  }
  vol.values.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (size_t i = 0; i < n; ++i)
    if (wsum[i] > 1e-3f) vol.values[i] = -dsum[i] / wsum[i];  // inside (behind the normal) positive
  return ExtractIsosurface(vol, 0.0f);
}

}  // namespace objscan
