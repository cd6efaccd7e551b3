#include "processes/object_finder/object_finder_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/geometry.h"
#include "common/json_writer.h"
#include "common/log.h"
#include "common/options.h"
#include "common/ply.h"
#include "common/robot_model.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"

namespace objscan {

namespace {

constexpr size_t kPoseHistory = 64;  // camera poses kept to find a keyframe's pose by seq

const ObjectFinderNodeOptions& ValidatedOrThrow(const ObjectFinderNodeOptions& o) {
  std::string why;
  if (!ValidateObjectFinderNodeOptions(o, &why)) throw std::invalid_argument("object finder node: " + why);
  return o;
}

std::string Format(const char* format, double a, double b = 0, double c = 0, double d = 0, double e = 0, double f = 0) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), format, a, b, c, d, e, f);
  return buffer;
}

// "at (x, y) mm, 150x120x140 mm"
std::string Describe(const TargetBox& box) {
  return Format("at (%.0f, %.0f) mm, %.0fx%.0fx%.0f mm", box.centre_mm.x(), box.centre_mm.y(), box.size_mm.x(),
                box.size_mm.y(), box.size_mm.z());
}

std::string Views(int views) { return std::to_string(views) + (views == 1 ? " view" : " views"); }

std::string JsonVector(const Eigen::Vector3d& v, const char* format) {
  return "[" + Format(format, v.x()) + ", " + Format(format, v.y()) + ", " + Format(format, v.z()) + "]";
}


}  // namespace

void AddObjectFinderNodeOptions(OptionParser& p, ObjectFinderNodeOptions* o) {
  // Only what a user sets (issue 27): plumbing and channels (with the final poses and the model that measures
  // target.json) and the target's size range. Every other field keeps its default here (the TARGET and status
  // periods, the clustering distance and the views to confirm among them); tests and tools set the struct directly.
  p.Add("name", &o->name, "process name (status name, sender of control messages)");
  p.AddChannel(&o->landmarks_channel, "input sparse map channel (landmarks_t)");
  p.AddChannel(&o->pose_channel, "input camera pose channel (pose_t)");
  p.AddChannel(&o->info_channel, "input camera_info_t channel");
  p.AddChannel(&o->odometry_channel, "input odometry_t channel (\"\" = none)");
  p.AddChannel(&o->target_channel, "output target_t channel");
  p.AddChannel(&o->control_channel, "control_t channel (end of stream in, finished out)");
  p.AddChannel(&o->status_channel, "process_status_t channel");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after answering end of stream");
  p.Add("output-dir", &o->output_dir, "write target.json here at end of stream (\"\" = none)");
  p.AddChannel(&o->final_pose_channel,
        "final poses (pose_t): target.json is re-expressed in their frame (\"\" = keep the online poses' frame)");
  p.AddChannel(&o->model_channel,
        "final model (model_t): target.json's box is measured on its voxels (\"\" = the landmarks' box, no wait)");
  ObjectFinderOptions* f = &o->finder;
  p.Add("target-min-size", &f->target_min_size_mm, "mm, smallest target (largest horizontal extent and height)");
  p.Add("target-max-size", &f->target_max_size_mm, "mm, largest target (largest horizontal extent and height)");
}

bool ValidateObjectFinderNodeOptions(const ObjectFinderNodeOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.name.empty()) e << "name must not be empty; ";
  if (o.landmarks_channel.empty()) e << "landmarks-channel must not be empty; ";
  if (o.pose_channel.empty()) e << "pose-channel must not be empty; ";
  if (o.info_channel.empty()) e << "info-channel must not be empty; ";
  if (o.target_channel.empty()) e << "target-channel must not be empty; ";
  if (o.control_channel.empty()) e << "control-channel must not be empty; ";
  if (o.status_channel.empty()) e << "status-channel must not be empty; ";
  if (!(o.target_period_s > 0.0) || !std::isfinite(o.target_period_s)) e << "target_period_s must be > 0; ";
  if (!(o.status_period_s > 0.0) || !std::isfinite(o.status_period_s)) e << "status_period_s must be > 0; ";
  std::string finder_why;
  if (!ValidateObjectFinderOptions(o.finder, &finder_why)) e << finder_why << "; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

