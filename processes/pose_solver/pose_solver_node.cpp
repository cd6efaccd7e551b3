#include "processes/pose_solver/pose_solver_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/log.h"
#include "common/options.h"
#include "common/recorded_run.h"
#include "common/time.h"
#include "objscan/landmarks_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"

namespace objscan {

void AddPoseSolverNodeOptions(OptionParser& p, PoseSolverNodeOptions* o) {
  // Only what a user sets (issue 27): plumbing, the motion model, the robot's geometry, the wide-baseline profile's
  // settings (scripts/profiles), the scale sources, and the relocalization and map-join switches the tests and the
  // README use. Every other field keeps its default here; tests and tools set the struct directly.
  p.Add("name", &o->name, "process name (status name, sender of control messages)");
  p.AddChannel(&o->tracks_channel, "input feature_tracks_t channel");
  p.AddChannel(&o->info_channel, "input camera_info_t channel");
  p.AddChannel(&o->odometry_channel, "input odometry_t channel (\"\" = no odometry)");
  p.AddChannel(&o->pose_channel, "output pose_t channel (one per frame)");
  p.AddChannel(&o->final_pose_channel, "output pose_t channel for the final poses after global BA");
  p.AddChannel(&o->landmarks_channel, "output landmarks_t channel");
  p.AddChannel(&o->control_channel, "control_t channel (finished in and out)");
  p.AddChannel(&o->status_channel, "process_status_t channel");
  p.Add("finish-on-sender", &o->finish_on_sender, "COMMAND_FINISHED from this sender starts the final phase");
  p.Add("model", &o->model, "camera motion model: 6dof or 4dof (robot on the floor: x, y, yaw, tilt)");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after the final phase");
  p.Add("output-dir", &o->output_dir, "write trajectory.txt, trajectory_online.txt, landmarks.ply, colmap/ here");
  p.Add("robot-file", &o->robot_file,
        "the robot's robot.cfg (common/recorded_run.h: mast height and offsets, camera offset; the planner takes the "
        "same file); none: the simulator's robot");
  PoseEstimatorOptions* e = &o->estimator;
  p.Add("pnp-min-inliers", &e->pnp.min_inliers, "fewer PnP inliers = lost");
  p.Add("tri-min-views", &e->min_triangulation_views, "posed views a track needs to be triangulated");
  p.Add("keyframe-interval", &e->keyframe_interval, "frames, longest gap between keyframes");
  p.Add("use-floor-for-scale", &e->use_floor_for_scale, "4dof: level on and scale from the floor plane");
  p.Add("camera-height-known", &e->camera_height_known,
        "the robot geometry's camera height is real (false: images without odometry are only levelled by the floor, "
        "lengths stay arbitrary)");
  p.Add("refine-scale-with-odometry", &e->refine_scale_with_odometry, "6dof: rescale at the end by odometry path");
  p.Add("online-scale-frames", &e->online_scale_frames, "6dof: rescale by odometry path at keyframes this long");
  p.Add("relocalize-after", &e->relocalize_after_lost_frames, "lost frames before the preliminary phase restarts");
  p.Add("relocalize-search", &e->relocalize_search_px,
        "px, largest image shift searched when a lost frame is relocalized by position from the odometry's "
        "prediction (larger for poorer odometry; 0 = off)");
  p.Add("join-search", &e->join_search_mm,
        "mm, after a restart join the new map to the old by common landmarks this close (0 = odometry chaining only)");
  p.Add("two-view-min-matches", &e->two_view_min_matches,
        "wide baseline (6dof): pose a frame PnP cannot pose from the essential matrix with the last posed frame when "
        "they share this many tracks (0 = off)");
  p.Add("two-view-min-landmarks", &e->two_view_min_landmarks, "landmarks that frame must see to fix the step length");
}

bool ValidatePoseSolverNodeOptions(const PoseSolverNodeOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.name.empty()) e << "name must not be empty; ";
  if (o.tracks_channel.empty()) e << "tracks-channel must not be empty; ";
  if (o.info_channel.empty()) e << "info-channel must not be empty; ";
  if (o.pose_channel.empty()) e << "pose-channel must not be empty; ";
  if (o.final_pose_channel.empty()) e << "final-pose-channel must not be empty; ";
  if (o.landmarks_channel.empty()) e << "landmarks-channel must not be empty; ";
  if (o.control_channel.empty()) e << "control-channel must not be empty; ";
  if (o.status_channel.empty()) e << "status-channel must not be empty; ";
  if (!(o.min_posed_fraction >= 0 && o.min_posed_fraction <= 1)) e << "min_posed_fraction must be in [0, 1]; ";
  if (o.finish_on_sender.empty()) e << "finish-on-sender must not be empty; ";
  if (o.model != "6dof" && o.model != "4dof") e << "model must be 6dof or 4dof; ";
  if (o.pending_tracks_capacity < 0) e << "pending_tracks_capacity must be >= 0; ";
  if (o.tracks_queue_capacity < 1) e << "tracks_queue_capacity must be >= 1; ";
  if (!(o.max_odometry_gap_s >= 0) || !std::isfinite(o.max_odometry_gap_s)) e << "max_odometry_gap_s must be >= 0; ";
  if (!(o.status_period_s > 0.0) || !std::isfinite(o.status_period_s)) e << "status_period_s must be > 0; ";
  std::string est_why;
  if (!ValidatePoseEstimatorOptions(o.estimator, &est_why)) e << est_why << "; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

namespace {
PoseSolverNodeOptions ValidatedOrThrow(PoseSolverNodeOptions o) {
  std::string why;
  if (!o.robot_file.empty()) {
    RobotDescription robot;
    if (!ReadRobotFile(o.robot_file, &robot, &why)) throw std::invalid_argument("pose_solver node: " + why);
    o.estimator.robot = robot.geometry;
  }
  if (!ValidatePoseSolverNodeOptions(o, &why)) throw std::invalid_argument("pose_solver node: " + why);
  o.estimator.model = o.model == "4dof" ? MotionModel::kFourDof : MotionModel::kSixDof;
  return o;
}
}  // namespace

PoseSolverNode::PoseSolverNode(Bus& bus, const PoseSolverNodeOptions& options)
    : bus_(bus),
      options_(ValidatedOrThrow(options)),
      status_(&bus, options_.name, options_.status_channel, options_.status_period_s) {
  status_.SetState(+process_status_t::STATE_STARTING, "waiting for camera_info and tracks");
  bus_.SubscribeMessage<feature_tracks_t>(
      options_.tracks_channel, [this](const feature_tracks_t& m, const RawMessage&) { OnTracks(m); },
      status_.MalformedHandler("tracks"), options_.tracks_queue_capacity);
  bus_.SubscribeMessage<camera_info_t>(
      options_.info_channel, [this](const camera_info_t& m, const RawMessage&) { OnCameraInfo(m); },
      status_.MalformedHandler("camera_info"));
  if (!options_.odometry_channel.empty())
    bus_.SubscribeMessage<odometry_t>(
        options_.odometry_channel, [this](const odometry_t& m, const RawMessage&) { OnOdometry(m); },
        status_.MalformedHandler("odometry"), 1000);
  bus_.SubscribeMessage<control_t>(
      options_.control_channel, [this](const control_t& m, const RawMessage&) { OnControl(m); },
      status_.MalformedHandler("control"));
}

void PoseSolverNode::OnCameraInfo(const camera_info_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "camera_info")) return;  // another session on the bus
  PinholeCamera camera;
  std::string error;
  if (!CameraFromMessage(msg, &camera, &error)) {
    status_.Reject(error, "camera " + msg.camera_name);
    return;
  }
  if (have_camera_) {
    if (!SameCalibration(camera_, camera))
      status_.Reject("camera_info: changed", "calibration differs from the first; ignored");
    else
      status_.CountIn();
    return;
  }
  status_.CountIn();
  camera_ = camera;
  have_camera_ = true;
  try {
    estimator_ = std::make_unique<PoseEstimator>(camera_, options_.estimator);
  } catch (const std::exception& e) {  // IsValid passed in the adapter; keep running regardless
    have_camera_ = false;
    status_.Reject("camera_info: unusable", e.what());
    return;
  }
  status_.SetState(+process_status_t::STATE_RUNNING);
  while (!pending_.empty()) {
    TrackFrame f = std::move(pending_.front());
    pending_.pop_front();
    if ((f.width != camera_.width || f.height != camera_.height) && f.width > 0) {
      status_.Reject("tracks: image size differs from camera_info", "seq " + std::to_string(f.seq));
      continue;
    }
    ProcessFrame(f);
  }
}

