#include "processes/planner/planner_node.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/log.h"
#include "common/recorded_run.h"
#include "common/options.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"
#include "objscan/robot_command_t.hpp"
#include "processes/planner/plan_report.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;


bool ParseRadii(const std::string& text, std::vector<double>* radii) { return ParseNumberList(text, radii); }

const char* kWorld = "world";

}  // namespace

void AddPlannerNodeOptions(OptionParser& p, PlannerNodeOptions* o) {
  // Only what a user sets (issue 27): plumbing, the mission's radius, speeds, budgets and next views, the map's extent
  // and the floor-support switch, and the robot (footprint, safety margin, clearance heights, geometry, speed and
  // head limits). Every other field keeps its default here (the status period among them); tests and tools set the
  // struct directly.
  p.Add("name", &o->name, "process name (status name, sender of control messages)");
  p.AddChannel(&o->pose_channel, "input camera pose channel (pose_t); one command per pose");
  p.AddChannel(&o->odometry_channel, "input odometry_t channel");
  p.AddChannel(&o->target_channel, "input target_t channel");
  p.AddChannel(&o->landmarks_channel, "input sparse map channel (landmarks_t)");
  p.AddChannel(&o->voxel_channel, "input dense model channel (voxel_map_t)");
  p.AddChannel(&o->info_channel, "input camera_info_t channel");
  p.AddChannel(&o->command_channel, "output robot_command_t channel");
  p.AddChannel(&o->control_channel, "control_t channel (end of stream in; shutdown, finished out)");
  p.AddChannel(&o->status_channel, "process_status_t channel");
  p.Add("driver-name", &o->driver_name, "process name of the driver asked to end the stream when the plan is done");
  p.Add("output-dir", &o->output_dir, "write plan.json here at end of stream (\"\" = none)");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after answering end of stream");
  PlannerOptions* q = &o->planner;
  p.Add("orbit-radius", &q->orbit_radius_mm, "mm, radius of the circle around the target");
  p.Add("orbit-speed", &q->orbit_speed_mm_s, "mm/s, speed along the circle");
  p.Add("explore-speed", &q->explore_speed_mm_s, "mm/s, speed while exploring, approaching and going to views");
  p.Add("capture-speed", &q->capture_speed_mm_s, "mm/s, speed along a next view's ring while capturing");
  p.Add("tracking-turn-deg-s", &o->tracking_turn_deg_s,
        "deg/s, fastest rotation of the base and of the camera (base + pan): the tracker must keep up");
  p.Add("explore-budget", &q->explore_budget_s, "s of exploring without a confirmed target before NO_TARGET");
  p.Add("coverage-target", &q->coverage_target, "coverage fraction that ends the next views, (0, 1]");
  p.Add("min-coverage", &q->min_coverage,
        "coverage fraction below which a finished plan is a failure (outcome partial: the model misses part of the "
        "target), [0, 1]");
  p.Add("max-next-views", &q->max_next_views, "next views added at most");
  p.Add("next-views-budget", &q->next_views_budget_s, "s spent on next views at most");
  p.Add("next-view-radii", &o->next_view_radii, "mm, comma-separated ring radii of next-view candidates");
  OccupancyMapOptions* m = &q->map;
  p.Add("map-size", &m->size_mm, "mm, side of the mapped square, centred on the robot's start");
  p.Add("free-support", &m->free_support_mm,
        "mm, free floor needs a floor landmark this close (0 = view rays alone, for untextured floors)");
  p.Add("obstacle-min-z", &m->obstacle_min_z_mm, "mm, landmarks at least this high are obstacles");
  p.Add("obstacle-max-z", &m->obstacle_max_z_mm, "mm, landmarks higher than this do not block the base");
  p.Add("safety-margin", &m->safety_margin_mm, "mm, planned paths keep footprint + this from obstacles");
  p.Add("robot-file", &o->robot_file,
        "the robot's robot.cfg (common/recorded_run.h: mast height and offsets, camera offset, footprint, speed, "
        "yaw rate, pan and tilt limits; the pose solver and the simulator take the same file); none: the "
        "simulator's robot");
}