std::string TargetJson(const FinderResult& r, int updates, const BoxSource& source) {
  std::ostringstream j;
  j << "{\n";
  j << "  \"state\": \"" << TargetStateName(r.state) << "\",\n";
  j << "  \"frame\": \"world\",\n";
  j << "  \"centre_mm\": " << JsonVector(r.box.centre_mm, "%.2f") << ",\n";
  j << "  \"size_mm\": " << JsonVector(r.box.size_mm, "%.2f") << ",\n";
  j << "  \"yaw_rad\": " << Format("%.6f", r.box.yaw_rad) << ",\n";
  j << "  \"confidence\": " << Format("%.4f", r.confidence) << ",\n";
  j << "  \"confirmed_seq\": " << r.confirmed_seq << ",\n";
  j << "  \"confirmed_utime\": " << r.confirmed_utime << ",\n";
  j << "  \"views\": " << r.views << ",\n";
  j << "  \"points\": " << r.points << ",\n";
  j << "  \"seq\": " << r.seq << ",\n";
  j << "  \"utime\": " << r.utime << ",\n";
  j << "  \"updates\": " << updates << ",\n";
  j << "  \"other_candidates\": [";
  for (size_t i = 0; i < r.other_candidates.size(); ++i) {
    const CandidateReport& c = r.other_candidates[i];
    j << (i ? ",\n" : "\n") << "    {\"centre_mm\": " << JsonVector(c.box.centre_mm, "%.2f")
      << ", \"size_mm\": " << JsonVector(c.box.size_mm, "%.2f") << ", \"points\": " << c.points << "}";
  }
  j << (r.other_candidates.empty() ? "],\n" : "\n  ],\n");
  j << "  \"floor\": {\"found\": " << (r.floor_valid ? "true" : "false")
    << ", \"normal\": " << JsonVector(r.floor.normal, "%.6f")
    << ", \"offset_mm\": " << Format("%.2f", r.floor.offset_mm) << "},\n";
  j << "  \"box_source\": \"" << (source.from_model ? "model" : "landmarks") << "\"";
  if (source.from_model)
    j << ",\n  \"landmarks_centre_mm\": " << JsonVector(source.landmarks_box.centre_mm, "%.2f")
      << ",\n  \"landmarks_size_mm\": " << JsonVector(source.landmarks_box.size_mm, "%.2f")
      << ",\n  \"model_voxels\": " << source.model_voxels;
  if (!source.model_error.empty()) j << ",\n  \"model_box_error\": " << JsonQuoted(source.model_error);
  j << "\n}\n";
  return j.str();
}

ObjectFinderNode::ObjectFinderNode(Bus& bus, const ObjectFinderNodeOptions& options)
    : bus_(bus),
      options_(ValidatedOrThrow(options)),
      finder_(options_.finder),
      status_(&bus, options_.name, options_.status_channel, options_.status_period_s) {
  status_.SetState(+process_status_t::STATE_STARTING, "waiting for landmarks on " + options_.landmarks_channel);
  bus_.SubscribeMessage<landmarks_t>(
      options_.landmarks_channel, [this](const landmarks_t& m, const RawMessage&) { OnLandmarks(m); },
      status_.MalformedHandler("landmarks"), 5);
  bus_.SubscribeMessage<camera_info_t>(
      options_.info_channel, [this](const camera_info_t& m, const RawMessage&) { OnCameraInfo(m); },
      status_.MalformedHandler("camera_info"), 0);
  bus_.SubscribeMessage<pose_t>(
      options_.pose_channel, [this](const pose_t& m, const RawMessage&) { OnPose(m); },
      status_.MalformedHandler("pose"), 200);
  if (!options_.odometry_channel.empty())
    bus_.SubscribeMessage<odometry_t>(
        options_.odometry_channel, [this](const odometry_t& m, const RawMessage&) { OnOdometry(m); },
        status_.MalformedHandler("odometry"), 200);
  if (!options_.final_pose_channel.empty())  // a burst of one per frame at the end: a deep queue
    bus_.SubscribeMessage<pose_t>(
        options_.final_pose_channel, [this](const pose_t& m, const RawMessage&) { OnFinalPose(m); },
        status_.MalformedHandler("final pose"), 65536);
  if (!options_.model_channel.empty())
    bus_.SubscribeMessage<model_t>(
        options_.model_channel, [this](const model_t& m, const RawMessage&) { OnModel(m); },
        status_.MalformedHandler("model"), 4);
  bus_.SubscribeMessage<control_t>(
      options_.control_channel, [this](const control_t& m, const RawMessage&) { OnControl(m); },
      status_.MalformedHandler("control"));
}

