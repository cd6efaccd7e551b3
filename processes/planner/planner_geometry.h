// Planar robot poses, the camera's intrinsics as the planner needs them, and the robot-model computations the
// planner shares (LCM-free). Frames and units as in common/robot_model.h: world z up, floor z = 0, mm, rad.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/robot_model.h"

namespace objscan {

// A base pose on the floor: world_from_base = [Rz(theta_rad) | (x_mm, y_mm, 0)].
struct BasePose {
  double x_mm = 0, y_mm = 0;
  double theta_rad = 0;
  Eigen::Vector2d position() const { return {x_mm, y_mm}; }
};

// Pinhole intrinsics without distortion (planning-level projection). Defaults: the simulated 640x480, fx = 800.
struct CameraIntrinsics {
  int width = 640, height = 480;  // px
  double fx = 800, fy = 800;      // px
  double cx = 319.5, cy = 239.5;  // px, principal point
  // True for positive size and focal lengths and finite values.
  bool IsValid() const;
  // Pixel of a point in the camera optical frame; false when it is not in front (z <= 1 mm).
  bool Project(const Eigen::Vector3d& point_in_camera, double* u, double* v) const;
  // True when (u, v) lies at least margin_px inside the image.
  bool InImage(double u, double v, double margin_px = 0) const;
  double HorizontalFovRad() const;
  double VerticalFovRad() const;
};

// Wraps to (-pi, pi].
double WrapAngle(double angle_rad);
// world_from_b = world_from_a * a_from_b for planar poses.
BasePose Compose(const BasePose& world_from_a, const BasePose& a_from_b);
// a_from_b = inverse(world_from_a) * world_from_b.
BasePose Between(const BasePose& world_from_a, const BasePose& world_from_b);

// The base pose under a camera: world_from_base = world_from_camera * inverse(BaseFromCamera(pan, tilt)), projected
// onto the floor (x, y of its origin, theta = yaw of its x axis). Exact inverse of WorldFromCamera for a level base.
BasePose BasePoseFromCamera(const RobotGeometry& robot, const Eigen::Isometry3d& world_from_camera, double pan_rad,
                            double tilt_rad);
Eigen::Isometry3d WorldFromCamera(const RobotGeometry& robot, const BasePose& base, double pan_rad, double tilt_rad);

// common/robot_model.h's AimHead for a BasePose.
void AimHead(const RobotGeometry& robot, const BasePose& base, const Eigen::Vector3d& point_world, double* pan_rad,
             double* tilt_rad);

// Angle (rad) between the optical axis of world_from_camera and the direction to point_world.
double AngleOffAxis(const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3d& point_world);

}  // namespace objscan
