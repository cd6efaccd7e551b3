// ViewerState: everything the viewer shows, as plain data, fed message by message through MessageDispatcher.
// No bus, no GL, no LCM runtime (only the header-only generated message structs as data containers): the live
// bus, the log player and the unit tests all feed the same Dispatch() call.
//
// MessageDispatcher decodes each message by its channel name (ViewerChannels, configurable) and hands the decoded
// struct to ViewerState. A message on an unconfigured channel is counted as unknown; one that does not decode as
// its channel's type, or decodes but fails validation (non-finite numbers, bad sizes, adapters.h reasons), is
// counted as malformed under a reason. Neither ever throws or changes the state of that channel.
//
// Times: recv_utime is the time the message arrived (µs; log event time when reading a log, wall clock live);
// "now" passed to the rate/age queries must use the same clock. Data times are the messages' own utime fields.
// Not thread-safe: feed and read from one thread.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/geometry.h"

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "objscan/control_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/model_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"

namespace objscan {

// Channel names the viewer decodes ("" disables one).
struct ViewerChannels {
  std::string camera_pose = "CAMERA_POSE";         // estimated camera poses (pose_t)
  std::string ground_truth = "GROUND_TRUTH_POSE";  // true camera poses (pose_t)
  std::string landmarks = "LANDMARKS";             // sparse map (landmarks_t)
  std::string voxel_map = "VOXEL_MAP";             // dense model (voxel_map_t)
  std::string target = "TARGET";                   // object estimate (target_t)
  std::string odometry = "ROBOT_ODOMETRY";         // robot odometry (odometry_t)
  std::string image = "CAMERA_IMAGE";              // camera frames (image_t)
  std::string camera_info = "CAMERA_INFO";         // calibration (camera_info_t)
  std::string tracks = "FEATURE_TRACKS";           // feature tracks (feature_tracks_t)
  std::string status = "PROCESS_STATUS";           // process status (process_status_t)
  std::string control = "OBJSCAN_CONTROL";         // session events (control_t)
  std::string model = "MODEL";                     // final model written (model_t)
};

// Per-channel traffic figures for the channel table.
struct ChannelStats {
  std::string type;                       // decoded type ("pose_t", ...) or "unknown"
  int64_t messages = 0;                   // all messages received on the channel
  int64_t malformed = 0;                  // messages that did not decode or failed validation
  int64_t dropped = 0;                    // messages missing according to sequence gaps (streams with +1 seq only)
  int64_t bytes = 0;                      // payload bytes received
  int64_t last_recv_utime = 0;            // µs, arrival of the newest message
  std::deque<int64_t> recent_recv_utime;  // µs, arrivals inside the rate window
};

struct TrajectoryPoint {
  int64_t utime = 0;                                                    // µs, data time
  int64_t seq = 0;                                                      // frame seq
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  int8_t status = 0;                                                    // pose_t::STATUS_*
};

struct ProcessStatusEntry {
  process_status_t status;  // the newest status message of the process
  int64_t recv_utime = 0;   // µs, its arrival
};

struct ViewerStateOptions {
  size_t max_trajectory_points = 200000;  // oldest poses are forgotten beyond this (per trajectory)
  size_t max_track_frames = 64;           // track frames kept to match the displayed image by seq
  double rate_window_s = 2.0;             // s, window of the message rate estimate (> 0)
  bool align_truth = true;                // map the truth into the estimate's frame (Sim(3) fit) for errors/drawing
  size_t max_alignment_frames = 2000;     // newest frames with both poses used for the fit and the error RMS
};

class ViewerState {
 public:
  explicit ViewerState(const ViewerStateOptions& options = {});

  // Forgets all data and counters (used when a log is rewound).
  void Reset();

  // --- Inputs (called by MessageDispatcher after decoding and validation). ---
  void AddEstimatedPose(const CameraPoseEstimate& pose);
  void AddGroundTruthPose(const CameraPoseEstimate& pose);
  void SetLandmarks(const landmarks_t& msg);
  void SetVoxelMap(const voxel_map_t& msg);
  void SetTarget(const target_t& msg);
  void SetOdometry(const OdometryReading& reading);
  void SetImage(const ImageFrame& frame);
  void SetCameraInfo(const PinholeCamera& camera);
  void AddTracks(const TrackFrame& frame);
  void SetProcessStatus(const process_status_t& msg, int64_t recv_utime);
  void SetControl(const control_t& msg);
  void SetModel(const model_t& msg);
  // Traffic accounting (the dispatcher calls these for every message).
  ChannelStats& Channel(const std::string& channel);
  void CountMessage(const std::string& channel, const std::string& type, int size, int64_t recv_utime);
  void CountMalformed(const std::string& channel, const std::string& reason);
  void CountUnknown(const std::string& channel, int size, int64_t recv_utime);
  // Counts a gap in a +1 sequence stream (key = channel, or channel/sender for per-sender streams).
  void ObserveSeq(const std::string& channel, const std::string& key, int64_t seq);