namespace {
constexpr size_t kMaxCentres = 200000;             // camera centres kept per kind (a 1.8 h run at 30 Hz)
constexpr int64_t kFinalPoseWaitUs = 120'000'000;  // wall clock the end waits for the pose solver's final poses
constexpr int64_t kModelWaitUs = 600'000'000;      // wall clock it then waits for the dense model
const char* const kPoseSolverName = "pose_solver";
const char* const kDenseModelerName = "dense_modeler";
}  // namespace

void ObjectFinderNode::OnFinalPose(const pose_t& msg) {
  CameraPoseEstimate pose;
  std::string error;
  if (!PoseFromMessage(msg, &pose, &error)) {
    status_.Reject("final " + error, "seq " + std::to_string(msg.seq));
    return;
  }
  status_.CountIn();
  if (pose.status != PoseStatus::kTracking && pose.status != PoseStatus::kRelocalized) return;
  if (final_centres_.size() < kMaxCentres || final_centres_.count(pose.seq))
    final_centres_[pose.seq] = pose.world_from_camera.translation();
}

void ObjectFinderNode::OnPose(const pose_t& msg) {
  CameraPoseEstimate pose;
  std::string error;
  if (!PoseFromMessage(msg, &pose, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq));
    return;
  }
  if (msg.parent_frame != "world") {
    status_.Reject("pose: not in world frame", "parent frame \"" + msg.parent_frame + "\"");
    return;
  }
  status_.CountIn();
  if (pose.status == PoseStatus::kLost) {  // the last good pose repeated: not where the camera is
    ++lost_poses_;
    return;
  }
  poses_[pose.seq] = pose.world_from_camera;
  while (poses_.size() > kPoseHistory) poses_.erase(poses_.begin());
  if (online_centres_.size() < kMaxCentres || online_centres_.count(pose.seq))
    online_centres_[pose.seq] = pose.world_from_camera.translation();
}

void ObjectFinderNode::OnCameraInfo(const camera_info_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "camera_info")) return;  // another session on the bus
  PinholeCamera camera;
  std::string error;
  if (!CameraFromMessage(msg, &camera, &error)) {
    status_.Reject(error, "camera " + msg.camera_name);
    return;
  }
  if (have_camera_ && !SameCalibration(first_camera_, camera)) {
    status_.Reject("camera_info: changed", "calibration of '" + msg.camera_name + "' differs from the first; ignored");
    return;
  }
  status_.CountIn();
  first_camera_ = camera;
  camera_.width = camera.width;
  camera_.height = camera.height;
  camera_.fx = camera.fx;
  camera_.fy = camera.fy;
  camera_.cx = camera.cx;
  camera_.cy = camera.cy;
  have_camera_ = true;
}