void PoseSolverNode::OnOdometry(const odometry_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "odometry")) return;  // another session on the bus
  OdometryReading r;
  std::string error;
  if (!OdometryFromMessage(msg, &r, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq), "odometry", msg.seq);  // received, not dropped
    return;
  }
  if (!odometry_.Add(r)) {
    status_.Reject("odometry: out of order", "utime " + std::to_string(msg.utime), "odometry", msg.seq);
    return;
  }
  status_.ObserveSeq("odometry", msg.seq);
  status_.CountIn();
  odometry_seen_ = true;
}

void PoseSolverNode::OnTracks(const feature_tracks_t& msg) {
  const int64_t start_us = MonotonicMicros();
  if (finished_) {
    status_.Reject("tracks: after end of stream", "seq " + std::to_string(msg.seq));
    return;
  }
  TrackFrame frame;
  std::string error;
  if (!TracksFromMessage(msg, &frame, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq), "tracks", msg.seq);  // received, not dropped
    return;
  }
  if (frame.width <= 0 || frame.height <= 0) {
    frame.width = have_camera_ ? camera_.width : frame.width;
    frame.height = have_camera_ ? camera_.height : frame.height;
  }
  if (have_camera_ && (frame.width != camera_.width || frame.height != camera_.height)) {
    status_.Reject(
        "tracks: image size differs from camera_info",
        "seq " + std::to_string(msg.seq) + " " + std::to_string(frame.width) + "x" + std::to_string(frame.height),
        "tracks", msg.seq);
    return;
  }
  for (const auto& t : frame.features) {
    if (t.u < -0.5f || t.v < -0.5f || (frame.width > 0 && t.u > frame.width - 0.5f) ||
        (frame.height > 0 && t.v > frame.height - 0.5f)) {
      status_.Reject("tracks: coordinate outside the image", "seq " + std::to_string(msg.seq), "tracks", msg.seq);
      return;
    }
  }
  if (!pending_.empty() && msg.seq <= pending_.back().seq) {
    status_.Reject("tracks: out of order or repeated", "seq " + std::to_string(msg.seq));
    return;
  }
  if (!status_.AcceptSeq("tracks", msg.seq, "tracks")) return;
  if (!have_camera_) {
    if (static_cast<int>(pending_.size()) >= options_.pending_tracks_capacity) {
      status_.Reject("tracks: no camera_info (buffer full)", "seq " + std::to_string(msg.seq));
      return;
    }
    status_.CountIn();
    pending_.push_back(std::move(frame));
    return;
  }
  status_.CountIn();
  ProcessFrame(frame);
  status_.RecordLatencyMs((MonotonicMicros() - start_us) * 1e-3);
}

