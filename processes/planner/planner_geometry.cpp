#include "processes/planner/planner_geometry.h"

#include <algorithm>
#include <cmath>

namespace objscan {

bool CameraIntrinsics::IsValid() const {
  return width > 0 && height > 0 && std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
         std::isfinite(cy) && fx > 0 && fy > 0;
}

bool CameraIntrinsics::Project(const Eigen::Vector3d& p, double* u, double* v) const {
  if (!(p.z() > 1.0)) return false;
  *u = fx * p.x() / p.z() + cx;
  *v = fy * p.y() / p.z() + cy;
  return true;
}

bool CameraIntrinsics::InImage(double u, double v, double margin_px) const {
  return u >= -0.5 + margin_px && v >= -0.5 + margin_px && u <= width - 0.5 - margin_px &&
         v <= height - 0.5 - margin_px;
}

double CameraIntrinsics::HorizontalFovRad() const {
  return std::atan((cx + 0.5) / fx) + std::atan((width - 0.5 - cx) / fx);
}

double CameraIntrinsics::VerticalFovRad() const {
  return std::atan((cy + 0.5) / fy) + std::atan((height - 0.5 - cy) / fy);
}

double WrapAngle(double a) {
  if (!std::isfinite(a)) return a;
  a = std::remainder(a, 2 * M_PI);
  return a <= -M_PI ? a + 2 * M_PI : a;
}

BasePose Compose(const BasePose& a, const BasePose& b) {
  const double c = std::cos(a.theta_rad), s = std::sin(a.theta_rad);
  return {a.x_mm + c * b.x_mm - s * b.y_mm, a.y_mm + s * b.x_mm + c * b.y_mm, WrapAngle(a.theta_rad + b.theta_rad)};
}

BasePose Between(const BasePose& a, const BasePose& b) {
  const double c = std::cos(a.theta_rad), s = std::sin(a.theta_rad);
  const double dx = b.x_mm - a.x_mm, dy = b.y_mm - a.y_mm;
  return {c * dx + s * dy, -s * dx + c * dy, WrapAngle(b.theta_rad - a.theta_rad)};
}

BasePose BasePoseFromCamera(const RobotGeometry& robot, const Eigen::Isometry3d& world_from_camera, double pan_rad,
                            double tilt_rad) {
  const Eigen::Isometry3d world_from_base = world_from_camera * BaseFromCamera(robot, pan_rad, tilt_rad).inverse();
  const Eigen::Matrix3d& r = world_from_base.linear();
  return {world_from_base.translation().x(), world_from_base.translation().y(), std::atan2(r(1, 0), r(0, 0))};
}

Eigen::Isometry3d WorldFromCamera(const RobotGeometry& robot, const BasePose& base, double pan_rad,
                                  double tilt_rad) {
  return WorldFromCamera(robot, base.x_mm, base.y_mm, base.theta_rad, pan_rad, tilt_rad);
}

void AimHead(const RobotGeometry& robot, const BasePose& base, const Eigen::Vector3d& point, double* pan_rad,
             double* tilt_rad) {
  AimHead(robot, base.x_mm, base.y_mm, base.theta_rad, point, pan_rad, tilt_rad);
}

double AngleOffAxis(const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3d& point_world) {
  const Eigen::Vector3d p = world_from_camera.inverse() * point_world;
  const double n = p.norm();
  if (!(n > 0)) return M_PI;
  return std::acos(std::clamp(p.z() / n, -1.0, 1.0));
}

}  // namespace objscan
