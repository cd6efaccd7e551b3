// Exports an objscan LCM log (e.g. a simulated session.lcmlog) into a dataset folder (format in export_dataset.h):
// images from the image channel (any image_t encoding, written as lossless PNG named by seq), calib.yaml from the
// first camera_info_t, poses_gt.txt from the ground-truth channel (pose_t world_from_camera, mm) and odometry.txt
// from the odometry channel. Messages that do not decode (wrong type, bad image) are skipped, counted and logged
// once per reason. Reads the log file directly (no bus); blocking; never throws or exits.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "tools/export/export_dataset.h"

namespace objscan {

class OptionParser;

struct LogExportOptions {
  std::string log_path;                                    // --log: LCM log file to read
  std::string out_dir;                                     // --out: dataset folder to write (created)
  std::string image_channel = "CAMERA_IMAGE";              // image_t frames
  std::string info_channel = "CAMERA_INFO";                // camera_info_t calibration
  std::string ground_truth_channel = "GROUND_TRUTH_POSE";  // pose_t true poses
  std::string odometry_channel = "ROBOT_ODOMETRY";         // odometry_t readings
  int every = 1;                                           // --every: keep frames whose seq is a multiple of N
  int64_t max_frames = 0;                                  // --max-frames: write at most N frames (0 = all)
  std::string robot_file;  // --robot-file: the robot's robot.cfg (common/recorded_run.h), checked, -> DIR/robot.cfg
  bool video = false;      // --video: a video folder (video.avi, frame-numbered timestamps.txt) instead of images/
};

// Registers every LogExportOptions field (names as in the comments).
void AddLogExportOptions(OptionParser& parser, LogExportOptions* options);
// False with *why on the first invalid value (missing --log / --out, every < 1, max_frames < 0, empty channel).
bool ValidateLogExportOptions(const LogExportOptions& options, std::string* why);

struct LogExportResult {
  DatasetExportSummary dataset;
  int64_t events_read = 0;                  // events in the log
  std::map<std::string, int64_t> rejected;  // reason -> count (undecodable messages of the exported channels)
  std::string log_damage;                   // what of the log was skipped as damaged ("" when whole)
};

// Reads the whole log and writes the folder. False with *error when the log cannot be opened, the options are
// invalid or a file cannot be written; bad messages are not errors (see result->rejected).
bool ExportLogToDataset(const LogExportOptions& options, LogExportResult* result, std::string* error);

}  // namespace objscan