void ObjectFinderNode::OnOdometry(const odometry_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "odometry")) return;  // another session on the bus
  OdometryReading reading;
  std::string error;
  if (!OdometryFromMessage(msg, &reading, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq));
    return;
  }
  status_.CountIn();
  odometry_x_mm_ = reading.x_mm;
  odometry_y_mm_ = reading.y_mm;
  odometry_pan_rad_ = reading.pan_rad;
  have_odometry_ = true;
}

bool ObjectFinderNode::RobotPosition(Eigen::Vector2d* xy_mm) const {
  if (poses_.empty()) {
    if (!have_odometry_) return false;
    *xy_mm = Eigen::Vector2d(odometry_x_mm_, odometry_y_mm_);  // odometry frame = world at the start
    return true;
  }
  // camera centre -> pan/tilt axes -> base (common/robot_model.h, default geometry)
  const RobotGeometry robot;
  const Eigen::Isometry3d& world_from_camera = poses_.rbegin()->second;
  const Eigen::Matrix3d world_from_tilt = world_from_camera.linear() * TiltFromCameraRotation().transpose();
  const Eigen::Vector3d axes = world_from_camera.translation() - world_from_tilt * robot.camera_offset_mm;
  const double heading = std::atan2(world_from_tilt(1, 0), world_from_tilt(0, 0)) - odometry_pan_rad_;
  const Eigen::Vector2d mast(robot.mast_offset_x_mm, robot.mast_offset_y_mm);
  *xy_mm = axes.head<2>() - Eigen::Rotation2Dd(heading) * mast;
  return true;
}

void ObjectFinderNode::OnLandmarks(const landmarks_t& msg) {
  const int64_t start_us = MonotonicMicros();
  const std::string seq = "seq " + std::to_string(msg.seq);
  const size_t n = static_cast<size_t>(msg.num_landmarks);  // >= 0: checked before decoding
  if (msg.id.size() != n || msg.position_mm.size() != n || msg.num_observations.size() != n ||
      msg.reprojection_error_px.size() != n) {
    status_.Reject("landmarks: array length mismatch", seq);
    return;
  }
  std::string reason, detail = seq;
  auto pose = poses_.upper_bound(msg.seq);  // the keyframe's own pose, else the newest before it
  if (msg.frame != "world") {
    reason = "landmarks: not in world frame";
    detail = "frame \"" + msg.frame + "\"";
  } else if (msg.seq < last_landmarks_seq_) {
    reason = "landmarks: out of order";
    detail = seq + " after " + std::to_string(last_landmarks_seq_);
  } else if (!have_camera_) {
    reason = "landmarks: no camera_info";
  } else if (pose == poses_.begin()) {
    reason = "landmarks: no camera pose";
  }
  if (!reason.empty()) {
    status_.Reject(reason, detail);
    return;
  }
  --pose;
  FinderInput input;
  input.utime = msg.utime;
  input.seq = msg.seq;
  input.world_from_camera = pose->second;
  input.camera = camera_;
  input.has_robot_position = RobotPosition(&input.robot_xy_mm);
  input.landmarks.resize(n);
  for (size_t i = 0; i < n; ++i) {
    MapLandmark& l = input.landmarks[i];
    l.id = msg.id[i];
    l.position_mm = Eigen::Vector3d(msg.position_mm[i][0], msg.position_mm[i][1], msg.position_mm[i][2]);
    l.num_observations = msg.num_observations[i];
    l.reprojection_error_px = msg.reprojection_error_px[i];
  }
  std::string error;
  const int64_t update_start_us = MonotonicMicros();
  if (!finder_.Update(input, &error)) {
    status_.Reject("landmarks: finder error", error + ", " + seq);
    return;
  }
  const double update_ms = (MonotonicMicros() - update_start_us) * 1e-3;
  status_.CountIn();
  status_.SetLastDataUtime(msg.utime);
  last_landmarks_seq_ = msg.seq;
  const FinderResult& r = finder_.result();
  LogChanges(r);
  target_.utime = r.utime;
  target_.seq = r.seq;
  target_.state = static_cast<int8_t>(r.state);
  target_.frame = "world";
  for (int k = 0; k < 3; ++k) {
    target_.center_mm[k] = r.box.centre_mm[k];
    target_.size_mm[k] = r.box.size_mm[k];
  }
  target_.yaw_rad = r.box.yaw_rad;
  target_.confidence = r.confidence;
  target_.roi_u = r.roi.u;
  target_.roi_v = r.roi.v;
  target_.roi_width = r.roi.width;
  target_.roi_height = r.roi.height;
  have_target_ = true;
  PublishTarget(WallTimeMicros());
  SetStatusValues(r, update_ms, static_cast<int>(n));
  if (!finished_ && status_.state() != +process_status_t::STATE_RUNNING)
    status_.SetState(+process_status_t::STATE_RUNNING);
  status_.RecordLatencyMs((MonotonicMicros() - start_us) * 1e-3);
}