void PoseSolverNode::ProcessFrame(const TrackFrame& frame) {
  status_.SetLastDataUtime(frame.utime);
  OdometryReading odo;
  const bool have_odo = odometry_.At(frame.utime, &odo, static_cast<int64_t>(options_.max_odometry_gap_s * 1e6));
  FrameResult r;
  const int64_t t0 = MonotonicMicros();
  try {
    r = estimator_->AddFrame(frame, have_odo ? &odo : nullptr);
  } catch (const std::exception& e) {
    status_.Reject("tracks: estimator error", e.what());
    return;
  }
  const double frame_ms = (MonotonicMicros() - t0) * 1e-3;
  if (r.initialized_now) LogInfo(estimator_->last_message());
  if (std::string notice = estimator_->TakeNotice(); !notice.empty()) LogInfo(notice);
  // Without a map (start, or lost): say why no map starts, on the first such frame and every 150 frames after.
  if (estimator_->has_map()) {
    frames_without_map_ = 0;
  } else if (frames_without_map_++ % 150 == 0 && !estimator_->init_wait_reason().empty()) {
    LogInfo("no map yet at frame " + std::to_string(frame.seq) + " (" + std::to_string(frames_without_map_) +
            " frames without one): " + estimator_->init_wait_reason());
  }
  // Earlier frames of the preliminary window, posed by the new map: published now (same seq, late) and recorded
  // in place of their first (INITIALIZING / LOST) publication.
  BurstPacer pacer(bus_);  // the window can be longer than a subscriber's queue
  for (const CameraPoseEstimate& late : r.late_poses) {
    if (bus_.PublishMessage(options_.pose_channel, PoseToMessage(late))) status_.CountOut();
    pacer.After();
    for (auto it = online_poses_.rbegin(); it != online_poses_.rend(); ++it)
      if (it->seq == late.seq) {
        *it = late;
        break;
      }
  }
  if (bus_.PublishMessage(options_.pose_channel, PoseToMessage(r.pose))) status_.CountOut();
  online_poses_.push_back(r.pose);
  if (!options_.output_dir.empty()) {
    if (!spool_) {
      std::error_code ec;
      std::filesystem::create_directories(options_.output_dir, ec);
      spool_ = std::make_unique<ObservationSpool>(options_.output_dir + "/.observations.spool");
      if (!spool_->ok()) LogError(spool_->error() + ": the COLMAP model will have no 2-D points");
    }
    if (spool_->ok() && !spool_->Append(frame)) LogError(spool_->error());
  }
  if (r.keyframe) PublishLandmarks(frame.utime, frame.seq, true);
  if (r.pose.status == PoseStatus::kLost) ++lost_frames_;
  last_seq_ = frame.seq;
  last_utime_ = frame.utime;
  status_.SetValue("frames", estimator_->num_frames());
  if (estimator_->num_frames() % 30 == 1)  // O(frames + tracks): not on every frame
    status_.SetValue("estimator_kb", static_cast<double>(estimator_->ApproxMemoryBytes() / 1024));
  status_.SetValue("fused_tracks", estimator_->num_fused());
  status_.SetValue("inliers", r.pose.num_inliers);
  status_.SetValue("rms_px", r.pose.reprojection_rms_px);
  status_.SetValue("lost_frames", static_cast<double>(lost_frames_));
  status_.SetValue("frame_ms", frame_ms);
}