bool ToPlannerOptions(const PlannerNodeOptions& o, PlannerOptions* out, std::string* why) {
  PlannerOptions p = o.planner;
  double max_omega_deg_s = o.max_omega_deg_s, pan_limit_deg = o.pan_limit_deg, tilt_min_deg = o.tilt_min_deg,
         tilt_max_deg = o.tilt_max_deg;
  if (!o.robot_file.empty()) {  // the robot's geometry and limits
    RobotDescription robot;
    if (!ReadRobotFile(o.robot_file, &robot, why)) return false;
    p.robot = robot.geometry;
    p.map.footprint_radius_mm = robot.footprint_radius_mm;
    p.limits.max_speed_mm_s = robot.max_speed_mm_s;
    max_omega_deg_s = robot.max_omega_deg_s;
    pan_limit_deg = robot.pan_limit_deg;
    tilt_min_deg = robot.tilt_min_deg;
    tilt_max_deg = robot.tilt_max_deg;
  }
  p.tracking_turn_rad_s = o.tracking_turn_deg_s * kDeg;
  p.limits.max_omega_rad_s = max_omega_deg_s * kDeg;
  p.limits.max_pan_rad = pan_limit_deg * kDeg;
  p.limits.min_tilt_rad = tilt_min_deg * kDeg;
  p.limits.max_tilt_rad = tilt_max_deg * kDeg;
  p.coverage.max_incidence_deg = o.max_incidence_deg;
  p.next_view.azimuth_step_deg = o.azimuth_step_deg;
  if (!ParseRadii(o.next_view_radii, &p.next_view.radii_mm)) {
    if (why) *why = "next-view-radii must be comma-separated numbers (mm)";
    return false;
  }
  *out = p;
  return true;
}

namespace {
// ValidatePlannerNodeOptions, with the converted options in *planner_options (when not null) on success: the robot
// file is read once.
bool ValidateAndConvert(const PlannerNodeOptions& o, std::string* why, PlannerOptions* planner_options) {
  std::ostringstream e;
  for (const auto& [value, name] :
       {std::pair{&o.name, "name"}, {&o.pose_channel, "pose-channel"}, {&o.odometry_channel, "odometry-channel"},
        {&o.target_channel, "target-channel"}, {&o.landmarks_channel, "landmarks-channel"},
        {&o.voxel_channel, "voxel-channel"}, {&o.info_channel, "info-channel"},
        {&o.command_channel, "command-channel"}, {&o.control_channel, "control-channel"},
        {&o.status_channel, "status-channel"}, {&o.driver_name, "driver-name"}})
    if (value->empty()) e << name << " must not be empty; ";
  if (!(o.status_period_s > 0) || !std::isfinite(o.status_period_s)) e << "status_period_s must be > 0; ";
  PlannerOptions p;
  std::string sub;
  if (!ToPlannerOptions(o, &p, &sub))
    e << sub << "; ";
  else if (!ValidatePlannerOptions(p, &sub))
    e << sub << (o.robot_file.empty() ? "" : " (with the limits of " + o.robot_file + ")") << "; ";
  const std::string message = e.str();
  if (message.empty()) {
    if (planner_options) *planner_options = p;
    return true;
  }
  if (why) *why = message.substr(0, message.size() - 2);
  return false;
}
}  // namespace

bool ValidatePlannerNodeOptions(const PlannerNodeOptions& o, std::string* why) {
  return ValidateAndConvert(o, why, nullptr);
}

namespace {
PlannerOptions PlannerOptionsOrThrow(const PlannerNodeOptions& o) {
  std::string why;
  PlannerOptions p;
  if (!ValidateAndConvert(o, &why, &p)) throw std::invalid_argument("planner node: " + why);
  return p;
}
}  // namespace

PlannerNode::PlannerNode(Bus& bus, const PlannerNodeOptions& options)
    : bus_(bus),
      options_(options),
      planner_(PlannerOptionsOrThrow(options)),
      status_(&bus, options_.name, options_.status_channel, options_.status_period_s) {
  status_.SetState(+process_status_t::STATE_STARTING, "waiting for camera poses on " + options_.pose_channel);
  bus_.SubscribeMessage<pose_t>(
      options_.pose_channel, [this](const pose_t& m, const RawMessage&) { OnPose(m); },
      status_.MalformedHandler("pose"), 1000);
  bus_.SubscribeMessage<odometry_t>(
      options_.odometry_channel, [this](const odometry_t& m, const RawMessage&) { OnOdometry(m); },
      status_.MalformedHandler("odometry"), 1000);
  bus_.SubscribeMessage<target_t>(
      options_.target_channel, [this](const target_t& m, const RawMessage&) { OnTarget(m); },
      status_.MalformedHandler("target"), 100);
  bus_.SubscribeMessage<landmarks_t>(
      options_.landmarks_channel, [this](const landmarks_t& m, const RawMessage&) { OnLandmarks(m); },
      status_.MalformedHandler("landmarks"));
  bus_.SubscribeMessage<voxel_map_t>(
      options_.voxel_channel, [this](const voxel_map_t& m, const RawMessage&) { OnVoxels(m); },
      status_.MalformedHandler("voxel_map"));
  bus_.SubscribeMessage<camera_info_t>(
      options_.info_channel, [this](const camera_info_t& m, const RawMessage&) { OnCameraInfo(m); },
      status_.MalformedHandler("camera_info"));
  bus_.SubscribeMessage<control_t>(
      options_.control_channel, [this](const control_t& m, const RawMessage&) { OnControl(m); },
      status_.MalformedHandler("control"));
}

