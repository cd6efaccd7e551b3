// The camera / dataset driver node (process "camera"): reads frames from a FrameSource and publishes, per frame and
// in this order, CAMERA_INFO (camera_info_t, the frame's calibration), CAMERA_IMAGE (image_t) and, when the source
// has true poses, GROUND_TRUTH_POSE (pose_t world_from_camera in mm, STATUS_GROUND_TRUTH, evaluation only). After
// the last frame it publishes control_t COMMAND_END_OF_STREAM (sender "camera", last_seq) on OBJSCAN_CONTROL.
//
// Timing: published frame i (0-based, contiguous over published frames; skipped files do not use a number) has
// seq = i and utime = llround(i * 1e6 / r), r = --rate (30 when --rate is 0; the device's fps for V4L2).
// Frames are published from Tick(wall_utime), which must be called often (main uses a 1 ms tick):
//   --rate R > 0        at most R frames/s of wall time (frame i+1 no earlier than 1/R after frame i);
//   --rate R --realtime on the fixed schedule start + i/R: after a stall (slow decode, lockstep wait) the late
//                       frames follow back to back, so the publication time tracks utime;
//   --rate 0            as fast as the bus takes it (at most kMaxFramesPerTick per Tick);
//   V4L2 devices        at the device's pace (reading blocks until the next frame).
//   --lockstep-channel  frame i+1 (and the end of stream) is published only once a message with seq >= i has
//                       arrived on that channel (seq = bytes 16..23, big-endian, of the raw LCM message: the field
//                       after utime in image_t / feature_tracks_t / pose_t); after --lockstep-timeout-ms it goes on
//                       anyway (counted in lockstep_timeouts; 0 = wait forever).
// A recorded robot run (an image folder with timestamps.txt, odometry.txt and robot.cfg, or a video folder with
// odometry.txt, robot.cfg and optionally timestamps.txt, else the video container's times; common/recorded_run.h):
// frame utimes are the recorded ones, and before each frame's CAMERA_INFO the odometry readings up to its time
// plus the first one after it are published on ROBOT_ODOMETRY (odometry_t, head angles turned into objscan's
// convention by robot.cfg), so a receiver can interpolate at the frame time as it does live; the rest follow the
// last frame, before END_OF_STREAM. odometry.txt without robot.cfg (or an image folder's timestamps.txt), or with
// --order / --loop, is a start-up error (--odometry=false plays the images alone). Frames with no reading within 0.5 s are counted.
// Bad frames (unreadable or odd-sized files) are logged with their name, counted as rejected in PROCESS_STATUS and
// skipped. The node never throws after construction. Determinism: the published messages depend only on the source
// and the options (not on timing), except PROCESS_STATUS.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/node.h"
#include "common/sensor_data.h"
#include "common/status.h"
#include "drivers/camera/frame_source.h"

namespace objscan {

class Bus;
class OptionParser;

struct CameraNodeOptions {
  std::string source;                  // --source: image folder, Middlebury folder / *_par.txt, video, /dev/videoN
  std::string calib;                   // --calib: calibration file (required for video and V4L2; overrides)
  double rate_hz = 30;                 // Hz, timestamp rate and publication pace; 0 = as fast as possible
  bool realtime = false;               // pace on the fixed wall-clock schedule start + i/rate (catch up when late)
  bool loop = false;                   // start again at the first frame at the end (seq keeps counting)
  std::string order;                   // explicit frame order: 1-based natural positions, ranges a-b, file names
  std::string rotate_180;              // frames (natural positions / names, or "all") to rotate 180 deg in-plane
  std::string encoding = "rgb8";       // image encoding: rgb8, bgr8, gray8 or jpeg
  int jpeg_quality = 90;               // 1..100, for --encoding jpeg
  int64_t max_frames = 0;              // stop after this many published frames (0 = all)
  std::string session_id;              // the session's id stamped on image/info/odometry (hex; "" = a random one)
  std::string lockstep_channel;        // wait for seq >= i on this channel before publishing frame i+1 ("" = off)
  int lockstep_timeout_ms = 5000;      // ms, give up waiting for a lockstep message after this (0 = forever)
  double gt_position_scale = 1000;     // ground-truth positions (TUM, Middlebury) times this = mm (m -> mm)
  bool publish_ground_truth = true;    // publish GROUND_TRUTH_POSE when the source has true poses
  std::string camera_name = "camera";  // camera_name in image_t / camera_info_t
  std::string device_size;             // "WxH" px, V4L2 capture size to request ("" = the calibration's size)
  std::string image_channel = "CAMERA_IMAGE";              // output channel of image_t
  std::string info_channel = "CAMERA_INFO";                // output channel of camera_info_t
  std::string ground_truth_channel = "GROUND_TRUTH_POSE";  // output channel of the true poses
  std::string control_channel = "OBJSCAN_CONTROL";         // output channel of END_OF_STREAM
  std::string status_channel = "PROCESS_STATUS";           // output channel of process_status_t
  bool odometry = true;  // an image or video folder's odometry.txt (with robot.cfg, timestamps.txt) is published
  std::string odometry_channel = "ROBOT_ODOMETRY";         // output channel of odometry_t
  bool exit_when_finished = true;  // Finished() turns true after END_OF_STREAM (the process exits)
};

// Registers the options a user sets on the command line (names as in the comments: --source, --rate, ...); the rest
// (gt_position_scale, publish_ground_truth, camera_name) keep their defaults, code and tests set the fields directly.
void AddCameraNodeOptions(OptionParser& parser, CameraNodeOptions* options);
// Parses a device size "WxH" (positive px, e.g. "640x480") into *width, *height; "" gives 0 x 0 (the calibration's
// size). False for anything else.
bool ParseDeviceSize(const std::string& text, int* width, int* height);
// Checks the option values (not the source itself). Returns false with *why on the first problem.
bool ValidateCameraNodeOptions(const CameraNodeOptions& options, std::string* why);

class CameraNode : public Node {
 public:
  static constexpr const char* kProcessName = "camera";
  static constexpr int kMaxFramesPerTick = 8;