void ObjectFinderNode::SetStatusValues(const FinderResult& r, double update_ms, int landmarks) {
  status_.SetValue("state", static_cast<double>(r.state));
  status_.SetValue("candidates", r.candidates);
  status_.SetValue("clusters", static_cast<double>(r.clusters.size()));
  status_.SetValue("floor_points", r.floor_points);
  status_.SetValue("update_ms", update_ms);
  status_.SetValue("confirmed_seq", static_cast<double>(r.confirmed_seq));
  status_.SetValue("views", r.views);
  status_.SetValue("landmarks", landmarks);
  status_.SetValue("dropped_landmarks", r.rejected_landmarks);
  status_.SetValue("lost_poses", static_cast<double>(lost_poses_));
}

void ObjectFinderNode::LogChanges(const FinderResult& r) {
  const std::string at = " (keyframe seq " + std::to_string(r.seq) + ")";
  if (r.floor_valid && !logged_floor_) {
    LogInfo(Format("floor found: normal (%.3f, %.3f, %.3f), offset %.1f mm, %.0f landmarks", r.floor.normal.x(),
                   r.floor.normal.y(), r.floor.normal.z(), r.floor.offset_mm, r.floor_points) +
            at);
    logged_floor_ = true;
  }
  if (r.rejected_landmarks > 0 && !logged_dropped_landmarks_) {
    LogWarning(std::to_string(r.rejected_landmarks) + " non-finite landmarks dropped" + at +
               " [later ones are only counted in the status value dropped_landmarks]");
    logged_dropped_landmarks_ = true;
  }
  const bool was_confirmed = logged_state_ == TargetState::kConfirmed || logged_state_ == TargetState::kLost;
  if (r.state != logged_state_ || r.track_id != logged_track_) {
    const std::string box = Describe(r.box);
    switch (r.state) {
      case TargetState::kSearching:
        LogInfo(std::string(was_confirmed ? "confirmed target dropped: " +
                                                (r.drop_reason.empty() ? "rejected by the later views" : r.drop_reason)
                                          : "searching: no candidate") +
                at);
        break;
      case TargetState::kCandidate:
        LogInfo((was_confirmed ? "confirmed target dropped (" + r.drop_reason + "); " : "") + std::string("candidate ") +
                box + ", " +
                std::to_string(r.points) + " points, " + Views(r.views) + at);
        break;
      case TargetState::kConfirmed:
        LogInfo(std::string(logged_state_ == TargetState::kLost && r.track_id == logged_track_ ? "found again "
                                                                                               : "confirmed ") +
                box + Format(", yaw %.1f deg, ", r.box.yaw_rad * 180 / M_PI) + std::to_string(r.points) + " points, " +
                Views(r.views) + at);
        break;
      case TargetState::kLost:
        LogInfo("lost: target " + box + " not seen where it should be" + at);
        break;
    }
    logged_state_ = r.state;
    logged_track_ = r.track_id;
  }
  // While searching, every 20 updates: the biggest clusters of plausible size and why the rule rejects them, so that
  // a run that never finds its target says what the map held (a target seen but "too large" or "not isolated").
  if (r.state == TargetState::kSearching && ++searching_updates_ % 20 == 0) {
    std::vector<const ClusterReport*> rejected;
    for (const auto& c : r.clusters)
      if (!c.passes && std::max(c.box.size_mm.x(), c.box.size_mm.y()) <= 3 * options_.finder.target_max_size_mm)
        rejected.push_back(&c);
    std::sort(rejected.begin(), rejected.end(),
              [](const ClusterReport* a, const ClusterReport* b) { return a->box.points > b->box.points; });
    std::string text = "searching: " + std::to_string(r.clusters.size()) + " clusters above the floor";
    for (size_t i = 0; i < rejected.size() && i < 3; ++i)
      text += std::string(i ? "; " : ", not a target: ") +
              Format("(%.0f, %.0f) mm %.0fx%.0fx%.0f mm %.0f points ", rejected[i]->box.centre_mm.x(),
                     rejected[i]->box.centre_mm.y(), rejected[i]->box.size_mm.x(), rejected[i]->box.size_mm.y(),
                     rejected[i]->box.size_mm.z(), static_cast<double>(rejected[i]->box.points)) +
              rejected[i]->rejection;
    LogInfo(text + at);
  }
  // While a candidate, every 10 updates: what its confirmation still lacks (a run that never confirms its target
  // says why: too few distinct views, a centre still moving, the rule failing now).
  if (r.state == TargetState::kCandidate && ++candidate_updates_ % 10 == 0 && !r.not_confirmed_why.empty())
    LogInfo("candidate " + Describe(r.box) + " not confirmed yet: " + r.not_confirmed_why + at);
  std::vector<int> others;
  for (const auto& c : r.other_candidates) others.push_back(c.track_id);
  if (others != logged_others_ && !others.empty()) {
    std::string text = "other candidates:";
    for (const auto& c : r.other_candidates)
      text += " #" + std::to_string(c.track_id) + " " + Describe(c.box) + " (" + std::to_string(c.points) + " points);";
    LogInfo(text + at);
  }
  logged_others_ = others;
}

