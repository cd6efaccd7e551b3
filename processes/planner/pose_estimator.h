// RobotPoseEstimator: the robot base pose in the world (mm, rad) from the pose solver's camera poses and the
// odometry, LCM-free.
//   - A usable camera pose (TRACKING, RELOCALIZED, GROUND_TRUTH) and the head angles of the odometry reading nearest
//     to its utime (within max_odometry_gap_us) give the base pose exactly (BasePoseFromCamera, the robot model's
//     inverse). That pose wins: it becomes the anchor of the estimate.
//   - Between camera poses, and while the poses are INITIALIZING or LOST, the estimate dead-reckons: the anchor
//     composed with the odometry increment from the anchor's reading to the latest reading.
//   - Before any usable camera pose the estimate is the odometry pose itself: by the system contract the world frame
//     is the odometry frame at the start (world_from_odometry = identity). Before any odometry: the origin.
//   - Disagreement: for every usable camera pose, the odometry pose (mapped into world by that identity) against the
//     pose from the camera, as a distance (mm) and a heading difference (rad); the last and the largest are kept.
// Odometry readings that do not advance in utime or carry non-finite values are refused (false); camera poses with
// non-finite values too.
#pragma once

#include <cstdint>
#include <deque>

#include "common/robot_model.h"
#include "common/sensor_data.h"
#include "processes/planner/planner_geometry.h"

namespace objscan {

struct PoseDisagreement {
  double distance_mm = 0;  // mm, odometry position vs estimate
  double angle_rad = 0;    // rad, |heading difference|
};

class RobotPoseEstimator {
 public:
  enum class Source { kNone, kOdometry, kCameraPose, kDeadReckoned };

  explicit RobotPoseEstimator(const RobotGeometry& robot, int64_t max_odometry_gap_us = 200000);

  bool AddOdometry(const OdometryReading& reading);
  // True when the pose set the estimate (usable status, finite, odometry reading near its utime).
  bool AddCameraPose(const CameraPoseEstimate& pose);

  BasePose Estimate() const;
  Source source() const { return source_; }
  bool has_odometry() const { return !readings_.empty(); }
  const OdometryReading* latest_odometry() const { return readings_.empty() ? nullptr : &readings_.back(); }
  int64_t camera_poses_used() const { return camera_poses_used_; }
  const PoseDisagreement& last_disagreement() const { return last_; }
  const PoseDisagreement& max_disagreement() const { return max_; }

 private:
  const OdometryReading* NearestReading(int64_t utime) const;

  RobotGeometry robot_;
  int64_t max_gap_us_;
  std::deque<OdometryReading> readings_;  // the latest readings, increasing utime
  bool anchored_ = false;
  BasePose anchor_world_;     // estimate at the anchor
  BasePose anchor_odometry_;  // odometry pose at the anchor
  Source source_ = Source::kNone;
  int64_t camera_poses_used_ = 0;
  PoseDisagreement last_, max_;
};

// Odometry pose of a reading (odometry frame).
inline BasePose OdometryPose(const OdometryReading& r) { return {r.x_mm, r.y_mm, r.theta_rad}; }

}  // namespace objscan
