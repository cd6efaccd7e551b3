#include "drivers/camera/camera_node.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/log.h"
#include "common/options.h"
#include "common/recorded_run.h"
#include "common/time.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {

bool EncodingFromName(const std::string& name, int8_t* encoding) {
  if (name == "gray8")
    *encoding = image_t::ENCODING_GRAY8;
  else if (name == "rgb8")
    *encoding = image_t::ENCODING_RGB8;
  else if (name == "bgr8")
    *encoding = image_t::ENCODING_BGR8;
  else if (name == "jpeg")
    *encoding = image_t::ENCODING_JPEG;
  else
    return false;
  return true;
}

}  // namespace

void AddCameraNodeOptions(OptionParser& parser, CameraNodeOptions* o) {
  // Only what a user sets (issue 27): the source and what of it is played (calibration, order, rotation, loop, frame
  // limit, device size), its encoding, pace and lock-step, the recorded odometry switch, and the channels. The
  // ground truth's unit scale, its publication switch and the camera name keep their defaults here; tests set the
  // struct directly.
  parser.Add("source", &o->source,
             "image folder (images/ or images in it + calib.yaml [+ poses_gt.txt]), Middlebury folder or "
             "*_par.txt, video file, /dev/videoN or device index");
  parser.Add("calib", &o->calib,
             "calibration file (OpenCV FileStorage: camera_matrix, distortion_coefficients, image_width, "
             "image_height); required for video / V4L2, overrides the source's own");
  parser.Add("rate", &o->rate_hz,
             "Hz, frame timestamps i*1e6/rate and publication pace; 0 = as fast as possible "
             "(timestamps at 30 Hz)");
  parser.Add("realtime", &o->realtime, "pace on the fixed wall-clock schedule start + i/rate (late frames catch up)");
  parser.Add("loop", &o->loop, "start again at the first frame at the end (no END_OF_STREAM; seq keeps counting)");
  parser.Add("order", &o->order, "explicit frame order, e.g. \"9,8,7\", \"3-5,1\" (1-based) or file names");
  parser.Add("rotate-180", &o->rotate_180,
             "frames (1-based natural positions, ranges or file names; or \"all\") to rotate 180 deg in-plane, "
             "with intrinsics and true pose adjusted");
  parser.Add("encoding", &o->encoding, "image encoding: rgb8, bgr8, gray8 or jpeg");
  parser.Add("jpeg-quality", &o->jpeg_quality, "JPEG quality 1..100 (--encoding jpeg)");
  parser.Add("max-frames", &o->max_frames, "stop after this many published frames (0 = all)");
  parser.Add("session-id", &o->session_id,
             "the session's id, stamped on every image, calibration and odometry message: 1-16 hex digits (empty = "
             "a random one); processes keep to the first session they hear and refuse the others");
  parser.Add("lockstep-channel", &o->lockstep_channel,
             "publish frame i+1 only after a message with seq >= i on this channel (empty = off)");
  parser.Add("lockstep-timeout-ms", &o->lockstep_timeout_ms,
             "ms, go on after waiting this long for the lockstep message (0 = wait forever)");
  parser.Add("device-size", &o->device_size, "WxH px, V4L2 capture size to request (\"\" = the calibration's size)");
  parser.AddChannel(&o->image_channel, "output channel for image_t");
  parser.AddChannel(&o->info_channel, "output channel for camera_info_t");
  parser.AddChannel(&o->ground_truth_channel, "output channel for the true poses (pose_t)");
  parser.AddChannel(&o->control_channel, "output channel for END_OF_STREAM (control_t)");
  parser.AddChannel(&o->status_channel, "output channel for process_status_t");
  parser.Add("exit-when-finished", &o->exit_when_finished, "exit after END_OF_STREAM");
  parser.Add("odometry", &o->odometry,
             "publish an image or video folder's odometry.txt (needs robot.cfg beside it, and timestamps.txt for "
             "images; a video without it uses the container's times); false: the images alone");
  parser.AddChannel(&o->odometry_channel, "output channel for odometry_t");
}

bool ParseDeviceSize(const std::string& text, int* width, int* height) {
  *width = *height = 0;
  if (text.empty()) return true;
  const size_t x = text.find('x');
  if (x == std::string::npos || x == 0 || x + 1 == text.size()) return false;
  const std::string w = text.substr(0, x), h = text.substr(x + 1);
  const auto digits = [](const std::string& s) {
    return s.size() <= 5 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!digits(w) || !digits(h)) return false;
  const int wv = std::stoi(w), hv = std::stoi(h);
  if (wv <= 0 || hv <= 0) return false;
  *width = wv;
  *height = hv;
  return true;
}

