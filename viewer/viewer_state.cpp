#include "viewer/viewer_state.h"

#include <cmath>
#include <exception>
#include <type_traits>

#include "common/adapters.h"
#include "common/message_size_check.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"

namespace objscan {
namespace {

bool Finite(const double* values, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

template <class Map>
void TrimOldest(Map* map, size_t max_size) {
  while (map->size() > max_size) map->erase(map->begin());
}

// Decodes msg from bytes through the one guarded decode (common/message_size_check.h): false on a wrong fingerprint,
// truncation, trailing bytes, counts that cannot fit the payload, or an exception from the generated decoder.
template <class Msg>
bool Decode(const void* data, int size, Msg* msg) {
  return DecodeMessage(data, size, msg, nullptr);
}

}  // namespace

ViewerState::ViewerState(const ViewerStateOptions& options) : options_(options) {}

void ViewerState::Reset() { *this = ViewerState(options_); }

void ViewerState::NoteDataUtime(int64_t utime) { latest_data_utime_ = std::max(latest_data_utime_, utime); }

void ViewerState::AddEstimatedPose(const CameraPoseEstimate& pose) {
  estimated_[pose.seq] = {pose.utime, pose.seq, pose.world_from_camera, static_cast<int8_t>(pose.status)};
  TrimOldest(&estimated_, options_.max_trajectory_points);
  UpdateError(pose.seq);
}

void ViewerState::AddGroundTruthPose(const CameraPoseEstimate& pose) {
  ground_truth_[pose.seq] = {pose.utime, pose.seq, pose.world_from_camera, static_cast<int8_t>(pose.status)};
  TrimOldest(&ground_truth_, options_.max_trajectory_points);
  UpdateError(pose.seq);
}

void ViewerState::UpdateError(int64_t seq) {
  if (estimated_.find(seq) == estimated_.end() || ground_truth_.find(seq) == ground_truth_.end()) return;
  // Frames with both, then the alignment over all of them, then every error again (a few hundred frames: cheap).
  std::vector<Eigen::Vector3d> truth_points, estimate_points;
  std::vector<int64_t> seqs;
  for (auto it = estimated_.rbegin(); it != estimated_.rend() && seqs.size() < options_.max_alignment_frames; ++it) {
    const auto gt = ground_truth_.find(it->first);
    if (gt == ground_truth_.end()) continue;
    seqs.insert(seqs.begin(), it->first);
    estimate_points.insert(estimate_points.begin(), it->second.world_from_camera.translation());
    truth_points.insert(truth_points.begin(), gt->second.world_from_camera.translation());
  }
  Sim3 alignment;
  truth_aligned_ =
      options_.align_truth && seqs.size() >= 3 && AlignUmeyama(truth_points, estimate_points, true, &alignment);
  estimate_from_truth_ = truth_aligned_ ? alignment : Sim3();
  error_sum_sq_ = 0;
  error_count_ = 0;
  for (size_t i = 0; i < seqs.size(); ++i) {
    const double error = (estimate_points[i] - estimate_from_truth_ * truth_points[i]).norm();
    error_sum_sq_ += error * error;
    ++error_count_;
    if (i + 1 == seqs.size()) {  // seqs ascend: the newest frame with both
      latest_error_seq_ = seqs[i];
      latest_error_mm_ = error;
    }
  }
}

double ViewerState::position_error_rms_mm() const {
  return error_count_ > 0 ? std::sqrt(std::max(0.0, error_sum_sq_) / error_count_) : 0.0;
}

void ViewerState::SetLandmarks(const landmarks_t& msg) {
  for (int64_t id : msg.id) landmark_first_seq_.emplace(id, msg.seq);
  landmarks_ = msg;
}

int64_t ViewerState::LandmarkFirstSeq(int64_t id) const {
  const auto it = landmark_first_seq_.find(id);
  return it == landmark_first_seq_.end() ? -1 : it->second;
}

void ViewerState::SetVoxelMap(const voxel_map_t& msg) {
  voxel_map_ = msg;
  ++voxel_map_version_;
}

void ViewerState::SetTarget(const target_t& msg) { target_ = msg; }
void ViewerState::SetOdometry(const OdometryReading& reading) { odometry_ = reading; }

void ViewerState::SetImage(const ImageFrame& frame) {
  image_ = frame;
  ++image_version_;
}

void ViewerState::SetCameraInfo(const PinholeCamera& camera) { camera_ = camera; }

void ViewerState::AddTracks(const TrackFrame& frame) {
  tracks_.push_back(frame);
  while (tracks_.size() > std::max<size_t>(options_.max_track_frames, 1)) tracks_.pop_front();
}

const TrackFrame* ViewerState::TracksFor(int64_t seq) const {
  for (auto it = tracks_.rbegin(); it != tracks_.rend(); ++it)
    if (it->seq == seq) return &*it;
  return tracks_.empty() ? nullptr : &tracks_.back();
}

void ViewerState::SetProcessStatus(const process_status_t& msg, int64_t recv_utime) {
  ProcessStatusEntry& entry = processes_[msg.name];
  entry.status = msg;
  entry.recv_utime = recv_utime;
}

void ViewerState::SetControl(const control_t& msg) { control_ = msg; }
void ViewerState::SetModel(const model_t& msg) { model_ = msg; }

ChannelStats& ViewerState::Channel(const std::string& channel) { return channels_[channel]; }

void ViewerState::CountMessage(const std::string& channel, const std::string& type, int size, int64_t recv_utime) {
  ChannelStats& stats = channels_[channel];
  stats.type = type;
  ++stats.messages;
  stats.bytes += std::max(size, 0);
  stats.last_recv_utime = recv_utime;
  stats.recent_recv_utime.push_back(recv_utime);
  const int64_t window_us = static_cast<int64_t>(options_.rate_window_s * 1e6);
  while (!stats.recent_recv_utime.empty() && stats.recent_recv_utime.front() < recv_utime - window_us)
    stats.recent_recv_utime.pop_front();
  ++total_messages_;
}

void ViewerState::CountMalformed(const std::string& channel, const std::string& reason) {
  ++channels_[channel].malformed;
  ++malformed_reasons_[reason];
  ++total_malformed_;
}

void ViewerState::CountUnknown(const std::string& channel, int size, int64_t recv_utime) {
  CountMessage(channel, "unknown", size, recv_utime);
  ++total_unknown_;
}

void ViewerState::ObserveSeq(const std::string& channel, const std::string& key, int64_t seq) {
  const auto it = last_seq_.find(key);
  if (it == last_seq_.end()) {
    last_seq_[key] = seq;
    return;
  }
  if (seq > it->second) {
    const int64_t missing = seq - it->second - 1;
    channels_[channel].dropped += missing;
    it->second = seq;
  }
}

double ViewerState::ChannelRate(const std::string& channel, int64_t now_utime) const {
  const auto it = channels_.find(channel);
  if (it == channels_.end() || options_.rate_window_s <= 0) return 0.0;
  const int64_t window_us = static_cast<int64_t>(options_.rate_window_s * 1e6);
  int64_t count = 0;
  for (int64_t t : it->second.recent_recv_utime)
    if (t >= now_utime - window_us && t <= now_utime) ++count;
  return count / options_.rate_window_s;
}

bool MessageDispatcher::DispatchImage(const std::string& channel, const void* data, int size) {
  image_t msg;
  std::string error = "image: malformed";
  ImageFrame frame;
  if (!Decode(data, size, &msg) || !ImageFromMessage(msg, &frame, &error)) {
    state_->CountMalformed(channel, error);
    last_error_ = error;
    return false;
  }
  state_->ObserveSeq(channel, channel, msg.seq);
  state_->NoteDataUtime(msg.utime);
  state_->SetImage(frame);
  return true;
}

void MessageDispatcher::EndFastForward() {
  fast_forward_ = false;
  if (deferred_image_.empty()) return;
  DispatchImage(deferred_image_channel_, deferred_image_.data(), static_cast<int>(deferred_image_.size()));
  deferred_image_.clear();
}

MessageDispatcher::MessageDispatcher(ViewerState* state, ViewerChannels channels)
    : state_(state), channels_(std::move(channels)) {}

bool MessageDispatcher::Dispatch(const std::string& channel, const void* data, int size, int64_t recv_utime) {
  ViewerState& s = *state_;
  const ViewerChannels& c = channels_;
  std::string error;
  auto malformed = [&](const std::string& reason) {
    s.CountMalformed(channel, reason);
    last_error_ = reason;
    return false;
  };
  auto is = [&](const std::string& name) { return !name.empty() && channel == name; };

  if (is(c.camera_pose) || is(c.ground_truth)) {
    const bool truth = is(c.ground_truth);
    s.CountMessage(channel, "pose_t", size, recv_utime);
    pose_t msg;
    if (!Decode(data, size, &msg)) return malformed("pose: malformed");
    CameraPoseEstimate pose;
    if (!PoseFromMessage(msg, &pose, &error)) return malformed(error);
    s.ObserveSeq(channel, channel, msg.seq);
    s.NoteDataUtime(msg.utime);
    if (truth)
      s.AddGroundTruthPose(pose);
    else
      s.AddEstimatedPose(pose);
    return true;
  }
  if (is(c.landmarks)) {
    s.CountMessage(channel, "landmarks_t", size, recv_utime);
    landmarks_t msg;
    if (!Decode(data, size, &msg)) return malformed("landmarks: malformed");
    if (msg.num_landmarks < 0) return malformed("landmarks: bad count");
    for (const auto& p : msg.position_mm)
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        return malformed("landmarks: non-finite position");
    for (float e : msg.reprojection_error_px)
      if (!std::isfinite(e)) return malformed("landmarks: non-finite error");
    s.NoteDataUtime(msg.utime);
    s.SetLandmarks(msg);
    return true;
  }
  if (is(c.voxel_map)) {
    s.CountMessage(channel, "voxel_map_t", size, recv_utime);
    voxel_map_t msg;
    if (!Decode(data, size, &msg)) return malformed("voxel_map: malformed");
    if (!std::isfinite(msg.voxel_size_mm) || msg.voxel_size_mm <= 0) return malformed("voxel_map: bad voxel size");
    if (!Finite(msg.origin_mm, 3)) return malformed("voxel_map: non-finite origin");
    if (msg.num_voxels < 0) return malformed("voxel_map: bad count");
    s.NoteDataUtime(msg.utime);
    s.SetVoxelMap(msg);
    return true;
  }
  if (is(c.target)) {
    s.CountMessage(channel, "target_t", size, recv_utime);
    target_t msg;
    if (!Decode(data, size, &msg)) return malformed("target: malformed");
    if (!Finite(msg.center_mm, 3) || !Finite(msg.size_mm, 3) || !std::isfinite(msg.yaw_rad) ||
        !std::isfinite(msg.confidence))
      return malformed("target: non-finite value");
    if (msg.size_mm[0] < 0 || msg.size_mm[1] < 0 || msg.size_mm[2] < 0) return malformed("target: negative size");
    s.NoteDataUtime(msg.utime);
    s.SetTarget(msg);
    return true;
  }
  if (is(c.odometry)) {
    s.CountMessage(channel, "odometry_t", size, recv_utime);
    odometry_t msg;
    if (!Decode(data, size, &msg)) return malformed("odometry: malformed");
    OdometryReading reading;
    if (!OdometryFromMessage(msg, &reading, &error)) return malformed(error);
    s.ObserveSeq(channel, channel, msg.seq);
    s.NoteDataUtime(msg.utime);
    s.SetOdometry(reading);
    return true;
  }
  if (is(c.image)) {
    s.CountMessage(channel, "image_t", size, recv_utime);
    if (fast_forward_ && data != nullptr && size > 0) {
      deferred_image_channel_ = channel;
      const auto* bytes = static_cast<const uint8_t*>(data);
      deferred_image_.assign(bytes, bytes + size);
      return true;
    }
    return DispatchImage(channel, data, size);
  }
  if (is(c.camera_info)) {
    s.CountMessage(channel, "camera_info_t", size, recv_utime);
    camera_info_t msg;
    if (!Decode(data, size, &msg)) return malformed("camera_info: malformed");
    PinholeCamera camera;
    if (!CameraFromMessage(msg, &camera, &error)) return malformed(error);
    s.SetCameraInfo(camera);
    return true;
  }
  if (is(c.tracks)) {
    s.CountMessage(channel, "feature_tracks_t", size, recv_utime);
    feature_tracks_t msg;
    if (!Decode(data, size, &msg)) return malformed("tracks: malformed");
    TrackFrame frame;
    if (!TracksFromMessage(msg, &frame, &error)) return malformed(error);
    s.ObserveSeq(channel, channel, msg.seq);
    s.NoteDataUtime(msg.utime);
    s.AddTracks(frame);
    return true;
  }
  if (is(c.status)) {
    s.CountMessage(channel, "process_status_t", size, recv_utime);
    process_status_t msg;
    if (!Decode(data, size, &msg)) return malformed("status: malformed");
    if (msg.name.empty()) return malformed("status: empty name");
    s.ObserveSeq(channel, channel + "/" + msg.name, msg.seq);
    s.SetProcessStatus(msg, recv_utime);
    return true;
  }
  if (is(c.control)) {
    s.CountMessage(channel, "control_t", size, recv_utime);
    control_t msg;
    if (!Decode(data, size, &msg)) return malformed("control: malformed");
    s.SetControl(msg);
    return true;
  }
  if (is(c.model)) {
    s.CountMessage(channel, "model_t", size, recv_utime);
    model_t msg;
    if (!Decode(data, size, &msg)) return malformed("model: malformed");
    s.SetModel(msg);
    return true;
  }
  s.CountUnknown(channel, size, recv_utime);
  return false;
}

}  // namespace objscan
