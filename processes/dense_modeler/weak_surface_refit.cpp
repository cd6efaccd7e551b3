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

// Marks the vertices some triangle uses (used), minus those that are not finite or lie 2^20 voxels or more from the
// origin (mm); valid_triangle: the triangles without such a vertex (one flag per triangle).
void MarkUsableVertices(const TriangleMesh& mesh, double voxel_size, std::vector<char>* used,
                        std::vector<char>* valid_triangle) {
  const size_t n = mesh.vertices.size();
  used->assign(n, 0);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) (*used)[t[k]] = 1;
  // Non-finite vertices, and those beyond the voxel keys' range (2^20 voxels from the origin), are never moved and
  // never a neighbour; nor are the others of their triangles' normals.
  const float max_coordinate = static_cast<float>(voxel_size) * float{1 << 20};
  std::vector<char> invalid(n, 0);
  valid_triangle->assign(mesh.triangles.size(), 1);
  for (size_t i = 0; i < n; ++i) {
    invalid[i] = !(mesh.vertices[i].allFinite() && mesh.vertices[i].cwiseAbs().maxCoeff() < max_coordinate);
    if (invalid[i]) (*used)[i] = 0;
  }
  DropTrianglesAt(mesh, invalid, valid_triangle);
}

// Median of the support (votes) of the used vertices (there must be at least one).
double MedianUsedSupport(const std::vector<double>& support, const std::vector<char>& used) {
  std::vector<double> used_support;
  for (size_t i = 0; i < support.size(); ++i)
    if (used[i]) used_support.push_back(support[i]);
  std::nth_element(used_support.begin(), used_support.begin() + used_support.size() / 2, used_support.end());
  return used_support[used_support.size() / 2];
}

// The counter of WeakRefitStats that a left (or dropped) weak vertex's outcome adds to.
int64_t* OutcomeCounter(WeakRefitStats* stats, WeakRefitOutcome outcome) {
  switch (outcome) {
    case WeakRefitOutcome::kFewNeighbours:
      return &stats->few_neighbours;
    case WeakRefitOutcome::kNotSurrounded:
      return &stats->not_surrounded;
    case WeakRefitOutcome::kTooFar:
      return &stats->too_far;
    case WeakRefitOutcome::kClose:
      return &stats->close;
    case WeakRefitOutcome::kRimDropped:
      return &stats->rim_vertices_dropped;
    default:
      return &stats->poor_fit;
  }
}

// Fits the surface of the strong vertices around a weak one (see the header): strong vertices are the used ones with
// a normal and support at least weak_below, one per voxel (the first in vertex order). Points in mm, world frame.
class WeakVertexFitter {
 public:
  WeakVertexFitter(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3f>& normals,
                   const std::vector<double>& support, const std::vector<char>& used, const std::vector<char>& border,
                   double weak_below, double voxel_size, const WeakRefitOptions& o)
      : points_(points),
        normals_(normals),
        support_(support),
        border_(border),
        o_(o),
        strong_(SelectStrong(used, weak_below, voxel_size), o.radius_mm / 2),
        sigma2_((o.radius_mm / 2) * (o.radius_mm / 2)),
        max_gap_(o.max_gap_deg * kDegToRad) {}

  // What becomes of weak vertex i; for kMoved, *move is its move (mm, along the strong vertices' mean normal).
  WeakRefitOutcome Refit(size_t i, Eigen::Vector3d* move) {
    const Eigen::Vector3d p = points_[i], nrm = normals_[i].cast<double>();
    if (!(nrm.squaredNorm() > 0)) return WeakRefitOutcome::kPoorFit;
    near_.clear();
    strong_.ForEachWithin(p, o_.radius_mm, [&](int j) {
      if (normals_[strong_index_[j]].cast<double>().dot(nrm) > o_.min_normal_cos) near_.push_back(j);
    });
    if (static_cast<int>(near_.size()) < o_.min_neighbours) return WeakRefitOutcome::kFewNeighbours;
    Eigen::Vector3d up;
    if (!MeanStrongNormal(p, &up)) return WeakRefitOutcome::kPoorFit;
    const Eigen::Vector3d t1 = up.unitOrthogonal(), t2 = up.cross(t1);
    AccumulateNormalEquations(p, up, t1, t2);
    const bool surrounded = LargestAngularGap(&angles_) <= max_gap_;
    // An unsurrounded vertex is only fitted (extrapolated) to decide whether it is a rim to drop.
    const bool rim = !surrounded && o_.rim_drop_mm > 0 && border_[i];
    if (!surrounded && !rim) return WeakRefitOutcome::kNotSurrounded;
    Eigen::Matrix<double, 6, 1> c;
    const bool fitted = SolveHeightField(&c);
    if (rim) {
      if (fitted && std::abs(c[0]) > o_.rim_drop_mm && std::abs(c[0]) <= o_.max_move_mm)
        return WeakRefitOutcome::kRimDropped;
      return WeakRefitOutcome::kNotSurrounded;
    }
    if (!fitted) return WeakRefitOutcome::kPoorFit;
    if (std::abs(c[0]) > o_.max_move_mm) return WeakRefitOutcome::kTooFar;
    if (std::abs(c[0]) < o_.min_move_mm) return WeakRefitOutcome::kClose;
    *move = up * c[0];
    return WeakRefitOutcome::kMoved;
  }