void PoseSolverNode::PublishLandmarks(int64_t utime, int64_t seq, bool current_map_only) {
  const std::vector<Landmark> lms = estimator_->Landmarks(current_map_only);
  landmarks_t m;
  m.utime = utime;
  m.seq = seq;
  m.frame = "world";
  m.num_landmarks = static_cast<int32_t>(lms.size());
  m.id.reserve(lms.size());
  for (const auto& l : lms) {
    m.id.push_back(l.id);
    m.position_mm.push_back({static_cast<float>(l.position_mm.x()), static_cast<float>(l.position_mm.y()),
                             static_cast<float>(l.position_mm.z())});
    m.num_observations.push_back(l.num_observations);
    m.reprojection_error_px.push_back(static_cast<float>(l.reprojection_rms_px));
    m.rgb.push_back({200, 200, 200});
  }
  if (bus_.PublishMessage(options_.landmarks_channel, m)) status_.CountOut();
  status_.SetValue("landmarks", static_cast<double>(lms.size()));
  status_.SetValue("keyframes", estimator_->num_keyframes());
}

void PoseSolverNode::OnControl(const control_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session on the bus
  if (!IsFinalizeRequest(msg, options_.name)) {
    if (msg.command != control_t::COMMAND_FINISHED || msg.sender != options_.finish_on_sender) return;
    if (!msg.target.empty() && msg.target != "*" && msg.target != options_.name) return;
  }
  status_.CountIn();
  if (finished_) return;
  RunFinalPhase(msg);
}

