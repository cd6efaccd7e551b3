// The files of a recorded robot run kept as a dataset folder (LCM-free; the one home of these formats). Beside
// images/ and calib.yaml (drivers/camera/README.md) a folder may hold:
//
//   timestamps.txt  the time of every image: "FILE_NAME UTIME_US" per line ('#' comments), FILE_NAME as in images/,
//                   utime in µs on the robot's clock (the clock of odometry.txt). Every image file must have a line
//                   and the times must increase in file-name order.
//   odometry.txt    wheel odometry and head encoders, one reading per line, the fields of odometry_t:
//                   "t_s utime_us seq x_mm y_mm theta_rad pan_rad tilt_rad v_mm_s omega_rad_s pan_rate_rad_s
//                   tilt_rate_rad_s" ('#' comments; t_s = utime_us / 1e6, kept for people reading the file, must
//                   agree within 1 ms). Odometry frame: x forward, y left, z up at the robot's start pose; theta
//                   about +z; pan and tilt as the robot's encoders report them (robot.cfg maps them to objscan's
//                   convention: pan > 0 = left, tilt > 0 = looking down). utime must increase.
//   robot.cfg       the robot's geometry and head conventions, "name = value" lines ('#' comments):
//                     mast_height_mm       (required) pan/tilt axes above the floor, mm
//                     mast_offset_x_mm, mast_offset_y_mm            mast forward / left of the base centre, mm
//                     camera_offset_x_mm, camera_offset_y_mm, camera_offset_z_mm
//                                          optical centre in the tilt frame (forward, left, up), mm
//                     wheel_base_mm        distance between the drive wheels, mm
//                     pan_sign, tilt_sign  +1 or -1: objscan angle = sign * (encoder angle - zero)
//                     pan_zero_rad, tilt_zero_rad  encoder readings when the camera looks straight ahead, level
//                   Frames and meanings as in common/robot_model.h. Unknown or repeated names are errors.
//
// A video folder (one video file instead of images/, drivers/camera/README.md) holds the same files, except that
// timestamps.txt names frames by number: "FRAME_NUMBER UTIME_US", frames numbered from 0 in decoding order, every
// frame a line. Without timestamps.txt a video's frames take the container's presentation times (0 = its first
// frame), and odometry.txt must then be on that clock.
//
// Errors: the readers return false with *error naming the file and line; nothing here throws or exits.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/robot_model.h"
#include "common/sensor_data.h"

namespace objscan {

constexpr const char* kTimestampsFileName = "timestamps.txt";
constexpr const char* kOdometryFileName = "odometry.txt";
constexpr const char* kRobotFileName = "robot.cfg";

struct FrameTime {
  std::string file_name;  // as in images/ (no directory)
  int64_t utime = 0;      // µs
};
bool WriteFrameTimes(const std::string& path, const std::vector<FrameTime>& times, std::string* error);
// Reads timestamps.txt in file order. Rejects malformed lines, repeated names and negative times.
bool ReadFrameTimes(const std::string& path, std::vector<FrameTime>* times, std::string* error);

bool WriteOdometryFile(const std::string& path, const std::vector<OdometryReading>& readings, std::string* error);
// Reads odometry.txt. Rejects malformed lines (12 numbers), non-finite values, t_s that disagrees with utime_us by
// more than 1 ms, and utime that does not increase.
bool ReadOdometryFile(const std::string& path, std::vector<OdometryReading>* readings, std::string* error);

struct RobotDescription {
  RobotGeometry geometry;
  double pan_sign = 1, tilt_sign = 1;          // +1 or -1
  double pan_zero_rad = 0, tilt_zero_rad = 0;  // rad, encoder readings of the straight-ahead, level camera
  // The base's and the head's limits: the planner plans within them; the simulator enforces the footprint, speed and
  // yaw rate (not the head's limits).
  double footprint_radius_mm = 200;  // mm, radius of the base's round footprint (> 0)
  double max_speed_mm_s = 400;       // mm/s, base speed (> 0)
  double max_omega_deg_s = 90;       // deg/s, base yaw rate (> 0)
  double pan_limit_deg = 170;        // deg, |pan| at most, (0, 180]
  double tilt_min_deg = 0;           // deg, lowest tilt (positive = looking down), < tilt_max_deg
  double tilt_max_deg = 60;          // deg, highest tilt, <= 90

  // A reading in objscan's convention (pan > 0 = left, tilt > 0 = down, 0 = straight ahead and level).
  OdometryReading ToObjscanConvention(const OdometryReading& encoder_reading) const;
};
bool WriteRobotFile(const std::string& path, const RobotDescription& robot, std::string* error);
// Reads robot.cfg; mast_height_mm is required, the rest default to RobotDescription's values. Rejects unknown and
// repeated names, non-numbers, signs other than +-1, an invalid geometry (RobotGeometry::IsValid) and limits out of
// their ranges.
bool ReadRobotFile(const std::string& path, RobotDescription* robot, std::string* error);

}  // namespace objscan
