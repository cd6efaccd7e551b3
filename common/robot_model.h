// Kinematics of the robot: a differential-drive base with a pan-tilt camera on a mast.
//
// Frames (all right-handed, lengths in mm, angles in rad):
//   world   z up, floor is z = 0. The odometry frame (odometry_t) is the robot base frame at its start pose, as
//           the robot believes it; estimators start their world frame there.
//   base    on the floor under the robot's centre: x forward, y left, z up.
//           world_from_base = [Rz(theta) | (x, y, 0)].
//   pan     at (mast_offset_x_mm, mast_offset_y_mm, mast_height_mm) in base, rotated by Rz(pan) (pan > 0 = left).
//   tilt    same origin, rotated by Ry(tilt) in the pan frame (tilt > 0 = looking down).
//   camera  optical frame (x right, y down, z forward) whose centre sits at camera_offset_mm in the tilt frame;
//           tilt_from_camera rotation maps camera z -> tilt x, camera x -> tilt -y, camera y -> tilt -z.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

namespace objscan {

struct RobotGeometry {
  double mast_height_mm = 400.0;    // mm, height of the pan/tilt axes above the floor
  double mast_offset_x_mm = 0.0;    // mm, mast position forward of the base centre
  double mast_offset_y_mm = 0.0;    // mm, mast position left of the base centre
  Eigen::Vector3d camera_offset_mm{40.0, 0.0, 0.0};  // mm, optical centre in the tilt frame (forward, left, up)
  double wheel_base_mm = 300.0;     // mm, distance between the drive wheels

  // False (with a reason) for non-finite or negative sizes.
  bool IsValid(std::string* why = nullptr) const;
};

Eigen::Isometry3d WorldFromBase(double x_mm, double y_mm, double theta_rad);
// base_from_camera for the head angles.
Eigen::Isometry3d BaseFromCamera(const RobotGeometry& robot, double pan_rad, double tilt_rad);
// world_from_camera for a robot pose and head angles.
Eigen::Isometry3d WorldFromCamera(const RobotGeometry& robot, double x_mm, double y_mm, double theta_rad,
                                  double pan_rad, double tilt_rad);
// The fixed rotation tilt_from_camera (optical axes to x-forward/y-left/z-up).
Eigen::Matrix3d TiltFromCameraRotation();
// Pan and tilt (rad; pan in [-pi, pi), tilt > 0 = down) that put `point_world` on the optical axis of a robot at
// base pose (x, y, theta): exact for camera offsets along the optical axis, refined by Newton steps otherwise. Not
// limited to the joints' range.
void AimHead(const RobotGeometry& robot, double x_mm, double y_mm, double theta_rad,
             const Eigen::Vector3d& point_world, double* pan_rad, double* tilt_rad);

}  // namespace objscan
