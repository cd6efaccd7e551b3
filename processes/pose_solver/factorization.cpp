#include "processes/pose_solver/factorization.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <cmath>

#include "common/geometry.h"

namespace objscan {

namespace {
bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

// Row vector of the 6 unknowns of the symmetric L for the bilinear form a^T L b.
Eigen::Matrix<double, 1, 6> Coeffs(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  Eigen::Matrix<double, 1, 6> c;
  c << a(0) * b(0), a(0) * b(1) + a(1) * b(0), a(0) * b(2) + a(2) * b(0), a(1) * b(1), a(1) * b(2) + a(2) * b(1),
      a(2) * b(2);
  return c;
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    r = u * svd.matrixV().transpose();
  }
  return r;
}
}  // namespace

FactorizationResult FactorizationResult::Mirrored() const {
  FactorizationResult m = *this;
  const Eigen::Matrix3d d = Eigen::Vector3d(1, 1, -1).asDiagonal();
  for (auto& r : m.camera_from_model) r = d * r * d;
  m.shape = d * shape;
  return m;
}

bool FactorizeWeakPerspective(const std::vector<std::vector<Eigen::Vector2d>>& measurements,
                              FactorizationResult* result, std::string* why) {
  const int num_frames = static_cast<int>(measurements.size());
  if (num_frames < 3) return Fail(why, "factorization: fewer than 3 frames");
  const int num_points = static_cast<int>(measurements[0].size());
  if (num_points < 4) return Fail(why, "factorization: fewer than 4 points");
  for (const auto& f : measurements)
    if (static_cast<int>(f.size()) != num_points) return Fail(why, "factorization: ragged measurement matrix");
  // Centred measurement matrix: rows 2f (u) and 2f+1 (v).
  Eigen::MatrixXd w(2 * num_frames, num_points);
  std::vector<Eigen::Vector2d> centroid(num_frames, Eigen::Vector2d::Zero());
  for (int f = 0; f < num_frames; ++f) {
    for (int p = 0; p < num_points; ++p) centroid[f] += measurements[f][p];
    centroid[f] /= num_points;
    for (int p = 0; p < num_points; ++p) {
      w(2 * f, p) = measurements[f][p].x() - centroid[f].x();
      w(2 * f + 1, p) = measurements[f][p].y() - centroid[f].y();
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(w, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (sv.size() < 3 || sv(2) <= 1e-9 * std::max(1.0, sv(0))) return Fail(why, "factorization: rank < 3");
  const Eigen::Vector3d sqrt_sv = sv.head<3>().cwiseSqrt();
  Eigen::MatrixXd motion = svd.matrixU().leftCols<3>() * sqrt_sv.asDiagonal();             // 2F x 3
  Eigen::MatrixXd shape = sqrt_sv.asDiagonal() * svd.matrixV().leftCols<3>().transpose();  // 3 x P
  // Metric upgrade: L = Q Q^T with m^T L m - n^T L n = 0, m^T L n = 0 for every frame, m_0^T L m_0 = 1.
  Eigen::MatrixXd a(2 * num_frames + 1, 6);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(2 * num_frames + 1);
  for (int f = 0; f < num_frames; ++f) {
    const Eigen::Vector3d m = motion.row(2 * f).transpose(), n = motion.row(2 * f + 1).transpose();
    a.row(2 * f) = Coeffs(m, m) - Coeffs(n, n);
    a.row(2 * f + 1) = Coeffs(m, n);
  }
  const Eigen::Vector3d m0 = motion.row(0).transpose();
  a.row(2 * num_frames) = Coeffs(m0, m0);
  b(2 * num_frames) = 1.0;
  const Eigen::Matrix<double, 6, 1> l = a.colPivHouseholderQr().solve(b);
  Eigen::Matrix3d lm;
  lm << l(0), l(1), l(2), l(1), l(3), l(4), l(2), l(4), l(5);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(lm);
  if (eig.eigenvalues()(0) <= 1e-12 * std::abs(eig.eigenvalues()(2)))
    return Fail(why, "factorization: metric upgrade not positive definite (too little rotation?)");
  const Eigen::Matrix3d q = eig.eigenvectors() * eig.eigenvalues().cwiseSqrt().asDiagonal();
  motion = motion * q;
  shape = q.inverse() * shape;
  FactorizationResult r;
  r.camera_from_model.resize(num_frames);
  r.scale.resize(num_frames);
  r.centroid_px = centroid;
  for (int f = 0; f < num_frames; ++f) {
    const Eigen::Vector3d m = motion.row(2 * f).transpose(), n = motion.row(2 * f + 1).transpose();
    const double s = 0.5 * (m.norm() + n.norm());
    Eigen::Matrix3d rot;
    rot.row(0) = m.normalized().transpose();
    rot.row(1) = n.normalized().transpose();
    rot.row(2) = m.normalized().cross(n.normalized()).transpose();
    r.camera_from_model[f] = NearestRotation(rot);
    r.scale[f] = s;
  }
  // Gauge: R_0 = I, s_0 = 1.
  const Eigen::Matrix3d r0 = r.camera_from_model[0];
  const double s0 = r.scale[0];
  for (int f = 0; f < num_frames; ++f) {
    r.camera_from_model[f] = r.camera_from_model[f] * r0.transpose();
    r.scale[f] /= s0;
  }
  r.shape = s0 * (r0 * shape);
  double sum_sq = 0;
  for (int f = 0; f < num_frames; ++f) {
    const Eigen::Matrix<double, 2, Eigen::Dynamic> proj = r.scale[f] * r.camera_from_model[f].topRows<2>() * r.shape;
    for (int p = 0; p < num_points; ++p) sum_sq += (proj.col(p) + centroid[f] - measurements[f][p]).squaredNorm();
  }
  r.residual_rms_px = std::sqrt(sum_sq / (num_frames * num_points));
  *result = std::move(r);
  return true;
}

double MaxRotationAngle(const FactorizationResult& result) {
  double angle = 0;
  for (const auto& r : result.camera_from_model) angle = std::max(angle, RotationAngle(r));
  return angle;
}

std::vector<int64_t> CommonIds(const std::vector<TrackList>& frames, int first, int last) {
  if (first < 0 || last >= static_cast<int>(frames.size()) || first > last) return {};
  std::vector<int64_t> common = frames[first].ids;
  for (int i = first + 1; i <= last && !common.empty(); ++i) {
    std::vector<int64_t> next;
    std::set_intersection(common.begin(), common.end(), frames[i].ids.begin(), frames[i].ids.end(),
                          std::back_inserter(next));
    common.swap(next);
  }
  return common;
}

bool SelectStartSpan(const std::vector<TrackList>& frames, const StartSpanOptions& options, int* first, int* last,
                     std::vector<int64_t>* common_ids, std::string* why) {
  const int n = static_cast<int>(frames.size());
  const int min_frames = std::max(3, options.min_frames);
  if (n < min_frames) {
    if (why) *why = std::to_string(n) + " frames since the base last stood still (need " + std::to_string(min_frames) + ")";
    return false;
  }
  const int end = n - 1;
  // The earliest start whose window still shares enough tracks (longest baseline ending at the newest frame).
  int best_first = -1;
  std::vector<int64_t> best_common;
  std::vector<int64_t> common = frames[end].ids;
  for (int f = end - 1; f >= 0 && end - f + 1 <= options.max_frames; --f) {
    std::vector<int64_t> next;
    std::set_intersection(common.begin(), common.end(), frames[f].ids.begin(), frames[f].ids.end(),
                          std::back_inserter(next));
    if (static_cast<int>(next.size()) < options.min_common_tracks) break;
    common.swap(next);
    best_first = f;
    best_common = common;
  }
  if (best_first < 0 || end - best_first + 1 < min_frames) {
    if (why)
      *why = std::to_string(best_first < 0 ? 1 : end - best_first + 1) + " newest frames share >= " +
             std::to_string(options.min_common_tracks) + " tracks (need " + std::to_string(min_frames) +
             " frames): tracks do not last";
    return false;
  }
  // Parallax test on the factorization of the window.
  std::vector<std::vector<Eigen::Vector2d>> w(end - best_first + 1);
  for (int f = best_first; f <= end; ++f) {
    const TrackList& t = frames[f];
    auto& row = w[f - best_first];
    row.reserve(best_common.size());
    size_t k = 0;
    for (int64_t id : best_common) {
      while (t.ids[k] != id) ++k;  // ids sorted and id is present
      row.push_back(t.pixels[k]);
    }
  }
  FactorizationResult fr;
  if (!FactorizeWeakPerspective(w, &fr)) {
    if (why) *why = "the factorization of the newest " + std::to_string(end - best_first + 1) + " frames failed";
    return false;
  }
  if (MaxRotationAngle(fr) < options.min_rotation_deg * M_PI / 180.0) {
    if (why) {
      char text[160];
      std::snprintf(text, sizeof(text), "rotation %.1f deg < %.1f deg over the newest %d frames (%zu common tracks)",
                    MaxRotationAngle(fr) * 180 / M_PI, options.min_rotation_deg, end - best_first + 1,
                    best_common.size());
      *why = text;
    }
    return false;
  }
  *first = best_first;
  *last = end;
  if (common_ids) *common_ids = best_common;
  return true;
}

bool SpanMotionAgreesWithOdometry(const std::vector<Eigen::Isometry3d>& visual,
                                  const std::vector<Eigen::Isometry3d>& odometry, std::string* why) {
  if (visual.size() != odometry.size() || visual.size() < 2) return true;
  const size_t n = visual.size();
  std::vector<Eigen::Vector3d> tv(n), to(n);
  double travel = 0, vv = 0, vo = 0;
  for (size_t f = 0; f < n; ++f) {  // translations relative to the first camera, in its frame
    tv[f] = visual[0].linear().transpose() * (visual[f].translation() - visual[0].translation());
    to[f] = odometry[0].linear().transpose() * (odometry[f].translation() - odometry[0].translation());
    travel = std::max(travel, to[f].norm());
    vv += tv[f].squaredNorm();
    vo += tv[f].dot(to[f]);
  }
  if (travel < 20) return true;
  const double scale = vv > 0 ? vo / vv : 0;
  double worst = 0;
  size_t worst_frame = 0;
  for (size_t f = 0; f < n; ++f) {
    const double d = (scale * tv[f] - to[f]).norm();
    if (d > worst) {
      worst = d;
      worst_frame = f;
    }
  }
  if (scale > 0 && worst <= 0.5 * travel + 5) return true;
  if (why) {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "the span's camera motion disagrees with the odometry: %.0f mm off at frame %zu of %zu after the "
                  "best scale (%.3g) over %.0f mm of odometry travel",
                  worst, worst_frame, n, scale, travel);
    *why = text;
  }
  return false;
}

}  // namespace objscan
