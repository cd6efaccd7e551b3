#include "common/robot_model.h"

#include <cmath>

namespace objscan {

bool RobotGeometry::IsValid(std::string* why) const {
  const bool finite = std::isfinite(mast_height_mm) && std::isfinite(mast_offset_x_mm) &&
                      std::isfinite(mast_offset_y_mm) && camera_offset_mm.allFinite() && std::isfinite(wheel_base_mm);
  if (!finite) {
    if (why) *why = "robot geometry has non-finite values";
    return false;
  }
  if (mast_height_mm <= 0 || wheel_base_mm <= 0) {
    if (why) *why = "mast height and wheel base must be > 0";
    return false;
  }
  return true;
}

Eigen::Matrix3d TiltFromCameraRotation() {
  Eigen::Matrix3d r;
  // columns: camera x, y, z expressed in the tilt frame
  r.col(0) = Eigen::Vector3d(0, -1, 0);
  r.col(1) = Eigen::Vector3d(0, 0, -1);
  r.col(2) = Eigen::Vector3d(1, 0, 0);
  return r;
}

Eigen::Isometry3d WorldFromBase(double x_mm, double y_mm, double theta_rad) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(theta_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  t.translation() = Eigen::Vector3d(x_mm, y_mm, 0);
  return t;
}

Eigen::Isometry3d BaseFromCamera(const RobotGeometry& robot, double pan_rad, double tilt_rad) {
  Eigen::Isometry3d base_from_tilt = Eigen::Isometry3d::Identity();
  base_from_tilt.linear() = (Eigen::AngleAxisd(pan_rad, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d::UnitY()))
                                .toRotationMatrix();
  base_from_tilt.translation() = Eigen::Vector3d(robot.mast_offset_x_mm, robot.mast_offset_y_mm, robot.mast_height_mm);
  Eigen::Isometry3d tilt_from_camera = Eigen::Isometry3d::Identity();
  tilt_from_camera.linear() = TiltFromCameraRotation();
  tilt_from_camera.translation() = robot.camera_offset_mm;
  return base_from_tilt * tilt_from_camera;
}

Eigen::Isometry3d WorldFromCamera(const RobotGeometry& robot, double x_mm, double y_mm, double theta_rad,
                                  double pan_rad, double tilt_rad) {
  return WorldFromBase(x_mm, y_mm, theta_rad) * BaseFromCamera(robot, pan_rad, tilt_rad);
}

void AimHead(const RobotGeometry& robot, double x_mm, double y_mm, double theta_rad,
             const Eigen::Vector3d& point_world, double* pan_rad, double* tilt_rad) {
  const Eigen::Isometry3d world_from_base = WorldFromBase(x_mm, y_mm, theta_rad);
  const Eigen::Vector3d pivot(robot.mast_offset_x_mm, robot.mast_offset_y_mm, robot.mast_height_mm);
  const Eigen::Vector3d d = world_from_base.inverse() * point_world - pivot;
  double pan = std::atan2(d.y(), d.x());
  double tilt = std::atan2(-d.z(), std::hypot(d.x(), d.y()));
  // Refine for camera offsets off the optical axis (exact in one step for the default offset along the axis).
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::Vector3d p = WorldFromCamera(robot, x_mm, y_mm, theta_rad, pan, tilt).inverse() * point_world;
    if (p.z() <= 0) break;
    const double ex = std::atan2(p.x(), p.z()), ey = std::atan2(p.y(), p.z());
    pan -= ex;
    tilt += ey;
    if (std::abs(ex) + std::abs(ey) < 1e-12) break;
  }
  pan = std::fmod(pan + M_PI, 2 * M_PI);  // into [-pi, pi)
  *pan_rad = (pan < 0 ? pan + 2 * M_PI : pan) - M_PI;
  *tilt_rad = tilt;
}

}  // namespace objscan
