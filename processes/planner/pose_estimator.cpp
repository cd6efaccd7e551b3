#include "processes/planner/pose_estimator.h"

#include <cmath>
#include <cstdlib>

namespace objscan {
namespace {
constexpr size_t kReadingsKept = 256;

bool Finite(const OdometryReading& r) {
  return std::isfinite(r.x_mm) && std::isfinite(r.y_mm) && std::isfinite(r.theta_rad) && std::isfinite(r.pan_rad) &&
         std::isfinite(r.tilt_rad);
}
}  // namespace

RobotPoseEstimator::RobotPoseEstimator(const RobotGeometry& robot, int64_t max_odometry_gap_us)
    : robot_(robot), max_gap_us_(max_odometry_gap_us) {}

bool RobotPoseEstimator::AddOdometry(const OdometryReading& reading) {
  if (!Finite(reading)) return false;
  if (!readings_.empty() && reading.utime <= readings_.back().utime) return false;
  readings_.push_back(reading);
  if (readings_.size() > kReadingsKept) readings_.pop_front();
  if (source_ == Source::kNone) source_ = Source::kOdometry;
  if (source_ == Source::kCameraPose) source_ = Source::kDeadReckoned;
  return true;
}

const OdometryReading* RobotPoseEstimator::NearestReading(int64_t utime) const {
  const OdometryReading* best = nullptr;
  int64_t best_gap = 0;
  for (auto it = readings_.rbegin(); it != readings_.rend(); ++it) {
    const int64_t gap = std::llabs(it->utime - utime);
    if (best == nullptr || gap < best_gap) {
      best = &*it;
      best_gap = gap;
    } else if (it->utime < utime) {
      break;  // older readings only get farther
    }
  }
  return best != nullptr && best_gap <= max_gap_us_ ? best : nullptr;
}

bool RobotPoseEstimator::AddCameraPose(const CameraPoseEstimate& pose) {
  const bool usable = pose.status == PoseStatus::kTracking || pose.status == PoseStatus::kRelocalized ||
                      pose.status == PoseStatus::kGroundTruth;
  if (!usable || !pose.world_from_camera.matrix().allFinite()) return false;
  const OdometryReading* reading = NearestReading(pose.utime);
  if (reading == nullptr) return false;
  const BasePose from_camera = BasePoseFromCamera(robot_, pose.world_from_camera, reading->pan_rad, reading->tilt_rad);
  if (!std::isfinite(from_camera.x_mm) || !std::isfinite(from_camera.y_mm) || !std::isfinite(from_camera.theta_rad))
    return false;
  const BasePose odometry = OdometryPose(*reading);  // world_from_odometry = identity (system contract)
  last_.distance_mm = std::hypot(odometry.x_mm - from_camera.x_mm, odometry.y_mm - from_camera.y_mm);
  last_.angle_rad = std::abs(WrapAngle(odometry.theta_rad - from_camera.theta_rad));
  if (last_.distance_mm > max_.distance_mm) max_.distance_mm = last_.distance_mm;
  if (last_.angle_rad > max_.angle_rad) max_.angle_rad = last_.angle_rad;
  anchored_ = true;
  anchor_world_ = from_camera;
  anchor_odometry_ = odometry;
  source_ = reading == &readings_.back() ? Source::kCameraPose : Source::kDeadReckoned;
  ++camera_poses_used_;
  return true;
}

BasePose RobotPoseEstimator::Estimate() const {
  if (readings_.empty()) return anchored_ ? anchor_world_ : BasePose{};
  const BasePose latest = OdometryPose(readings_.back());
  if (!anchored_) return latest;
  return Compose(anchor_world_, Between(anchor_odometry_, latest));
}

}  // namespace objscan