void ObjectFinderNode::PublishTarget(int64_t wall_utime) {
  if (!have_target_) return;
  if (bus_.PublishMessage(options_.target_channel, target_))
    status_.CountOut();
  else
    LogWarning("publishing on " + options_.target_channel + " failed");
  target_published_us_ = wall_utime;
}

void ObjectFinderNode::OnControl(const control_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session on the bus
  if (awaiting_final_ && msg.command == control_t::COMMAND_FINISHED && msg.sender == kPoseSolverName) {
    status_.CountIn();
    FinishTarget("the pose solver finished");
    return;
  }
  if (awaiting_model_ && msg.command == control_t::COMMAND_FINISHED && msg.sender == kDenseModelerName) {
    status_.CountIn();  // its MODEL comes first: a FINISHED without one means none is coming
    CompleteTarget("the dense modeler finished without one");
    return;
  }
  const bool finalize = IsFinalizeRequest(msg, options_.name);
  if (!finalize) {
    if (msg.command != control_t::COMMAND_END_OF_STREAM) return;
    if (!msg.target.empty() && msg.target != "*" && msg.target != options_.name) return;
  }
  status_.CountIn();
  if (finished_) return;
  if (awaiting_final_) {  // FINALIZE (or a repeated end of stream) while waiting: end with what there is
    if (finalize) FinishTarget("asked to finalize");
    return;
  }
  if (awaiting_model_) {
    if (finalize) CompleteTarget("asked to finalize");
    return;
  }
  const FinderResult& r = finder_.result();
  end_utime_ = msg.utime;
  LogInfo("end of stream from " + msg.sender + ": " + TargetStateName(r.state) +
          (r.state == TargetState::kSearching ? std::string(", no target found") : " target " + Describe(r.box)) +
          ", " + std::to_string(finder_.updates()) + " maps");
  if (!finalize && r.state != TargetState::kSearching && !options_.final_pose_channel.empty() &&
      !options_.output_dir.empty()) {
    // The online target.json now (a process stopped hard later still leaves it), the final one when the poses come.
    std::error_code ec;
    std::filesystem::create_directories(options_.output_dir, ec);
    std::ofstream(options_.output_dir + "/target.json") << TargetJson(r, finder_.updates());
    awaiting_final_ = true;
    awaiting_since_us_ = WallTimeMicros();
    status_.SetState(+process_status_t::STATE_RUNNING, "waiting for the final poses on " + options_.final_pose_channel);
    return;
  }
  FinishTarget("");
}