void PoseSolverNode::RunFinalPhase(const control_t& msg) {
  for (const auto& f : pending_)
    status_.Reject("tracks: no camera_info at end of stream", "seq " + std::to_string(f.seq));
  pending_.clear();
  std::vector<CameraPoseEstimate> final_poses;
  std::string failure;  // why the run failed (empty: it did not)
  if (estimator_) {
    try {
      final_poses = estimator_->Finish();
    } catch (const std::exception& e) {
      failure = std::string("final phase failed: ") + e.what();
      LogError(failure);
    }
    status_.SetValue("final_ba_ms", estimator_->final_ba_ms());
    status_.SetValue("final_bend_percent", estimator_->final_bend_fraction() < 0
                                               ? -1.0
                                               : 100.0 * estimator_->final_bend_fraction());
    status_.SetValue("final_ba_dropped", estimator_->final_ba_dropped() ? 1 : 0);
    if (estimator_->final_ba_dropped())
      LogWarning(estimator_->last_message());
    else
      LogInfo(estimator_->last_message());
    BurstPacer pacer(bus_);  // one message per frame: lcm-logger and viewers would drop an unpaced burst
    for (const auto& p : final_poses) {
      if (bus_.PublishMessage(options_.final_pose_channel, PoseToMessage(p))) status_.CountOut();
      pacer.After();
    }
    PublishLandmarks(last_seq_ >= 0 ? last_utime_ : msg.utime, last_seq_, false);
    if (!options_.output_dir.empty()) {
      std::string error;
      std::error_code ec;
      std::filesystem::create_directories(options_.output_dir, ec);
      const std::vector<Landmark> lms = estimator_->Landmarks();
      bool ok = WriteTumTrajectory(options_.output_dir + "/trajectory.txt", final_poses, &error) &&
                WriteTumTrajectory(options_.output_dir + "/trajectory_online.txt", online_poses_, &error) &&
                WriteLandmarksPly(options_.output_dir + "/landmarks.ply", lms, estimator_->scale_source(), &error);
      if (ok) {
        // Images in frame order; their observations come back from the spool in the same (seq) order. The two
        // are merged by seq: a spooled frame without a pose (the estimator rejected it) is skipped.
        // Fused tracks observe their landmark: the 2-D points carry the landmark id.
        std::unordered_map<int64_t, int64_t> landmark_of_track;
        for (const auto& [track, landmark] : estimator_->FusedTrackIds()) landmark_of_track[track] = landmark;
        const bool have_spool = spool_ && spool_->Rewind();
        size_t next = 0;
        bool spool_done = !have_spool, spool_pending = false;
        int64_t spool_seq = -1;
        std::vector<TrackedFeature> spool_features;
        auto next_image = [&](ColmapImage* im) {
          if (next >= final_poses.size()) return false;
          const CameraPoseEstimate& pose = final_poses[next++];
          im->pose = pose;
          char name[64];
          std::snprintf(name, sizeof(name), "%06lld.png", static_cast<long long>(pose.seq));
          im->name = name;
          im->features.clear();
          while (!spool_done) {
            if (!spool_pending && !(spool_pending = spool_->Next(&spool_seq, &spool_features))) {
              spool_done = true;
              break;
            }
            if (spool_seq < pose.seq) {  // no pose for that frame
              spool_pending = false;
              continue;
            }
            if (spool_seq == pose.seq) {
              im->features.swap(spool_features);
              if (!landmark_of_track.empty())
                for (TrackedFeature& feature : im->features)
                  if (auto it = landmark_of_track.find(feature.id); it != landmark_of_track.end())
                    feature.id = it->second;
              spool_pending = false;
            }
            break;  // a later frame's record stays pending
          }
          return true;
        };
        ok = WriteColmapText(options_.output_dir + "/colmap", camera_, next_image, lms, &error);
        if (spool_ && !spool_->ok()) LogError(spool_->error() + ": COLMAP 2-D points incomplete");
        spool_.reset();  // removes the file
      }
      if (!ok)
        LogError("writing results: " + error);
      else
        LogInfo("results written to " + options_.output_dir);
    }
  }
  // Loud: a run that poses too few of its frames is a failure (the model, if any, covers part of the object).
  const int64_t frames = estimator_ ? estimator_->num_frames() : 0;
  const int64_t posed = std::count_if(final_poses.begin(), final_poses.end(),
                                      [](const CameraPoseEstimate& p) { return IsWrittenPose(p.status); });
  status_.SetValue("final_posed", static_cast<double>(posed));
  if (estimator_) {
    status_.SetValue("scale_metric", IsMetric(estimator_->scale_source()) ? 1.0 : 0.0);
    LogInfo("final: " + std::to_string(posed) + " of " + std::to_string(frames) + " frames posed; scale " +
            ScaleDescription(estimator_->scale_source()));
    // Where the final trajectory holds maps never joined to each other (the session checks them against the
    // frames the model was built from).
    const std::vector<int64_t> unjoined = estimator_->UnjoinedRestartSeqs();
    status_.SetValue("unjoined_restarts", static_cast<double>(unjoined.size()));
    status_.SetValue("last_unjoined_restart_seq", unjoined.empty() ? -1.0 : static_cast<double>(unjoined.back()));
    if (!unjoined.empty()) {
      std::string list;
      for (int64_t s : unjoined) list += (list.empty() ? "" : ", ") + std::to_string(s);
      LogWarning("the final trajectory holds maps never joined to the one before them, from frames " + list +
                 ": poses across these frames are related by the odometry only");
    }
  }
  if (failure.empty() && frames > 0 &&
      static_cast<double>(posed) < options_.min_posed_fraction * static_cast<double>(frames)) {
    failure = "only " + std::to_string(posed) + " of " + std::to_string(frames) +
              " frames got a pose (min_posed_fraction " + std::to_string(options_.min_posed_fraction).substr(0, 4) +
              "): ";
    if (odometry_seen_)  // a robot: the stream is continuous, so tracking was lost and no new map started
      failure += "tracking was lost and no new map started for long (last reason: " +
                 (estimator_->init_wait_reason().empty() ? std::string("none logged") : estimator_->init_wait_reason()) +
                 "). A new map needs the base to travel with texture in view; see the log's 'no map yet' lines";
    else
      failure += "neighbouring views share too few tracks. Try views closer together or in order around the object "
                 "(--order), the other tracking mode (--klt / --wide-baseline), or more texture";
    LogError(failure);
  }
  PublishFinished(bus_, status_, options_.control_channel, options_.name, last_seq_ >= 0 ? last_utime_ : msg.utime,
                  last_seq_, options_.output_dir);
  finished_ = true;
  if (failure.empty())
    status_.SetState(+process_status_t::STATE_FINISHED, "final phase done");
  else
    status_.SetState(+process_status_t::STATE_ERROR, failure);
  status_.PublishIfDue(WallTimeMicros(), true);
}

void PoseSolverNode::Tick(int64_t wall_utime) { status_.PublishIfDue(wall_utime); }

void PoseSolverNode::OnShutdown() { status_.PublishIfDue(WallTimeMicros(), true); }

}  // namespace objscan
