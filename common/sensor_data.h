// Plain data structs the algorithm libraries take and return (no LCM here). adapters.h converts messages.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace objscan {

struct ImageFrame {
  int64_t utime = 0;        // µs, capture time
  int64_t seq = 0;          // frame sequence number
  std::string camera_name;
  cv::Mat image;            // CV_8UC1 (gray) or CV_8UC3 (BGR)
};

struct TrackedFeature {
  int64_t id = 0;           // persistent track id
  float u = 0, v = 0;       // px, (column, row), origin at the top-left pixel's centre
  int32_t age = 0;          // frames since birth (0 = born in this frame)
};

struct TrackFrame {
  int64_t utime = 0;        // µs, capture time of the frame
  int64_t seq = 0;          // frame sequence number
  std::string camera_name;
  int width = 0, height = 0;  // px
  std::vector<TrackedFeature> features;
};

struct OdometryReading {
  int64_t utime = 0;        // µs, time the reading claims
  int64_t seq = 0;
  double x_mm = 0, y_mm = 0, theta_rad = 0;  // robot base in the odometry frame
  double pan_rad = 0, tilt_rad = 0;          // head joint angles (tilt positive = down)
  double v_mm_s = 0, omega_rad_s = 0;
  double pan_rate_rad_s = 0, tilt_rate_rad_s = 0;
};

enum class PoseStatus : int8_t { kInitializing = 0, kTracking = 1, kLost = 2, kRelocalized = 3, kGroundTruth = 4 };
enum class ScaleSource : int8_t { kNone = 0, kCameraHeight = 1, kOdometry = 2, kTrue = 3 };

// True when lengths are millimetres: the scale comes from the odometry, from the floor and a configured camera
// height, or from the simulator's truth. Without either (images only) lengths are in an arbitrary unit.
inline bool IsMetric(ScaleSource s) { return s != ScaleSource::kNone; }
// What the scale of a result is, for file headers, final log lines and summary.json: "metric (...)" or
// "arbitrary (...)", one line, no newline.
inline const char* ScaleDescription(ScaleSource s) {
  switch (s) {
    case ScaleSource::kOdometry:
      return "metric (mm, scale from the odometry)";
    case ScaleSource::kCameraHeight:
      return "metric (mm, scale from the floor and the configured camera height)";
    case ScaleSource::kTrue:
      return "metric (mm, true poses)";
    case ScaleSource::kNone:
      break;
  }
  return "arbitrary (no odometry and no camera height: lengths are in an unknown unit, not mm)";
}

struct CameraPoseEstimate {
  int64_t utime = 0;        // µs, capture time of the frame
  int64_t seq = 0;          // frame sequence number
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  PoseStatus status = PoseStatus::kInitializing;
  ScaleSource scale_source = ScaleSource::kNone;
  int num_inliers = 0;
  double reprojection_rms_px = 0;
  // Frame seq where the map this pose lies in began (pose_t.map_start_seq): poses with different values lie in maps
  // never joined, related by the odometry only. -1: not from a map (ground truth, unposed frames).
  int64_t map_start_seq = -1;
};

}  // namespace objscan