void ObjectFinderNode::FinishTarget(const std::string& why) {
  awaiting_final_ = false;
  FinderResult r = finder_.result();
  std::string frame_note;
  if (r.state != TargetState::kSearching && !final_centres_.empty()) {
    // The Sim(3) from the online to the final camera centres over the frames since the confirmation.
    std::vector<Eigen::Vector3d> from, to;
    for (auto it = online_centres_.lower_bound(std::max<int64_t>(0, r.confirmed_seq)); it != online_centres_.end();
         ++it) {
      auto f = final_centres_.find(it->first);
      if (f == final_centres_.end()) continue;
      from.push_back(it->second);
      to.push_back(f->second);
    }
    if (from.size() >= 10) {
      Sim3 sim;
      double rms = std::numeric_limits<double>::infinity();
      const bool aligned = AlignSimilarity(from, to, &sim, &rms);
      const double scale = sim.scale;
      const Eigen::Matrix3d& rotation = sim.rotation;
      const Eigen::Matrix3d sr = scale * rotation;
      const Eigen::Vector3d shift = sim.translation;
      char text[256];
      if (aligned && std::isfinite(scale) && scale > 0 && rms <= 20.0) {
        const Eigen::Vector3d before = r.box.centre_mm;
        const auto apply = [&](TargetBox* box) {
          box->centre_mm = sr * box->centre_mm + shift;
          box->size_mm *= scale;
          box->yaw_rad = std::remainder(box->yaw_rad + std::atan2(rotation(1, 0), rotation(0, 0)), 2 * M_PI);
        };
        apply(&r.box);
        for (CandidateReport& c : r.other_candidates) apply(&c.box);
        if (r.floor_valid) {
          const Eigen::Vector3d n = rotation * r.floor.normal;
          r.floor.offset_mm = scale * r.floor.offset_mm - n.dot(shift);
          r.floor.normal = n;
        }
        std::snprintf(text, sizeof(text),
                      "target.json in the final poses' frame (as trajectory.txt): centre moved %.1f mm (Sim(3) over "
                      "%zu frames since the confirmation, scale %.4f, rms %.2f mm)",
                      (r.box.centre_mm - before).norm(), from.size(), scale, rms);
        LogInfo(text);
      } else {
        std::snprintf(text, sizeof(text),
                      "target.json stays in the online poses' frame: the final poses of the %zu frames since the "
                      "confirmation are not a rigid move of the online ones (rms %.1f mm): a map restart among them?",
                      from.size(), rms);
        LogWarning(text);
      }
    } else {
      LogWarning("target.json stays in the online poses' frame: " + std::to_string(from.size()) +
                 " frames since the confirmation have a final pose (10 needed)");
    }
  } else if (r.state != TargetState::kSearching && !why.empty()) {
    LogWarning("target.json stays in the online poses' frame: no final poses (" + why + ")");
  }
  final_result_ = r;
  if (ExpectsModel(r)) {
    WriteTargetJson(r, BoxSource{});  // the landmarks' box in the final frame now: a hard stop later still leaves it
    if (have_model_) {
      CompleteTarget("");
      return;
    }
    awaiting_model_ = true;
    awaiting_since_us_ = WallTimeMicros();
    status_.SetState(+process_status_t::STATE_RUNNING, "waiting for the dense model on " + options_.model_channel);
    return;
  }
  CompleteTarget("");
}