  // Validates the options and opens the source. Throws std::invalid_argument on invalid options and
  // std::runtime_error when the source cannot be opened (missing / invalid calibration, empty folder, bad list).
  CameraNode(Bus& bus, const CameraNodeOptions& options);
  ~CameraNode() override;

  // Publishes the frames that are due (see the header comment) and the status (1 Hz). wall_utime in µs.
  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return end_of_stream_sent_ && options_.exit_when_finished; }
  // Publishes END_OF_STREAM if it was not sent yet (stop signal mid-stream), so downstream nodes can finish.
  void OnShutdown() override;

  int64_t frames_published() const { return frames_published_; }
  int64_t frames_skipped() const { return frames_skipped_; }
  int64_t lockstep_timeouts() const { return lockstep_timeouts_; }
  bool end_of_stream_sent() const { return end_of_stream_sent_; }
  // Hz used for utime (see the header comment).
  double timestamp_rate() const { return timestamp_rate_; }
  const StatusReporter& status() const { return status_; }
  const FrameSource& source() const { return *source_; }
  // Tick period main should run the loop with (ms).
  int SuggestedTickMs() const { return source_->IsLive() ? 5 : 1; }

 private:
  bool LockstepReady(int64_t wall_utime);
  bool FrameDue(int64_t wall_utime) const;
  // Reads (skipping bad frames) and publishes the next frame; at the end sends END_OF_STREAM (or rewinds with
  // --loop). Returns true when a frame was published.
  bool PublishNextFrame(int64_t wall_utime);
  // Loads odometry.txt and robot.cfg of a recorded run (see the header comment); throws std::runtime_error.
  void LoadRecordedOdometry();
  // Publishes the odometry readings up to utime and the first one after it (all when utime is INT64_MAX).
  void PublishOdometryUpTo(int64_t utime);
  void FinishStream();
  template <class Msg>
  void Publish(const std::string& channel, Msg msg);  // stamped with session_id_ (StampSession)
  void UpdateStatusValues();

  Bus& bus_;
  CameraNodeOptions options_;
  int8_t encoding_ = 1;
  std::unique_ptr<FrameSource> source_;
  StatusReporter status_;
  double timestamp_rate_ = 30;

  bool started_ = false;
  int64_t schedule_start_wall_ = 0;  // µs, wall time of the first Tick (realtime schedule origin)
  int64_t last_publish_wall_ = 0;    // µs, wall time frame (frames_published_ - 1) was published
  int64_t frames_published_ = 0;     // = seq of the next frame
  int64_t frames_published_in_pass_ = 0;
  int64_t frames_skipped_ = 0;
  int64_t passes_ = 1;
  int64_t last_utime_ = 0;
  bool end_of_stream_sent_ = false;
  int64_t publish_failures_ = 0;
  int64_t session_id_ = 0;  // stamped on what Publish sends

  std::vector<OdometryReading> odometry_;  // recorded odometry in objscan's convention (empty: none)
  size_t next_odometry_ = 0;               // index of the next reading to publish
  int64_t frames_without_odometry_ = 0;    // frames with no reading within 0.5 s

  int64_t lockstep_max_seq_ = -1;       // highest seq seen on the lockstep channel
  int64_t lockstep_waiting_for_ = -1;   // seq we are waiting for (-1 = not waiting)
  int64_t lockstep_wait_start_ = 0;     // µs, wall time the wait began
  int64_t lockstep_released_seq_ = -1;  // seq released by a timeout
  int64_t lockstep_timeouts_ = 0;
};

}  // namespace objscan
