// Bundle adjustment with Ceres: perspective pinhole projection (observations are UNDISTORTED pixels, i.e. the
// intrinsics' fx, fy, cx, cy, skew applied to ideal normalized coordinates), robust loss, two camera models:
//
//  kSixDof   per frame camera_from_world as angle-axis (3) + translation (3) in mm.
//  kFourDof  the robot model (common/robot_model.h): the camera moves on the floor and tilts. Per frame
//            (x_mm, y_mm, yaw_rad, tilt_rad): (x, y) is the pan axis' foot point on the floor in world, yaw is the
//            heading of the pan frame (base heading theta + pan angle: the camera cannot tell them apart, and with
//            the mast offset the pan axis position is what the camera sees), tilt the tilt joint angle (> 0 down):
//              world_from_tilt = [Rz(yaw) * Ry(tilt) | (x, y, mast_height_mm)]
//              world_from_camera = world_from_tilt * [TiltFromCameraRotation() | camera_offset_mm]
//            Camera height above the floor and roll are fixed by the geometry; 4 DOF per frame.
//
// Gauge: the caller fixes it (frame_fix / point_fix below); for kSixDof with all frames free of a fixed reference, a
// distance prior between two frames' centres holds the scale. Windowed (local) BA = pass the window's frames as free
// and the other frames that observe the window's points as fixed (see BuildLocalWindow in pose_estimator.cpp);
// global BA = everything free but the gauge. Deterministic: num_threads = 1 by default, fixed parameter order.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/robot_model.h"

namespace objscan {

enum class MotionModel { kSixDof, kFourDof };

// 4-DOF robot parameters <-> world_from_camera (see the header comment).
struct FloorPose {
  double x_mm = 0, y_mm = 0, yaw_rad = 0, tilt_rad = 0;
};
Eigen::Isometry3d WorldFromCameraFloor(const RobotGeometry& robot, const FloorPose& p);
// Closest FloorPose to an arbitrary pose (drops roll and height; exact for poses the model can produce).
FloorPose FloorPoseFromWorldFromCamera(const RobotGeometry& robot, const Eigen::Isometry3d& world_from_camera);

// Projection with the intrinsics of an undistorted pinhole camera (no distortion applied). False when z <= 0.
bool ProjectIdeal(const PinholeCamera& camera, const Eigen::Vector3d& point_in_camera, Eigen::Vector2d* pixel);
// Undistorted pixel of a (distorted) measured pixel: K * Unproject(pixel).
Eigen::Vector2d UndistortPixel(const PinholeCamera& camera, const Eigen::Vector2d& pixel);

struct BaObservation {
  int frame = 0;          // index into BaProblem::world_from_camera
  int point = 0;          // index into BaProblem::points
  Eigen::Vector2d pixel;  // px, undistorted
};

enum class FrameFix : uint8_t {
  kFree = 0,
  kFixed = 1,       // pose held constant
  kFixedFloor = 2,  // kFourDof only: x, y, yaw held, tilt free (the 4-DOF gauge)
};

struct BaProblem {
  std::vector<Eigen::Isometry3d> world_from_camera;  // in/out, mm
  std::vector<Eigen::Vector3d> points;               // in/out, mm, world
  std::vector<BaObservation> observations;
  std::vector<FrameFix> frame_fix;      // per frame (empty = all free)
  std::vector<uint8_t> point_fixed;     // per point, 1 = held constant (empty = all free)
  std::vector<uint8_t> point_on_floor;  // per point, 1 = z held at 0 (floor landmarks; empty = none)
  // Optional scale gauge: ||c_a - c_b|| held near distance_mm (weight: residual = weight * (d - distance)).
  int distance_frame_a = -1, distance_frame_b = -1;
  double distance_mm = 0;
  double distance_weight = 100.0;  // 1/mm
};

struct BaOptions {
  MotionModel model = MotionModel::kSixDof;  // camera parameterization
  std::string loss = "huber";                // "huber", "cauchy" or "none"
  double loss_scale_px = 1.0;                // px, robust loss scale
  int max_iterations = 50;                   // Levenberg–Marquardt iterations
  double function_tolerance = 1e-6;          // relative cost change to stop
  int num_threads = 1;                       // Ceres threads (1 for determinism)
};

struct BaSummary {
  bool ok = false;
  int iterations = 0;
  double initial_rms_px = 0;  // RMS reprojection error over all observations before / after
  double final_rms_px = 0;
  bool converged = false;  // stopped by a tolerance (not by max_iterations)
  std::string message;
};

// Runs the adjustment in place. Observations referring to out-of-range indices are ignored, and so are the
// observations of a point seen by fewer than two distinct frames unless it is point_fixed (no depth: such a point
// is returned unchanged; kept free it would make the Schur complement singular). Never throws for bad
// numbers: non-finite inputs make it return ok = false without touching the problem.
BaSummary RunBundleAdjustment(const PinholeCamera& camera, const RobotGeometry& robot, const BaOptions& options,
                              BaProblem* problem);

// Pose-only refinement (points held fixed, given as data): the correspondences listed in `use`, the camera model,
// loss and iteration count of options. Returns false (pose untouched) on failure.
bool RefinePose(const PinholeCamera& camera, const RobotGeometry& robot, const BaOptions& options,
                const std::vector<Eigen::Vector3d>& points_in_world, const std::vector<Eigen::Vector2d>& pixels,
                const std::vector<int>& use, Eigen::Isometry3d* world_from_camera);

// RMS reprojection error (px) of observations (points behind a camera count as 1e3 px).
double ReprojectionRms(const PinholeCamera& camera, const BaProblem& problem);

}  // namespace objscan