bool ObjectFinderNode::ExpectsModel(const FinderResult& r) const {
  return !options_.model_channel.empty() && !options_.output_dir.empty() && r.state != TargetState::kSearching;
}

void ObjectFinderNode::WriteTargetJson(const FinderResult& r, const BoxSource& source) {
  if (options_.output_dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(options_.output_dir, ec);
  const std::string path = options_.output_dir + "/target.json";
  std::ofstream out(path);
  out << TargetJson(r, finder_.updates(), source);
  out.close();
  if (out)
    LogInfo("wrote " + path);
  else
    LogError("cannot write " + path);
}

void ObjectFinderNode::OnModel(const model_t& msg) {
  status_.CountIn();
  model_ = msg;
  have_model_ = true;
  if (awaiting_model_) CompleteTarget("");
}

void ObjectFinderNode::CompleteTarget(const std::string& why) {
  awaiting_model_ = false;
  FinderResult r = final_result_;
  BoxSource source;
  if (ExpectsModel(r)) {
    std::string error;
    std::vector<Eigen::Vector3d> voxels;
    if (!have_model_) {
      error = "no model on " + options_.model_channel + " (" + why + ")";
    } else if (model_.voxels_ply_path.empty() || model_.num_voxels <= 0) {
      error = "the dense modeler's model is empty or was not written";
    } else if (!r.floor_valid) {
      error = "no floor to measure the model's height from";
    } else if (!ReadPlyPoints(model_.voxels_ply_path, &voxels, &error)) {
      error = "cannot read the model's voxels on this host: " + error;
    } else {
      TargetBox box;
      int used = 0;
      if (BoxFromModel(voxels, model_.voxel_size_mm, r.floor, r.box, &box, &used, &error)) {
        source.from_model = true;
        source.landmarks_box = r.box;
        source.model_voxels = used;
        LogInfo("target.json's box measured on the model (" + std::to_string(used) + " of " +
                std::to_string(voxels.size()) + " voxels): " + Describe(box) +
                Format(", %.1f mm from the landmarks' box", (box.centre_mm - r.box.centre_mm).norm()));
        r.box = box;
      }
    }
    if (!source.from_model) {
      source.model_error = error;
      LogWarning("target.json keeps the landmarks' box: " + error);
    }
  }
  WriteTargetJson(r, source);
  PublishTarget(WallTimeMicros());
  PublishFinished(bus_, status_, options_.control_channel, options_.name,
                  last_landmarks_seq_ >= 0 ? r.utime : end_utime_, last_landmarks_seq_);
  finished_ = true;
  status_.SetState(+process_status_t::STATE_FINISHED, "end of stream answered");
  status_.PublishIfDue(WallTimeMicros(), true);
}

void ObjectFinderNode::Tick(int64_t wall_utime) {
  if (awaiting_final_ && wall_utime - awaiting_since_us_ > kFinalPoseWaitUs)
    FinishTarget("none within " + std::to_string(kFinalPoseWaitUs / 1'000'000) + " s of the end of stream");
  if (awaiting_model_ && wall_utime - awaiting_since_us_ > kModelWaitUs)
    CompleteTarget("none within " + std::to_string(kModelWaitUs / 1'000'000) + " s of the final poses");
  if (have_target_ && wall_utime - target_published_us_ >= static_cast<int64_t>(options_.target_period_s * 1e6))
    PublishTarget(wall_utime);
  status_.PublishIfDue(wall_utime);
}

void ObjectFinderNode::OnShutdown() {
  if (awaiting_final_) FinishTarget("stopped before the pose solver finished");
  if (awaiting_model_) CompleteTarget("stopped before the dense modeler finished");
  status_.PublishIfDue(WallTimeMicros(), true);
}

}  // namespace objscan