void PlannerNode::OnPose(const pose_t& msg) {
  const int64_t start_us = MonotonicMicros();
  if (have_pose_ && msg.seq <= last_pose_seq_) {  // a republished (late) pose: answered already
    status_.CountIn();
    ++late_poses_;
    return;
  }
  CameraPoseEstimate pose;
  std::string error;
  if (PoseFromMessage(msg, &pose, &error)) {
    status_.CountIn();
  } else {
    status_.Reject(error, "seq " + std::to_string(msg.seq));
    pose = CameraPoseEstimate{};  // answered all the same: the planner dead-reckons
    pose.status = PoseStatus::kLost;
  }
  pose.seq = msg.seq;
  pose.utime = msg.utime;
  status_.ObserveSeq("pose", msg.seq);
  status_.SetLastDataUtime(msg.utime);
  have_pose_ = true;
  last_pose_seq_ = msg.seq;
  last_pose_utime_ = msg.utime;
  const PlannerCommand command = planner_.Step(pose);
  for (const std::string& event : planner_.TakeEvents()) LogInfo(event);
  PublishCommand(command, msg.seq, msg.utime);
  if (planner_.done() && !shutdown_sent_) {
    control_t request;
    request.session_id = status_.session_id();  // the session it keeps to
    request.utime = msg.utime;
    request.sender = options_.name;
    request.target = options_.driver_name;
    request.command = control_t::COMMAND_SHUTDOWN;
    request.last_seq = msg.seq;
    request.argument = PlanOutcome(planner_.Summary());
    if (bus_.PublishMessage(options_.control_channel, request))
      status_.CountOut();
    else
      LogWarning("publishing on " + options_.control_channel + " failed");
    shutdown_sent_ = true;
    LogInfo(std::string("plan finished (") + PhaseName(planner_.phase()) + "): asked " + options_.driver_name +
            " to end the stream");
  }
  if (!finished_) {
    const std::string detail = std::string(PhaseName(planner_.phase())) + ": " + planner_.activity();
    status_.SetState(+process_status_t::STATE_RUNNING, detail);
  }
  UpdateStatusValues();
  status_.RecordLatencyMs((MonotonicMicros() - start_us) * 1e-3);
}

void PlannerNode::PublishCommand(const PlannerCommand& c, int64_t seq, int64_t utime) {
  robot_command_t m;
  m.utime = utime;
  m.seq = seq;
  m.mode = c.stop ? robot_command_t::MODE_STOP : robot_command_t::MODE_VELOCITY;
  m.v_mm_s = c.stop ? 0.0 : c.v_mm_s;
  m.omega_rad_s = c.stop ? 0.0 : c.omega_rad_s;
  m.goal_x_mm = m.goal_y_mm = m.goal_theta_rad = 0;
  m.has_pan_tilt = !c.stop;
  m.pan_rad = c.stop ? 0.0 : c.pan_rad;
  m.tilt_rad = c.stop ? 0.0 : c.tilt_rad;
  if (bus_.PublishMessage(options_.command_channel, m)) {
    status_.CountOut();
    ++commands_;
  } else {
    LogWarning("publishing on " + options_.command_channel + " failed");
  }
}

void PlannerNode::OnOdometry(const odometry_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "odometry")) return;  // another session on the bus
  OdometryReading reading;
  std::string error;
  if (!OdometryFromMessage(msg, &reading, &error)) {
    status_.Reject(error, "seq " + std::to_string(msg.seq), "odometry", msg.seq);
    return;
  }
  if (!planner_.AddOdometry(reading)) {
    status_.Reject("odometry: out of order", "seq " + std::to_string(msg.seq), "odometry", msg.seq);
    return;
  }
  status_.CountIn();
  status_.ObserveSeq("odometry", msg.seq);
}