  // --- Outputs. ---
  const std::map<int64_t, TrajectoryPoint>& estimated_trajectory() const { return estimated_; }        // by seq
  const std::map<int64_t, TrajectoryPoint>& ground_truth_trajectory() const { return ground_truth_; }  // by seq
  // The estimate's world frame is its own (e.g. the odometry frame at the first image), not the truth's: once >= 3
  // frames have both, the truth is mapped into the estimate's frame by the least-squares similarity (Umeyama) over
  // the newest such frames (options), recomputed as poses arrive; identity before or with align_truth off. Errors below
  // and the drawn truth use it.
  const Sim3& estimate_from_truth() const { return estimate_from_truth_; }
  bool truth_aligned() const { return truth_aligned_; }
  // Position error (mm) between the estimate and the (aligned) truth of the newest frame that has both; nullopt
  // before.
  std::optional<double> latest_position_error_mm() const { return latest_error_mm_; }
  int64_t latest_error_seq() const { return latest_error_seq_; }
  // RMS of the position error over the newest frames with both (mm, after the alignment above), and how many.
  double position_error_rms_mm() const;
  int64_t position_error_count() const { return error_count_; }

  const std::optional<landmarks_t>& landmarks() const { return landmarks_; }
  // Keyframe seq at which a landmark id was first listed (for colouring by age); -1 if unknown.
  int64_t LandmarkFirstSeq(int64_t id) const;
  const std::optional<voxel_map_t>& voxel_map() const { return voxel_map_; }
  int64_t voxel_map_version() const { return voxel_map_version_; }  // +1 per accepted voxel map
  const std::optional<target_t>& target() const { return target_; }
  const std::optional<OdometryReading>& odometry() const { return odometry_; }
  const std::optional<ImageFrame>& image() const { return image_; }
  int64_t image_version() const { return image_version_; }  // +1 per accepted image
  const std::optional<PinholeCamera>& camera() const { return camera_; }
  // Tracks of the frame with this seq if kept, else the newest tracks (nullptr before any).
  const TrackFrame* TracksFor(int64_t seq) const;
  const std::map<std::string, ProcessStatusEntry>& processes() const { return processes_; }
  const std::optional<control_t>& last_control() const { return control_; }
  const std::optional<model_t>& model() const { return model_; }

  const std::map<std::string, ChannelStats>& channels() const { return channels_; }
  // Messages per second on a channel over the rate window ending at now_utime.
  double ChannelRate(const std::string& channel, int64_t now_utime) const;
  int64_t total_messages() const { return total_messages_; }
  int64_t total_malformed() const { return total_malformed_; }
  int64_t total_unknown() const { return total_unknown_; }
  const std::map<std::string, int64_t>& malformed_reasons() const { return malformed_reasons_; }
  // Newest data time (µs) seen in any decoded message, 0 before.
  int64_t latest_data_utime() const { return latest_data_utime_; }
  void NoteDataUtime(int64_t utime);

 private:
  void UpdateError(int64_t seq);

  ViewerStateOptions options_;
  std::map<int64_t, TrajectoryPoint> estimated_;
  std::map<int64_t, TrajectoryPoint> ground_truth_;
  std::optional<double> latest_error_mm_;
  int64_t latest_error_seq_ = -1;
  Sim3 estimate_from_truth_;
  bool truth_aligned_ = false;
  double error_sum_sq_ = 0;
  int64_t error_count_ = 0;
  std::optional<landmarks_t> landmarks_;
  std::map<int64_t, int64_t> landmark_first_seq_;
  std::optional<voxel_map_t> voxel_map_;
  int64_t voxel_map_version_ = 0;
  std::optional<target_t> target_;
  std::optional<OdometryReading> odometry_;
  std::optional<ImageFrame> image_;
  int64_t image_version_ = 0;
  std::optional<PinholeCamera> camera_;
  std::deque<TrackFrame> tracks_;
  std::map<std::string, ProcessStatusEntry> processes_;
  std::optional<control_t> control_;
  std::optional<model_t> model_;
  std::map<std::string, ChannelStats> channels_;
  std::map<std::string, int64_t> last_seq_;
  std::map<std::string, int64_t> malformed_reasons_;
  int64_t total_messages_ = 0;
  int64_t total_malformed_ = 0;
  int64_t total_unknown_ = 0;
  int64_t latest_data_utime_ = 0;
};

// Decodes messages by channel name into a ViewerState. Never throws.
class MessageDispatcher {
 public:
  MessageDispatcher(ViewerState* state, ViewerChannels channels);

  // Decodes and applies one message (data valid only during the call). Returns true when it was decoded and
  // accepted, false when it was unknown or malformed (and counted as such).
  bool Dispatch(const std::string& channel, const void* data, int size, int64_t recv_utime);

  const ViewerChannels& channels() const { return channels_; }

  // Fast-forward mode (seeking, headless catch-up): image messages are counted but only the newest is kept, as
  // bytes, and decoded by EndFastForward() (image seq gaps are not counted meanwhile). Everything else is handled
  // as usual.
  void BeginFastForward() { fast_forward_ = true; }
  void EndFastForward();

  // Reason of the last message rejected as malformed ("pose: malformed", adapters.h reasons, ...).
  const std::string& last_error() const { return last_error_; }

 private:
  bool DispatchImage(const std::string& channel, const void* data, int size);

  ViewerState* state_;
  std::string last_error_;
  bool fast_forward_ = false;
  std::string deferred_image_channel_;
  std::vector<uint8_t> deferred_image_;
  ViewerChannels channels_;
};

}  // namespace objscan
