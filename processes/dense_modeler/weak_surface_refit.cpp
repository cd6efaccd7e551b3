#include "processes/dense_modeler/weak_surface_refit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>

#include "common/geometry.h"
#include "common/point_grid.h"
#include "processes/dense_modeler/voxel_votes.h"

namespace objscan {

bool ValidateWeakRefitOptions(const WeakRefitOptions& o, std::string* why) {
  std::ostringstream e;
  if (!(o.relative_votes >= 0 && o.relative_votes < 1)) e << "weak refit relative_votes must be in [0, 1); ";
  if (!(o.radius_mm >= 1) || !std::isfinite(o.radius_mm)) e << "weak refit radius_mm must be >= 1; ";
  if (o.min_neighbours < 6) e << "weak refit min_neighbours must be >= 6; ";
  if (!(o.min_normal_cos >= -1 && o.min_normal_cos < 1)) e << "weak refit min_normal_cos must be in [-1, 1); ";
  if (!(o.max_gap_deg > 0 && o.max_gap_deg <= 360)) e << "weak refit max_gap_deg must be in (0, 360]; ";
  if (!(o.max_residual_mm > 0) || !std::isfinite(o.max_residual_mm)) e << "weak refit max_residual_mm must be > 0; ";
  if (!(o.max_move_mm > 0) || !std::isfinite(o.max_move_mm)) e << "weak refit max_move_mm must be > 0; ";
  if (!(o.min_move_mm >= 0 && o.min_move_mm < o.max_move_mm))
    e << "weak refit min_move_mm must be in [0, max_move_mm); ";
  if (!(o.rim_drop_mm >= 0 && o.rim_drop_mm < o.max_move_mm))
    e << "weak refit rim_drop_mm must be in [0, max_move_mm); ";
  const std::string msg = e.str();
  if (why) *why = msg.empty() ? msg : msg.substr(0, msg.size() - 2);
  return msg.empty();
}

namespace {

// Votes of the final voxel whose centre is nearest to each used point (within two voxels; 0 when none is or the
// point is unused).
std::vector<double> VertexSupport(const std::vector<Eigen::Vector3d>& points, const std::vector<char>& used,
                                  const std::vector<CarvedVoxel>& voxels, double voxel_size) {
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(voxels.size());
  for (const CarvedVoxel& v : voxels) centres.push_back(VoxelCenterOf(v.ijk, voxel_size));
  const PointGrid grid(centres, voxel_size);
  std::vector<double> support(points.size(), 0.0);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!used[i]) continue;
    double best = std::numeric_limits<double>::infinity();
    grid.ForEachWithin(points[i], 2 * voxel_size, [&](int j) {
      const double d = (centres[j] - points[i]).squaredNorm();
      if (d < best) {
        best = d;
        support[i] = voxels[j].votes;
      }
    });
  }
  return support;
}

// Largest angle (rad) between consecutive directions around a full turn; 2 pi for fewer than two directions.
double LargestAngularGap(std::vector<double>* angles) {
  if (angles->size() < 2) return 2 * M_PI;
  std::sort(angles->begin(), angles->end());
  double gap = angles->front() + 2 * M_PI - angles->back();
  for (size_t i = 1; i < angles->size(); ++i) gap = std::max(gap, (*angles)[i] - (*angles)[i - 1]);
  return gap;
}

}  // namespace