void PlannerNode::OnTarget(const target_t& msg) {
  if (msg.frame != kWorld) {
    status_.Reject("target: not in world frame", "frame \"" + msg.frame + "\"");
    return;
  }
  TargetObservation t;
  t.utime = msg.utime;
  t.seq = msg.seq;
  t.centre_mm = Eigen::Vector3d(msg.center_mm[0], msg.center_mm[1], msg.center_mm[2]);
  t.size_mm = Eigen::Vector3d(msg.size_mm[0], msg.size_mm[1], msg.size_mm[2]);
  t.yaw_rad = msg.yaw_rad;
  t.confidence = msg.confidence;
  const bool state_ok = msg.state >= target_t::STATE_SEARCHING && msg.state <= target_t::STATE_LOST;
  if (!state_ok || !t.centre_mm.allFinite() || !t.size_mm.allFinite() || !std::isfinite(t.yaw_rad) ||
      (t.size_mm.array() < 0).any()) {
    status_.Reject("target: bad values", "seq " + std::to_string(msg.seq));
    return;
  }
  t.state = static_cast<TargetState>(msg.state);
  status_.CountIn();
  planner_.SetTarget(t);
  for (const std::string& event : planner_.TakeEvents()) LogInfo(event);
}

void PlannerNode::OnLandmarks(const landmarks_t& msg) {
  if (msg.frame != kWorld) {
    status_.Reject("landmarks: not in world frame", "frame \"" + msg.frame + "\"");
    return;
  }
  std::vector<MapLandmark> landmarks(static_cast<size_t>(msg.num_landmarks));
  for (int i = 0; i < msg.num_landmarks; ++i) {
    MapLandmark& l = landmarks[static_cast<size_t>(i)];
    l.position_mm = Eigen::Vector3f(msg.position_mm[i][0], msg.position_mm[i][1], msg.position_mm[i][2]);
    l.observations = msg.num_observations[i];
    l.error_px = msg.reprojection_error_px[i];
  }
  status_.CountIn();
  planner_.SetLandmarks(landmarks);  // non-finite points are skipped there
}

void PlannerNode::OnVoxels(const voxel_map_t& msg) {
  if (msg.frame != kWorld) {
    status_.Reject("voxel_map: not in world frame", "frame \"" + msg.frame + "\"");
    return;
  }
  const Eigen::Vector3d origin(msg.origin_mm[0], msg.origin_mm[1], msg.origin_mm[2]);
  if (!(msg.voxel_size_mm > 0) || !std::isfinite(msg.voxel_size_mm) || !origin.allFinite()) {
    status_.Reject("voxel_map: bad values", "voxel size " + std::to_string(msg.voxel_size_mm));
    return;
  }
  VoxelCloud voxels;
  voxels.voxel_size_mm = msg.voxel_size_mm;
  voxels.centres_mm.reserve(static_cast<size_t>(msg.num_voxels));
  for (int i = 0; i < msg.num_voxels; ++i)
    voxels.centres_mm.push_back(origin + (Eigen::Vector3d(msg.ijk[i][0], msg.ijk[i][1], msg.ijk[i][2]) +
                                          Eigen::Vector3d::Constant(0.5)) *
                                             msg.voxel_size_mm);
  status_.CountIn();
  planner_.SetVoxels(voxels);
}

void PlannerNode::OnCameraInfo(const camera_info_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "camera_info")) return;  // another session on the bus
  PinholeCamera camera;
  std::string error;
  if (!CameraFromMessage(msg, &camera, &error)) {
    status_.Reject(error, "camera " + msg.camera_name);
    return;
  }
  if (first_camera_ && !SameCalibration(*first_camera_, camera)) {
    status_.Reject("camera_info: changed", "calibration of '" + msg.camera_name + "' differs from the first; ignored");
    return;
  }
  status_.CountIn();
  first_camera_ = camera;
  CameraIntrinsics intrinsics;
  intrinsics.width = camera.width;
  intrinsics.height = camera.height;
  intrinsics.fx = camera.fx;
  intrinsics.fy = camera.fy;
  intrinsics.cx = camera.cx;
  intrinsics.cy = camera.cy;
  planner_.SetCamera(intrinsics);
}