 private:
  // Fills strong_points_ / strong_index_ (one strong vertex per voxel) and returns strong_points_ (for the grid).
  const std::vector<Eigen::Vector3d>& SelectStrong(const std::vector<char>& used, double weak_below,
                                                   double voxel_size) {
    // Strong vertices: used, with a normal, support at least weak_below; the fits take one per voxel (the first in
    // vertex order; marching cubes makes ~4 per voxel of surface, the fit needs no more than the voxels' resolution).
    std::unordered_set<uint64_t> taken;
    for (size_t i = 0; i < points_.size(); ++i)
      if (used[i] && normals_[i].squaredNorm() > 0 && support_[i] >= weak_below &&
          taken.insert(VoxelKey(VoxelIndexOf(points_[i], voxel_size))).second) {
        strong_points_.push_back(points_[i]);
        strong_index_.push_back(static_cast<int>(i));
      }
    return strong_points_;
  }

  // Weights (support x Gaussian of the distance to p) of the near strong vertices into weight_, and their weighted
  // mean unit normal into *up; false when it vanishes.
  bool MeanStrongNormal(const Eigen::Vector3d& p, Eigen::Vector3d* up) {
    // Tangent frame (t1, t2, up) of the strong vertices' weighted mean normal: the weak vertex's own normal is as
    // unreliable as its position (a dent's slope tilts it).
    weight_.resize(near_.size());
    *up = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < near_.size(); ++k) {
      const int j = strong_index_[near_[k]];
      weight_[k] = support_[j] * std::exp(-(strong_points_[near_[k]] - p).squaredNorm() / (2 * sigma2_));
      *up += weight_[k] * normals_[j].cast<double>();
    }
    if (!(up->squaredNorm() > 0)) return false;
    up->normalize();
    return true;
  }

  // Rows (1, u, v, u^2, u v, v^2) with (u, v) in the tangent plane in units of radius_mm, heights along up (mm), the
  // weighted normal equations of the height field, and the directions (angles_, rad) of the near strong vertices.
  void AccumulateNormalEquations(const Eigen::Vector3d& p, const Eigen::Vector3d& up, const Eigen::Vector3d& t1,
                                 const Eigen::Vector3d& t2) {
    // Weighted least squares through the normal equations (6 x 6), residual from a second pass.
    angles_.clear();
    rows_.resize(near_.size());
    heights_.resize(near_.size());
    normal_matrix_ = Eigen::Matrix<double, 6, 6>::Zero();
    rhs_ = Eigen::Matrix<double, 6, 1>::Zero();
    weight_sum_ = 0;
    for (size_t k = 0; k < near_.size(); ++k) {
      const Eigen::Vector3d d = strong_points_[near_[k]] - p;
      const double u = d.dot(t1) / o_.radius_mm, v = d.dot(t2) / o_.radius_mm;  // scaled: a well-conditioned fit
      if (u != 0 || v != 0) angles_.push_back(std::atan2(v, u));
      rows_[k] << 1, u, v, u * u, u * v, v * v;
      heights_[k] = d.dot(up);
      normal_matrix_.selfadjointView<Eigen::Lower>().rankUpdate(rows_[k], weight_[k]);
      rhs_ += weight_[k] * heights_[k] * rows_[k];
      weight_sum_ += weight_[k];
    }
  }

  // Solves the normal equations for the height field's coefficients *c (zero when degenerate); true when the fit is
  // well-conditioned, finite and its weighted RMS residual is at most max_residual_mm.
  bool SolveHeightField(Eigen::Matrix<double, 6, 1>* c) const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(
        normal_matrix_.selfadjointView<Eigen::Lower>());
    const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();  // ascending
    bool fitted = eig.info() == Eigen::Success && weight_sum_ > 0 && lambda[0] > 1e-8 * lambda[5];
    *c = Eigen::Matrix<double, 6, 1>::Zero();
    if (fitted) {
      *c = eig.eigenvectors() * (eig.eigenvectors().transpose() * rhs_).cwiseQuotient(lambda);
      double squared = 0;
      for (size_t k = 0; k < near_.size(); ++k) {
        const double r = heights_[k] - rows_[k].dot(*c);
        squared += weight_[k] * r * r;
      }
      fitted = std::isfinite((*c)[0]) && std::sqrt(squared / weight_sum_) <= o_.max_residual_mm;
    }
    return fitted;
  }

  const std::vector<Eigen::Vector3d>& points_;
  const std::vector<Eigen::Vector3f>& normals_;
  const std::vector<double>& support_;
  const std::vector<char>& border_;
  const WeakRefitOptions& o_;
  std::vector<Eigen::Vector3d> strong_points_;  // mm
  std::vector<int> strong_index_;               // their vertices
  const PointGrid strong_;                      // over strong_points_
  const double sigma2_;                         // mm^2, of the distance weight
  const double max_gap_;                        // rad
  // per weak vertex: the near strong vertices (indices into strong_points_) and their fit
  std::vector<int> near_;
  std::vector<double> angles_, weight_, heights_;
  std::vector<Eigen::Matrix<double, 6, 1>> rows_;
  Eigen::Matrix<double, 6, 6> normal_matrix_;
  Eigen::Matrix<double, 6, 1> rhs_;
  double weight_sum_ = 0;
};