bool ValidateCameraNodeOptions(const CameraNodeOptions& o, std::string* why) {
  auto fail = [why](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  int8_t encoding = 0;
  if (o.source.empty()) return fail("--source is required");
  int64_t session_id = 0;  // "" draws one: always valid
  if (std::string session_why; !SessionIdFromText(o.session_id, &session_id, &session_why))
    return fail("--session-id: " + session_why);
  if (!std::isfinite(o.rate_hz) || o.rate_hz < 0 || o.rate_hz > 10000) return fail("--rate must be in [0, 10000] Hz");
  if (o.realtime && o.rate_hz <= 0) return fail("--realtime needs --rate > 0");
  if (!EncodingFromName(o.encoding, &encoding)) return fail("--encoding must be rgb8, bgr8, gray8 or jpeg");
  if (o.jpeg_quality < 1 || o.jpeg_quality > 100) return fail("--jpeg-quality must be in 1..100");
  if (o.max_frames < 0) return fail("--max-frames must be >= 0");
  if (o.lockstep_timeout_ms < 0) return fail("--lockstep-timeout-ms must be >= 0");
  if (!std::isfinite(o.gt_position_scale) || o.gt_position_scale <= 0) return fail("gt_position_scale must be > 0");
  int width = 0, height = 0;
  if (!ParseDeviceSize(o.device_size, &width, &height))
    return fail("--device-size must be WxH in px, e.g. 640x480 (got '" + o.device_size + "')");
  if (o.camera_name.empty()) return fail("camera_name must not be empty");
  if (o.image_channel.empty() || o.info_channel.empty() || o.ground_truth_channel.empty() ||
      o.control_channel.empty() || o.status_channel.empty() || o.odometry_channel.empty())
    return fail("channel names must not be empty");
  return true;
}

CameraNode::CameraNode(Bus& bus, const CameraNodeOptions& options)
    : bus_(bus), options_(options), status_(&bus, kProcessName, options.status_channel) {
  std::string why;
  if (!ValidateCameraNodeOptions(options_, &why)) throw std::invalid_argument(why);
  EncodingFromName(options_.encoding, &encoding_);
  FrameSourceOptions source_options;
  source_options.path = options_.source;
  source_options.calib_path = options_.calib;
  source_options.order = options_.order;
  source_options.rotate_180 = options_.rotate_180;
  source_options.gt_position_scale = options_.gt_position_scale;
  source_options.camera_name = options_.camera_name;
  ParseDeviceSize(options_.device_size, &source_options.device_width, &source_options.device_height);
  source_ = OpenFrameSource(source_options, &why);
  if (!source_) throw std::runtime_error(why);

  timestamp_rate_ = options_.rate_hz > 0 ? options_.rate_hz : 30.0;
  if (source_->IsLive() && source_->SourceRate() > 0) timestamp_rate_ = source_->SourceRate();
  SessionIdFromText(options_.session_id, &session_id_, &why);  // validated above; "" draws one
  status_.SetSession(session_id_);
  LogInfo("source: " + source_->Describe() + "; session " + SessionIdText(session_id_));
  const bool folder_source = source_->kind() == SourceKind::kImageFolder ||
                             (source_->kind() == SourceKind::kVideoFile && std::filesystem::is_directory(options_.source));
  if (folder_source && options_.odometry) LoadRecordedOdometry();
  if (odometry_.empty()) LogInfo("timestamps at " + std::to_string(timestamp_rate_) + " Hz");

  if (!options_.lockstep_channel.empty()) {
    bus_.Subscribe(options_.lockstep_channel, [this](const RawMessage& raw) {
      int64_t seq = 0;
      if (!RawMessageSeq(raw.data, raw.size, &seq)) {
        status_.Reject("lockstep: message too short", raw.channel);
        return;
      }
      if (seq > lockstep_max_seq_) lockstep_max_seq_ = seq;
    });
  }
  status_.SetState(process_status_t::STATE_STARTING, source_->Describe());
  UpdateStatusValues();
}

CameraNode::~CameraNode() = default;

template <class Msg>
void CameraNode::Publish(const std::string& channel, Msg msg) {
  StampSession(&msg, session_id_);
  if (bus_.PublishMessage(channel, msg)) {
    status_.CountOut();
  } else if (publish_failures_++ == 0) {
    LogError("publishing on " + channel + " failed (further failures are only counted)");
  }
}

bool CameraNode::LockstepReady(int64_t wall_utime) {
  if (options_.lockstep_channel.empty() || frames_published_ == 0) return true;
  const int64_t needed = frames_published_ - 1;  // seq of the frame the consumer must have handled
  if (lockstep_max_seq_ >= needed || lockstep_released_seq_ == needed) {
    lockstep_waiting_for_ = -1;
    return true;
  }
  if (lockstep_waiting_for_ != needed) {
    lockstep_waiting_for_ = needed;
    lockstep_wait_start_ = wall_utime;
    status_.SetState(process_status_t::STATE_RUNNING,
                     "waiting on " + options_.lockstep_channel + " for seq " + std::to_string(needed));
  }
  if (options_.lockstep_timeout_ms > 0 &&
      wall_utime - lockstep_wait_start_ >= static_cast<int64_t>(options_.lockstep_timeout_ms) * 1000) {
    ++lockstep_timeouts_;
    LogWarning("no seq >= " + std::to_string(needed) + " on " + options_.lockstep_channel + " within " +
               std::to_string(options_.lockstep_timeout_ms) + " ms; going on");
    lockstep_released_seq_ = needed;
    lockstep_waiting_for_ = -1;
    return true;
  }
  return false;
}

bool CameraNode::FrameDue(int64_t wall_utime) const {
  if (source_->IsLive() || options_.rate_hz <= 0 || frames_published_ == 0) return true;
  if (options_.realtime) {
    return wall_utime >=
           schedule_start_wall_ + std::llround(static_cast<double>(frames_published_) * 1e6 / options_.rate_hz);
  }
  return wall_utime >= last_publish_wall_ + std::llround(1e6 / options_.rate_hz);
}

bool CameraNode::PublishNextFrame(int64_t wall_utime) {
  for (;;) {
    if (options_.max_frames > 0 && frames_published_ >= options_.max_frames) {
      FinishStream();
      return false;
    }
    const int64_t read_start = MonotonicMicros();
    SourceFrame frame;
    std::string reason, detail;
    const ReadResult result = source_->Next(&frame, &reason, &detail);
    if (result == ReadResult::kSkipped) {
      ++frames_skipped_;
      status_.Reject(reason, detail);
      LogWarning("skipped " + detail + " (" + reason + ")");
      continue;
    }
    if (result == ReadResult::kEnd) {
      if (options_.loop && frames_published_in_pass_ > 0 && source_->Rewind()) {
        frames_published_in_pass_ = 0;
        ++passes_;
        continue;
      }
      FinishStream();
      return false;
    }
    status_.CountIn();
    const int64_t seq = frames_published_;
    const int64_t utime = !odometry_.empty() ? frame.recorded_utime
                                             : std::llround(static_cast<double>(seq) * 1e6 / timestamp_rate_);
    if (!odometry_.empty()) {
      PublishOdometryUpTo(utime);
      constexpr int64_t kMaxGapUs = 500000;
      if (utime < odometry_.front().utime - kMaxGapUs || utime > odometry_.back().utime + kMaxGapUs) {
        if (frames_without_odometry_++ == 0)
          LogWarning(frame.name + " (t = " + std::to_string(utime / 1e6) + " s) has no odometry within 0.5 s: " +
                     std::string(kOdometryFileName) + " covers " + std::to_string(odometry_.front().utime / 1e6) +
                     " .. " + std::to_string(odometry_.back().utime / 1e6) + " s (further frames only counted)");
      }
    }

    // Calibration first, so that a receiver has it when the image arrives.
    camera_info_t info = CameraToMessage(frame.camera, utime);
    info.camera_name = options_.camera_name;
    Publish(options_.info_channel, info);

    ImageFrame image_frame;
    image_frame.utime = utime;
    image_frame.seq = seq;
    image_frame.camera_name = options_.camera_name;
    image_frame.image = frame.image;
    Publish(options_.image_channel, ImageToMessage(image_frame, encoding_, options_.jpeg_quality));

    if (frame.has_true_pose && options_.publish_ground_truth) {
      CameraPoseEstimate truth;
      truth.utime = utime;
      truth.seq = seq;
      truth.world_from_camera = frame.world_from_camera;
      truth.status = PoseStatus::kGroundTruth;
      truth.scale_source = ScaleSource::kTrue;
      Publish(options_.ground_truth_channel, PoseToMessage(truth, "world", "camera"));
    }

    ++frames_published_;
    ++frames_published_in_pass_;
    last_utime_ = utime;
    last_publish_wall_ = wall_utime;
    status_.SetLastDataUtime(utime);
    status_.RecordLatencyMs(static_cast<double>(MonotonicMicros() - read_start) / 1000.0);
    status_.SetState(process_status_t::STATE_RUNNING, "published " + frame.name + " as seq " + std::to_string(seq));
    return true;
  }
}

void CameraNode::LoadRecordedOdometry() {
  namespace fs = std::filesystem;
  const fs::path root(options_.source);
  const fs::path odometry_path = root / kOdometryFileName, robot_path = root / kRobotFileName;
  if (!fs::is_regular_file(odometry_path)) return;
  auto fail = [&](const std::string& what) {
    throw std::runtime_error(odometry_path.string() + ": " + what + " (--odometry=false plays the images alone)");
  };
  if (!fs::is_regular_file(robot_path))
    fail("a recorded run needs " + robot_path.string() +
         ", the robot's geometry and head conventions (format in common/recorded_run.h)");
  const bool video = source_->kind() == SourceKind::kVideoFile;
  if (!video && !fs::is_regular_file(root / kTimestampsFileName))
    fail("a recorded run needs " + (root / kTimestampsFileName).string() + ", the time of every image");
  if (!options_.order.empty()) fail("--order cannot reorder a recorded run");
  if (options_.loop) fail("--loop cannot repeat a recorded run");
  RobotDescription robot;
  std::string error;
  if (!ReadRobotFile(robot_path.string(), &robot, &error)) throw std::runtime_error(error);
  std::vector<OdometryReading> readings;
  if (!ReadOdometryFile(odometry_path.string(), &readings, &error)) throw std::runtime_error(error);
  if (readings.empty()) fail("no reading");
  for (const auto& r : readings) odometry_.push_back(robot.ToObjscanConvention(r));
  LogInfo("recorded run: " + std::to_string(odometry_.size()) + " odometry readings, t = " +
          std::to_string(odometry_.front().utime / 1e6) + " .. " + std::to_string(odometry_.back().utime / 1e6) +
          " s; image times from " +
          (fs::is_regular_file(root / kTimestampsFileName) ? std::string(kTimestampsFileName)
                                                           : std::string("the video container (0 = its first frame)")) +
          "; robot from " + robot_path.string());
}

void CameraNode::PublishOdometryUpTo(int64_t utime) {
  while (next_odometry_ < odometry_.size() && odometry_[next_odometry_].utime <= utime)
    Publish(options_.odometry_channel, OdometryToMessage(odometry_[next_odometry_++]));
  if (next_odometry_ < odometry_.size() && utime != INT64_MAX)  // the bracket after the frame time
    Publish(options_.odometry_channel, OdometryToMessage(odometry_[next_odometry_++]));
}

void CameraNode::FinishStream() {
  if (end_of_stream_sent_) return;
  if (!odometry_.empty()) PublishOdometryUpTo(INT64_MAX);
  control_t control;
  control.session_id = 0;  // Publish stamps the session
  control.utime = last_utime_;
  control.sender = kProcessName;
  control.target = "*";
  control.command = control_t::COMMAND_END_OF_STREAM;
  control.last_seq = frames_published_ - 1;
  control.argument = "";
  Publish(options_.control_channel, control);
  end_of_stream_sent_ = true;
  const std::string summary = "end of stream after " + std::to_string(frames_published_) + " frames (" +
                              std::to_string(frames_skipped_) + " skipped)";
  if (frames_published_ == 0) {
    LogError("no frame could be published: " + summary);
    status_.SetState(process_status_t::STATE_ERROR, "no readable frame; " + summary);
  } else {
    LogInfo(summary);
    status_.SetState(process_status_t::STATE_FINISHED, summary);
  }
}

void CameraNode::UpdateStatusValues() {
  status_.SetValue("frames_published", static_cast<double>(frames_published_));
  status_.SetValue("frames_skipped", static_cast<double>(frames_skipped_));
  status_.SetValue("frames_per_pass", source_ ? source_->NumFrames() : -1);
  status_.SetValue("passes", static_cast<double>(passes_));
  status_.SetValue("timestamp_rate_hz", timestamp_rate_);
  status_.SetValue("lockstep_timeouts", static_cast<double>(lockstep_timeouts_));
  status_.SetValue("publish_failures", static_cast<double>(publish_failures_));
  status_.SetValue("odometry_published", static_cast<double>(next_odometry_));
  status_.SetValue("frames_without_odometry", static_cast<double>(frames_without_odometry_));
}

void CameraNode::Tick(int64_t wall_utime) {
  if (!started_) {
    started_ = true;
    schedule_start_wall_ = wall_utime;
    status_.SetState(process_status_t::STATE_RUNNING, source_->Describe());
  }
  const bool was_sent = end_of_stream_sent_;
  const int max_frames = source_->IsLive() ? 1 : kMaxFramesPerTick;
  for (int published = 0; !end_of_stream_sent_ && published < max_frames;) {
    if (!LockstepReady(wall_utime) || !FrameDue(wall_utime)) break;
    if (!PublishNextFrame(wall_utime)) break;
    ++published;
  }
  UpdateStatusValues();
  status_.PublishIfDue(wall_utime, end_of_stream_sent_ && !was_sent);
}

void CameraNode::OnShutdown() {
  if (!end_of_stream_sent_) {
    LogInfo("stopping before the end of the source");
    FinishStream();
  }
  UpdateStatusValues();
}

}  // namespace objscan