void PlannerNode::OnControl(const control_t& msg) {
  if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session on the bus
  if (!IsFinalizeRequest(msg, options_.name)) {
    if (msg.command != control_t::COMMAND_END_OF_STREAM) return;  // our own SHUTDOWN, others' FINISHED, ...
    if (!msg.target.empty() && msg.target != "*" && msg.target != options_.name) return;
  }
  status_.CountIn();
  if (finished_) return;
  const PlanSummary summary = planner_.Summary();
  const int64_t end_utime = have_pose_ ? last_pose_utime_ : msg.utime;
  LogInfo("end of stream from " + msg.sender + ": outcome " + PlanOutcome(summary) + ", " +
          std::to_string(summary.views) + " views, path " + std::to_string(static_cast<int>(summary.path_length_mm)) +
          " mm, coverage " + std::to_string(summary.coverage));
  if (!options_.output_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options_.output_dir, ec);
    std::string error;
    if (!WritePlanJson(options_.output_dir + "/plan.json", summary, end_utime, &error)) LogError(error);
    if (!WritePlanMapPgm(options_.output_dir + "/plan_map.pgm", planner_.map(), planner_.path(), &error))
      LogError(error);
  }
  PublishFinished(bus_, status_, options_.control_channel, options_.name, end_utime, have_pose_ ? last_pose_seq_ : -1,
                  PlanOutcome(summary));
  finished_ = true;
  // A mission that did not end with a model is an error of the session (it says what happened and what to try).
  const std::string outcome = PlanOutcome(summary);
  char travelled[96];
  std::snprintf(travelled, sizeof(travelled), "after %.1f m and %lld views", summary.path_length_mm * 1e-3,
                static_cast<long long>(summary.views));
  if (outcome == "no_target") {
    status_.SetState(+process_status_t::STATE_ERROR,
                     std::string("no target found ") + travelled +
                         " (room explored or explore budget spent); try a longer --explore-budget and --frames, "
                         "check the object finder's target rule (size, texture), or start the robot nearer the object");
  } else if (outcome == "partial") {
    char text[720];
    std::snprintf(text, sizeof(text),
                  "the plan ended with %.1f %% of the target's surface seen (--min-coverage %.1f %%) %s: %s. The "
                  "model misses part of the target; try a smaller orbit radius (objscan run --radius, planner "
                  "--orbit-radius) or room around the target (%lld safety stops), more next views (objscan run "
                  "--next-views, planner --max-next-views, --next-views-budget)",
                  100 * summary.coverage, 100 * summary.min_coverage, travelled, summary.finish_reason.c_str(),
                  static_cast<long long>(summary.safety_stops));
    status_.SetState(+process_status_t::STATE_ERROR, text);
  } else if (outcome == "stopped") {
    status_.SetState(+process_status_t::STATE_ERROR,
                     std::string("the stream ended during ") + PhaseName(summary.phase) + " " + travelled +
                         ", before the plan finished; try more frames for the driver (objscan run --frames)");
  } else {
    status_.SetState(+process_status_t::STATE_FINISHED, "end of stream answered: " + outcome);
  }
  UpdateStatusValues();
  status_.PublishIfDue(WallTimeMicros(), true);
}

void PlannerNode::UpdateStatusValues() {
  const PoseDisagreement& last = planner_.pose_estimator().last_disagreement();
  const OccupancyMap& map = planner_.map();
  status_.SetValue("phase", static_cast<double>(static_cast<int>(planner_.phase())));
  status_.SetValue("coverage", planner_.coverage());
  status_.SetValue("orbit_percent", planner_.orbit_percent());
  status_.SetValue("next_views", planner_.num_next_views());
  status_.SetValue("path_mm", planner_.path_length_mm());
  status_.SetValue("odometry_disagreement_mm", last.distance_mm);
  status_.SetValue("odometry_disagreement_deg", last.angle_rad / kDeg);
  status_.SetValue("odometry_disagreement_max_mm", planner_.pose_estimator().max_disagreement().distance_mm);
  status_.SetValue("plan_ms", planner_.last_step_ms());
  status_.SetValue("next_view_ms", planner_.last_next_view_ms());
  status_.SetValue("commands", static_cast<double>(commands_));
  status_.SetValue("late_poses", static_cast<double>(late_poses_));
  status_.SetValue("free_m2", map.free_cells() * map.cell_mm() * map.cell_mm() * 1e-6);
  status_.SetValue("obstacle_cells", map.obstacle_cells());
}

void PlannerNode::Tick(int64_t wall_utime) { status_.PublishIfDue(wall_utime); }

void PlannerNode::OnShutdown() { status_.PublishIfDue(WallTimeMicros(), true); }

}  // namespace objscan
