#include "processes/pose_solver/triangulation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "processes/pose_solver/bundle_adjustment.h"

namespace objscan {

namespace {
bool Fail(std::string* why, const char* reason) {
  if (why) *why = reason;
  return false;
}
}  // namespace

bool TriangulatePoint(const PinholeCamera& camera, const std::vector<Eigen::Isometry3d>& world_from_camera,
                      const std::vector<Eigen::Vector2d>& pixels, const TriangulationOptions& options,
                      TriangulatedPoint* out, std::string* why) {
  const int n = static_cast<int>(pixels.size());
  if (n < std::max(2, options.min_views) || static_cast<int>(world_from_camera.size()) != n)
    return Fail(why, "too few views");
  const Eigen::Matrix3d k_inv = camera.K().inverse();
  std::vector<Eigen::Isometry3d> cam_from_world(n);
  std::vector<Eigen::Vector3d> rays(n);  // in world
  Eigen::MatrixXd a(2 * n, 4);
  for (int i = 0; i < n; ++i) {
    cam_from_world[i] = world_from_camera[i].inverse();
    const Eigen::Vector3d x = k_inv * pixels[i].homogeneous();
    rays[i] = (world_from_camera[i].linear() * x).normalized();
    const Eigen::Matrix<double, 3, 4> pm = cam_from_world[i].matrix().topRows<3>();
    a.row(2 * i) = x.x() / x.z() * pm.row(2) - pm.row(0);
    a.row(2 * i + 1) = x.y() / x.z() * pm.row(2) - pm.row(1);
  }
  double max_angle = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      max_angle = std::max(max_angle, std::acos(std::clamp(rays[i].dot(rays[j]), -1.0, 1.0)));
  const double parallax_deg = max_angle * 180.0 / M_PI;
  if (parallax_deg < options.min_parallax_deg) return Fail(why, "low parallax");
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (std::abs(h(3)) < 1e-12) return Fail(why, "point at infinity");
  Eigen::Vector3d x = h.head<3>() / h(3);
  // Gauss–Newton on the reprojection error.
  for (int it = 0; it < options.refine_iterations; ++it) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    bool ok = true;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d pc = cam_from_world[i] * x;
      if (pc.z() <= 1e-9) {
        ok = false;
        break;
      }
      const double iz = 1.0 / pc.z();
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << camera.fx * iz, camera.skew * iz, -(camera.fx * pc.x() + camera.skew * pc.y()) * iz * iz, 0,
          camera.fy * iz, -camera.fy * pc.y() * iz * iz;
      const Eigen::Matrix<double, 2, 3> j = dproj * cam_from_world[i].linear();
      Eigen::Vector2d uv;
      ProjectIdeal(camera, pc, &uv);
      const Eigen::Vector2d r = uv - pixels[i];
      jtj += j.transpose() * j;
      jtr += j.transpose() * r;
    }
    if (!ok) break;
    const Eigen::Vector3d dx = jtj.ldlt().solve(-jtr);
    if (!dx.allFinite()) break;
    x += dx;
    if (dx.norm() < 1e-9) break;
  }
  double sum = 0, worst = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d pc = cam_from_world[i] * x;
    Eigen::Vector2d uv;
    if (!ProjectIdeal(camera, pc, &uv)) return Fail(why, "behind camera");
    const double e = (uv - pixels[i]).norm();
    sum += e * e;
    worst = std::max(worst, e);
  }
  if (!x.allFinite() || worst > options.max_reprojection_px) return Fail(why, "reprojection");
  out->point_in_world = x;
  out->rms_px = std::sqrt(sum / n);
  out->max_error_px = worst;
  out->parallax_deg = parallax_deg;
  return true;
}

}  // namespace objscan
