#include "common/geometry.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace objscan {

Eigen::Isometry3d Sim3::Apply(const Eigen::Isometry3d& pose) const {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = rotation * pose.linear();
  out.translation() = (*this) * pose.translation();
  return out;
}

bool AlignSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, Sim3* out,
                     double* rms) {
  if (!AlignUmeyama(src, dst, true, out)) return false;
  double sum2 = 0;
  for (size_t i = 0; i < src.size(); ++i) sum2 += ((*out) * src[i] - dst[i]).squaredNorm();
  *rms = std::sqrt(sum2 / static_cast<double>(src.size()));
  return true;
}

bool AlignUmeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, bool with_scale,
                  Sim3* out) {
  const size_t n = src.size();
  if (n < 3 || dst.size() != n) return false;
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero(), mean_dst = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= static_cast<double>(n);
  mean_dst /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_src = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = src[i] - mean_src, b = dst[i] - mean_dst;
    cov += b * a.transpose();
    var_src += a.squaredNorm();
  }
  cov /= static_cast<double>(n);
  var_src /= static_cast<double>(n);
  if (var_src <= 0) return false;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (sv(1) < 1e-12 * std::max(1.0, sv(0))) return false;  // collinear
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s(2, 2) = -1;
  out->rotation = svd.matrixU() * s * svd.matrixV().transpose();
  out->scale = with_scale ? (sv.asDiagonal() * s).trace() / var_src : 1.0;
  out->translation = mean_dst - out->scale * out->rotation * mean_src;
  return true;
}

double RotationAngle(const Eigen::Matrix3d& r) {
  return Eigen::AngleAxisd(Eigen::Quaterniond(r).normalized()).angle();
}

bool EvaluateTrajectory(const std::vector<Eigen::Isometry3d>& est, const std::vector<Eigen::Isometry3d>& truth,
                        bool with_scale, TrajectoryError* out) {
  if (est.size() != truth.size() || est.size() < 3) return false;
  std::vector<Eigen::Vector3d> src, dst;
  for (size_t i = 0; i < est.size(); ++i) {
    src.push_back(est[i].translation());
    dst.push_back(truth[i].translation());
  }
  Sim3 s;
  if (!AlignUmeyama(src, dst, with_scale, &s)) return false;
  TrajectoryError e;
  e.num_poses = static_cast<int>(est.size());
  e.scale = s.scale;
  e.alignment = s;
  double sum2 = 0, rot_sum = 0;
  for (size_t i = 0; i < est.size(); ++i) {
    const Eigen::Isometry3d aligned = s.Apply(est[i]);
    const double d = (aligned.translation() - truth[i].translation()).norm();
    sum2 += d * d;
    e.ate_max = std::max(e.ate_max, d);
    const double angle = RotationAngle(aligned.linear().transpose() * truth[i].linear());
    rot_sum += angle;
    e.rotation_max_rad = std::max(e.rotation_max_rad, angle);
  }
  e.ate_rmse = std::sqrt(sum2 / static_cast<double>(est.size()));
  e.rotation_mean_rad = rot_sum / static_cast<double>(est.size());
  *out = e;
  return true;
}

Eigen::Isometry3d PoseFromArrays(const double position[3], const double q[4]) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(position[0], position[1], position[2]);
  return pose;
}

void PoseToArrays(const Eigen::Isometry3d& pose, double position[3], double q[4]) {
  Eigen::Quaterniond quat(pose.linear());
  quat.normalize();
  if (quat.w() < 0) quat.coeffs() *= -1;  // canonical sign
  q[0] = quat.w();
  q[1] = quat.x();
  q[2] = quat.y();
  q[3] = quat.z();
  for (int i = 0; i < 3; ++i) position[i] = pose.translation()(i);
}

}  // namespace objscan