// Removes the triangles of the dropped rim vertices (and the vertices left without one), renumbering outcomes (one per
// input vertex) like the mesh; counts the removed triangles in stats.
void DropRimTriangles(const std::vector<char>& drop, TriangleMesh* mesh, WeakRefitStats* stats,
                      std::vector<WeakRefitOutcome>* outcomes) {
  const size_t n = mesh->vertices.size();
  std::vector<char> keep(mesh->triangles.size(), 1);
  DropTrianglesAt(*mesh, drop, &keep);
  std::vector<int32_t> new_index;
  stats->rim_triangles_dropped = KeepMeshTriangles(mesh, keep, &new_index);
  if (outcomes) {
    std::vector<WeakRefitOutcome> renumbered(mesh->vertices.size());
    for (size_t i = 0; i < n; ++i)
      if (new_index[i] >= 0) renumbered[new_index[i]] = (*outcomes)[i];
    outcomes->swap(renumbered);
  }
}

}  // namespace

WeakRefitStats RefitWeakMeshVertices(TriangleMesh* mesh, const std::vector<CarvedVoxel>& voxels, double voxel_size,
                                     const WeakRefitOptions& o, std::vector<WeakRefitOutcome>* outcomes) {
  WeakRefitStats stats;
  const size_t n = mesh->vertices.size();
  std::vector<char> used, valid_triangle;
  MarkUsableVertices(*mesh, voxel_size, &used, &valid_triangle);
  stats.vertices = std::count(used.begin(), used.end(), 1);
  if (outcomes) {
    outcomes->assign(n, WeakRefitOutcome::kUnused);
    for (size_t i = 0; i < n; ++i)
      if (used[i]) (*outcomes)[i] = WeakRefitOutcome::kStrong;
  }
  if (o.relative_votes <= 0 || !(voxel_size > 0) || voxels.empty() || stats.vertices == 0) return stats;
  const std::vector<Eigen::Vector3f> normal_f = VertexNormals(*mesh, &valid_triangle);
  std::vector<Eigen::Vector3d> points(n);
  for (size_t i = 0; i < n; ++i) points[i] = mesh->vertices[i].cast<double>();
  const std::vector<double> support = VertexSupport(points, used, voxels, voxel_size);
  stats.median_votes = MedianUsedSupport(support, used);
  const double weak_below = o.relative_votes * stats.median_votes;

  std::vector<char> border, drop(n, 0);
  MarkBorderVertices(*mesh, valid_triangle, &border);
  WeakVertexFitter fitter(points, normal_f, support, used, border, weak_below, voxel_size, o);
  std::vector<std::pair<int, Eigen::Vector3d>> moves;  // vertex, its move (mm)
  for (size_t i = 0; i < n; ++i) {
    if (!used[i] || support[i] >= weak_below) continue;
    ++stats.weak;
    Eigen::Vector3d move;
    const WeakRefitOutcome outcome = fitter.Refit(i, &move);
    if (outcome == WeakRefitOutcome::kMoved) {
      moves.emplace_back(static_cast<int>(i), move);
    } else {
      if (outcome == WeakRefitOutcome::kRimDropped) drop[i] = 1;
      ++*OutcomeCounter(&stats, outcome);
    }
    if (outcomes) (*outcomes)[i] = outcome;
  }
  double sum = 0;
  for (const auto& [i, move] : moves) {
    mesh->vertices[i] += move.cast<float>();
    sum += move.norm();
    stats.max_abs_move_mm = std::max(stats.max_abs_move_mm, move.norm());
  }
  stats.moved = static_cast<int64_t>(moves.size());
  if (!moves.empty()) stats.mean_abs_move_mm = sum / moves.size();
  if (stats.rim_vertices_dropped > 0) DropRimTriangles(drop, mesh, &stats, outcomes);
  return stats;
}

}  // namespace objscan