WeakRefitStats RefitWeakMeshVertices(TriangleMesh* mesh, const std::vector<CarvedVoxel>& voxels, double voxel_size,
                                     const WeakRefitOptions& o, std::vector<WeakRefitOutcome>* outcomes) {
  WeakRefitStats stats;
  const size_t n = mesh->vertices.size();
  std::vector<char> used(n, 0);
  for (const auto& t : mesh->triangles)
    for (int k = 0; k < 3; ++k) used[t[k]] = 1;
  // Non-finite vertices, and those beyond the voxel keys' range (2^20 voxels from the origin), are never moved and
  // never a neighbour; nor are the others of their triangles' normals.
  const float max_coordinate = static_cast<float>(voxel_size) * float{1 << 20};
  std::vector<char> invalid(n, 0), valid_triangle(mesh->triangles.size(), 1);
  for (size_t i = 0; i < n; ++i) {
    invalid[i] = !(mesh->vertices[i].allFinite() && mesh->vertices[i].cwiseAbs().maxCoeff() < max_coordinate);
    if (invalid[i]) used[i] = 0;
  }
  DropTrianglesAt(*mesh, invalid, &valid_triangle);
  stats.vertices = std::count(used.begin(), used.end(), 1);
  if (outcomes) {
    outcomes->assign(n, WeakRefitOutcome::kUnused);
    for (size_t i = 0; i < n; ++i)
      if (used[i]) (*outcomes)[i] = WeakRefitOutcome::kStrong;
  }
  if (o.relative_votes <= 0 || !(voxel_size > 0) || voxels.empty() || stats.vertices == 0) return stats;
  const auto leave = [&](size_t i, WeakRefitOutcome why, int64_t* count) {
    ++*count;
    if (outcomes) (*outcomes)[i] = why;
  };
  const std::vector<Eigen::Vector3f> normal_f = VertexNormals(*mesh, &valid_triangle);
  std::vector<Eigen::Vector3d> points(n);
  for (size_t i = 0; i < n; ++i) points[i] = mesh->vertices[i].cast<double>();
  const std::vector<double> support = VertexSupport(points, used, voxels, voxel_size);

  std::vector<double> used_support;
  for (size_t i = 0; i < n; ++i)
    if (used[i]) used_support.push_back(support[i]);
  std::nth_element(used_support.begin(), used_support.begin() + used_support.size() / 2, used_support.end());
  stats.median_votes = used_support[used_support.size() / 2];
  const double weak_below = o.relative_votes * stats.median_votes;

  // Strong vertices: used, with a normal, support at least weak_below; the fits take one per voxel (the first in
  // vertex order; marching cubes makes ~4 per voxel of surface, the fit needs no more than the voxels' resolution).
  std::vector<Eigen::Vector3d> strong_points;
  std::vector<int> strong_index;
  std::unordered_set<uint64_t> taken;
  for (size_t i = 0; i < n; ++i)
    if (used[i] && normal_f[i].squaredNorm() > 0 && support[i] >= weak_below &&
        taken.insert(VoxelKey(VoxelIndexOf(points[i], voxel_size))).second) {
      strong_points.push_back(points[i]);
      strong_index.push_back(static_cast<int>(i));
    }
  const PointGrid strong(strong_points, o.radius_mm / 2);
  const double sigma2 = (o.radius_mm / 2) * (o.radius_mm / 2);
  const double max_gap = o.max_gap_deg * kDegToRad;

  std::vector<char> border, drop(n, 0);
  MarkBorderVertices(*mesh, valid_triangle, &border);
  std::vector<std::pair<int, Eigen::Vector3d>> moves;  // vertex, its move (mm)
  std::vector<int> near;
  std::vector<double> angles, weight, heights;
  std::vector<Eigen::Matrix<double, 6, 1>> rows;
  for (size_t i = 0; i < n; ++i) {
    if (!used[i] || support[i] >= weak_below) continue;
    ++stats.weak;
    const Eigen::Vector3d p = points[i], nrm = normal_f[i].cast<double>();
    if (!(nrm.squaredNorm() > 0)) {
      leave(i, WeakRefitOutcome::kPoorFit, &stats.poor_fit);
      continue;
    }
    near.clear();
    strong.ForEachWithin(p, o.radius_mm, [&](int j) {
      if (normal_f[strong_index[j]].cast<double>().dot(nrm) > o.min_normal_cos) near.push_back(j);
    });
    if (static_cast<int>(near.size()) < o.min_neighbours) {
      leave(i, WeakRefitOutcome::kFewNeighbours, &stats.few_neighbours);
      continue;
    }
    // Tangent frame (t1, t2, up) of the strong vertices' weighted mean normal: the weak vertex's own normal is as
    // unreliable as its position (a dent's slope tilts it).
    weight.resize(near.size());
    Eigen::Vector3d up = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < near.size(); ++k) {
      const int j = strong_index[near[k]];
      weight[k] = support[j] * std::exp(-(strong_points[near[k]] - p).squaredNorm() / (2 * sigma2));
      up += weight[k] * normal_f[j].cast<double>();
    }
    if (!(up.squaredNorm() > 0)) {
      leave(i, WeakRefitOutcome::kPoorFit, &stats.poor_fit);
      continue;
    }
    up.normalize();
    const Eigen::Vector3d t1 = up.unitOrthogonal(), t2 = up.cross(t1);
    // Weighted least squares through the normal equations (6 x 6), residual from a second pass.
    angles.clear();
    rows.resize(near.size());
    heights.resize(near.size());
    Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    double weight_sum = 0;
    for (size_t k = 0; k < near.size(); ++k) {
      const Eigen::Vector3d d = strong_points[near[k]] - p;
      const double u = d.dot(t1) / o.radius_mm, v = d.dot(t2) / o.radius_mm;  // scaled: a well-conditioned fit
      if (u != 0 || v != 0) angles.push_back(std::atan2(v, u));
      rows[k] << 1, u, v, u * u, u * v, v * v;
      heights[k] = d.dot(up);
      normal_matrix.selfadjointView<Eigen::Lower>().rankUpdate(rows[k], weight[k]);
      rhs += weight[k] * heights[k] * rows[k];
      weight_sum += weight[k];
    }
    const bool surrounded = LargestAngularGap(&angles) <= max_gap;
    // An unsurrounded vertex is only fitted (extrapolated) to decide whether it is a rim to drop.
    const bool rim = !surrounded && o.rim_drop_mm > 0 && border[i];
    if (!surrounded && !rim) {
      leave(i, WeakRefitOutcome::kNotSurrounded, &stats.not_surrounded);
      continue;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(normal_matrix.selfadjointView<Eigen::Lower>());
    const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();  // ascending
    bool fitted = eig.info() == Eigen::Success && weight_sum > 0 && lambda[0] > 1e-8 * lambda[5];
    Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero();
    if (fitted) {
      c = eig.eigenvectors() * (eig.eigenvectors().transpose() * rhs).cwiseQuotient(lambda);
      double squared = 0;
      for (size_t k = 0; k < near.size(); ++k) {
        const double r = heights[k] - rows[k].dot(c);
        squared += weight[k] * r * r;
      }
      fitted = std::isfinite(c[0]) && std::sqrt(squared / weight_sum) <= o.max_residual_mm;
    }
    if (rim) {
      if (fitted && std::abs(c[0]) > o.rim_drop_mm && std::abs(c[0]) <= o.max_move_mm) {
        drop[i] = 1;
        leave(i, WeakRefitOutcome::kRimDropped, &stats.rim_vertices_dropped);
      } else {
        leave(i, WeakRefitOutcome::kNotSurrounded, &stats.not_surrounded);
      }
      continue;
    }
    if (!fitted) {
      leave(i, WeakRefitOutcome::kPoorFit, &stats.poor_fit);
      continue;
    }
    if (std::abs(c[0]) > o.max_move_mm) {
      leave(i, WeakRefitOutcome::kTooFar, &stats.too_far);
      continue;
    }
    if (std::abs(c[0]) < o.min_move_mm) {
      leave(i, WeakRefitOutcome::kClose, &stats.close);
      continue;
    }
    moves.emplace_back(static_cast<int>(i), up * c[0]);
    if (outcomes) (*outcomes)[i] = WeakRefitOutcome::kMoved;
  }
  double sum = 0;
  for (const auto& [i, move] : moves) {
    mesh->vertices[i] += move.cast<float>();
    sum += move.norm();
    stats.max_abs_move_mm = std::max(stats.max_abs_move_mm, move.norm());
  }
  stats.moved = static_cast<int64_t>(moves.size());
  if (!moves.empty()) stats.mean_abs_move_mm = sum / moves.size();
  if (stats.rim_vertices_dropped == 0) return stats;
  std::vector<char> keep(mesh->triangles.size(), 1);
  DropTrianglesAt(*mesh, drop, &keep);
  std::vector<int32_t> new_index;
  stats.rim_triangles_dropped = KeepMeshTriangles(mesh, keep, &new_index);
  if (outcomes) {
    std::vector<WeakRefitOutcome> renumbered(mesh->vertices.size());
    for (size_t i = 0; i < n; ++i)
      if (new_index[i] >= 0) renumbered[new_index[i]] = (*outcomes)[i];
    outcomes->swap(renumbered);
  }
  return stats;
}

}  // namespace objscan
