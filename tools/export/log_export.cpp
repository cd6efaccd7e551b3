#include "tools/export/log_export.h"

#include <filesystem>

#include "common/adapters.h"
#include "common/lcm_log.h"
#include "common/log.h"
#include "common/message_size_check.h"
#include "common/options.h"
#include "common/recorded_run.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"

namespace objscan {
namespace {
bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

template <class Msg>
bool Decode(const LcmLogEvent& event, Msg* msg) {
  return DecodeMessage(event.data.data(), static_cast<int>(event.data.size()), msg, nullptr);
}
}  // namespace

void AddLogExportOptions(OptionParser& parser, LogExportOptions* options) {
  parser.Add("log", &options->log_path, "LCM log file to read");
  parser.Add("out", &options->out_dir, "dataset folder to write (created: images/, calib.yaml, poses_gt.txt, ...)");
  parser.AddChannel(&options->image_channel, "channel of image_t frames");
  parser.AddChannel(&options->info_channel, "channel of camera_info_t (the first one -> calib.yaml)");
  parser.AddChannel(&options->ground_truth_channel, "channel of true pose_t (-> poses_gt.txt)");
  parser.AddChannel(&options->odometry_channel, "channel of odometry_t (-> odometry.txt)");
  parser.Add("every", &options->every, "keep frames whose seq is a multiple of N (1 = all)");
  parser.Add("max-frames", &options->max_frames, "write at most N frames (0 = all)");
  parser.Add("video", &options->video,
             "write the frames as DIR/video.avi (Motion-JPEG, quality 95) with a frame-numbered timestamps.txt "
             "instead of images/ (a recorded run as a video folder)");
  parser.Add("robot-file", &options->robot_file,
             "the robot's robot.cfg (geometry, head conventions; the simulator writes ground_truth/robot.cfg): "
             "checked and copied into the folder, so that it replays with its odometry");
}

bool ValidateLogExportOptions(const LogExportOptions& options, std::string* why) {
  if (options.log_path.empty()) return Fail(why, "--log: the LCM log to read is required");
  if (options.image_channel.empty() || options.info_channel.empty() || options.ground_truth_channel.empty() ||
      options.odometry_channel.empty())
    return Fail(why, "channel names must not be empty");
  DatasetWriterOptions writer;
  writer.out_dir = options.out_dir;
  writer.every = options.every;
  writer.max_frames = options.max_frames;
  return ValidateDatasetWriterOptions(writer, why);
}

bool ExportLogToDataset(const LogExportOptions& options, LogExportResult* result, std::string* error) {
  *result = LogExportResult();
  if (!ValidateLogExportOptions(options, error)) return false;
  LcmLogReader log;
  if (!log.Open(options.log_path, error)) return false;

  DatasetWriter writer;
  DatasetWriterOptions writer_options;
  writer_options.out_dir = options.out_dir;
  writer_options.every = options.every;
  writer_options.max_frames = options.max_frames;
  writer_options.video = options.video;
  RobotDescription robot;
  if (!options.robot_file.empty() && !ReadRobotFile(options.robot_file, &robot, error)) return false;
  if (!writer.Open(writer_options, error)) return false;
  auto reject = [result](const std::string& reason, const std::string& detail) {
    if (result->rejected[reason]++ == 0) LogWarning("skipped: " + reason + " (" + detail + "); further ones counted");
  };

  bool ok = true;
  LcmLogEvent event;
  while (log.Next(&event)) {
    ++result->events_read;
    const std::string& channel = event.channel;
    const std::string where = "event " + std::to_string(event.event_number) + " on " + channel;
    if (channel == options.image_channel) {
      if (!writer.LimitReached()) {
        image_t msg;
        ImageFrame frame;
        std::string reason;
        if (!Decode(event, &msg)) {
          writer.CountUndecodable();
          reject("image: not an image_t", where);
        } else if (!ImageFromMessage(msg, &frame, &reason)) {
          writer.CountUndecodable();
          reject(reason, where + ", seq " + std::to_string(msg.seq));
        } else {
          std::string why;
          const DatasetWriter::FrameResult r = writer.AddFrame(frame, &why);
          if (r == DatasetWriter::FrameResult::kError) {
            ok = Fail(error, why);
          } else if (r == DatasetWriter::FrameResult::kDuplicateSeq) {
            reject("image: duplicate seq", where + ", seq " + std::to_string(frame.seq));
          }
        }
      }
    } else if (channel == options.info_channel) {
      camera_info_t msg;
      PinholeCamera camera;
      std::string reason;
      if (!Decode(event, &msg))
        reject("camera_info: not a camera_info_t", where);
      else if (!CameraFromMessage(msg, &camera, &reason))
        reject(reason, where);
      else
        writer.AddCamera(camera);
    } else if (channel == options.ground_truth_channel) {
      pose_t msg;
      CameraPoseEstimate pose;
      std::string reason;
      if (!Decode(event, &msg))
        reject("ground truth: not a pose_t", where);
      else if (!PoseFromMessage(msg, &pose, &reason))
        reject(reason, where);
      else
        writer.AddTruePose(pose);
    } else if (channel == options.odometry_channel) {
      odometry_t msg;
      OdometryReading reading;
      std::string reason;
      if (!Decode(event, &msg))
        reject("odometry: not an odometry_t", where);
      else if (!OdometryFromMessage(msg, &reading, &reason))
        reject(reason, where);
      else
        writer.AddOdometry(reading);
    }
    if (!ok) break;
  }
  if (!ok) return false;
  result->log_damage = log.damage().Describe();
  if (!writer.Finish(error)) return false;
  result->dataset = writer.summary();
  if (!options.robot_file.empty() &&
      !WriteRobotFile((std::filesystem::path(options.out_dir) / kRobotFileName).string(), robot, error))
    return false;
  if (result->dataset.odometry_written > 0 && options.robot_file.empty())
    LogWarning("odometry.txt written without robot.cfg: the folder replays with its odometry only once the robot's "
               "robot.cfg is beside it (--robot-file; format in common/recorded_run.h)");
  return true;
}

}  // namespace objscan
