// PlannerNode: the "planner" process, a thin LCM adapter around Planner (planner.h).
// Inputs:
//   CAMERA_POSE     pose_t world_from_camera (mm). For EVERY pose received in order (any status) exactly one
//                   ROBOT_COMMAND goes out, with seq and utime of that pose: the simulator runs in lock-step on it
//                   (frame i+1 after a command with seq >= i). A republished pose with a seq not above the last one
//                   (the pose solver's late window) gets no command (counted in late_poses). A pose that decodes but
//                   fails PoseFromMessage (non-finite, not a rotation) is rejected and still answered: the planner
//                   dead-reckons as for a LOST pose.
//   ROBOT_ODOMETRY  odometry_t (odometry frame; pan/tilt readings): dead reckoning and the head angles of each pose.
//   TARGET          target_t (frame "world"): searching / candidate / confirmed / lost, centre, size, yaw.
//   LANDMARKS       landmarks_t (frame "world"): the whole sparse map; obstacles and floor of the planner's map.
//   VOXEL_MAP       voxel_map_t (frame "world"): the dense model so far, for the coverage.
//   CAMERA_INFO     camera_info_t: image size and focal lengths (defaults 640 x 480, fx = fy = 800 before it).
//   OBJSCAN_CONTROL control_t COMMAND_END_OF_STREAM (target "*", "" or the process name): writes output_dir/plan.json
//                   (when set; plan_report.h), publishes control_t COMMAND_FINISHED (sender = name, last_seq / utime
//                   = the last pose answered, -1 / the message's utime if none); then Finished() (with
//                   exit_when_finished). Other commands are ignored.
// Outputs:
//   ROBOT_COMMAND   robot_command_t: MODE_VELOCITY with has_pan_tilt (v_mm_s >= 0, omega_rad_s, pan_rad, tilt_rad,
//                   within the limits) while planning; MODE_STOP once the plan is finished (FINISH or NO_TARGET).
//   OBJSCAN_CONTROL once, right after the first MODE_STOP: control_t COMMAND_SHUTDOWN (sender = name, target =
//                   driver_name) so that the driver ends the stream (its END_OF_STREAM then ends every process).
//   PROCESS_STATUS  at status_period_s; state_detail "PHASE: activity"; values phase (0 EXPLORE, 1 APPROACH, 2 ORBIT,
//                   3 NEXT_VIEWS, 4 FINISH, 5 NO_TARGET), coverage (fraction), orbit_percent, next_views, path_mm,
//                   odometry_disagreement_mm / _deg (last), odometry_disagreement_max_mm, plan_ms (last decision,
//                   wall clock), next_view_ms (last next-view choice), commands, late_poses, safety_stops,
//                   free_m2 (free map area), obstacle_cells.
// Phase changes and events are logged one line each ("phase EXPLORE -> APPROACH: target confirmed at ...").
// Rejections (counted, logged once per reason, never fatal): "<input>: malformed" (landmarks, voxel_map and
// camera_info have their declared array sizes checked against the byte count before decoding), PoseFromMessage's /
// OdometryFromMessage's / CameraFromMessage's reasons, "odometry: out of order", "target: not in world frame",
// "target: bad values", "landmarks: not in world frame", "voxel_map: not in world frame", "voxel_map: bad values".
// Handlers run inside Bus::Handle() on the caller's thread; not thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/camera_model.h"
#include "common/node.h"
#include "common/status.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"
#include "processes/planner/planner.h"

namespace objscan {

class Bus;
class OptionParser;

struct PlannerNodeOptions {
  std::string name = "planner";                     // process name (status name, control sender)
  std::string robot_file;  // robot.cfg (common/recorded_run.h): replaces planner.robot, the footprint, speed, yaw rate
                           // and head limits (planner.map, planner.limits and the four fields below)
  std::string pose_channel = "CAMERA_POSE";         // pose_t in
  std::string odometry_channel = "ROBOT_ODOMETRY";  // odometry_t in
  std::string target_channel = "TARGET";            // target_t in
  std::string landmarks_channel = "LANDMARKS";      // landmarks_t in
  std::string voxel_channel = "VOXEL_MAP";          // voxel_map_t in
  std::string info_channel = "CAMERA_INFO";         // camera_info_t in
  std::string command_channel = "ROBOT_COMMAND";    // robot_command_t out
  std::string control_channel = "OBJSCAN_CONTROL";  // control_t in (end of stream) and out (shutdown, finished)
  std::string status_channel = "PROCESS_STATUS";    // process_status_t out
  std::string driver_name = "robot_sim";            // process the SHUTDOWN request is addressed to
  std::string output_dir;                           // plan.json is written here at end of stream ("" = none)
  double status_period_s = 1.0;                     // s
  bool exit_when_finished = true;                   // Finished() after end of stream was answered
  // Degrees on the command line, radians in planner.
  double tracking_turn_deg_s = 30;                  // deg/s, fastest base and camera rotation
  double max_omega_deg_s = 90;                      // deg/s, the base's yaw-rate limit
  double pan_limit_deg = 170;                       // deg, |pan| limit
  double tilt_min_deg = 0;                          // deg (positive = down)
  double tilt_max_deg = 60;                         // deg
  double max_incidence_deg = 60;                    // deg, coverage: largest view angle to a surface normal
  double azimuth_step_deg = 15;                     // deg, next-view candidates around the target
  std::string next_view_radii = "500,650,800,1000"; // mm, comma-separated rings of next-view candidates
  PlannerOptions planner;                           // everything else (mm, s; robot geometry)
};

// Registers the options a user sets on the command line (the rest keep their defaults; code and tests set the
// struct's fields directly).
void AddPlannerNodeOptions(OptionParser& parser, PlannerNodeOptions* options);
// True when usable; otherwise false with *why set.
bool ValidatePlannerNodeOptions(const PlannerNodeOptions& options, std::string* why);
// The planner's options with the degree and list options applied. False with *why for unparsable radii.
bool ToPlannerOptions(const PlannerNodeOptions& options, PlannerOptions* out, std::string* why);

class PlannerNode : public Node {
 public:
  // Subscribes on bus (which must outlive the node). Throws std::invalid_argument on invalid options.
  PlannerNode(Bus& bus, const PlannerNodeOptions& options);

  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_ && options_.exit_when_finished; }
  void OnShutdown() override;

  const StatusReporter& status() const { return status_; }
  const Planner& planner() const { return planner_; }
  bool shutdown_sent() const { return shutdown_sent_; }
  bool end_of_stream_answered() const { return finished_; }
  int64_t commands_sent() const { return commands_; }

 private:
  void OnPose(const pose_t& msg);
  void OnOdometry(const odometry_t& msg);
  void OnTarget(const target_t& msg);
  void OnLandmarks(const landmarks_t& msg);
  void OnVoxels(const voxel_map_t& msg);
  void OnCameraInfo(const camera_info_t& msg);
  void OnControl(const control_t& msg);
  void PublishCommand(const PlannerCommand& command, int64_t seq, int64_t utime);
  void UpdateStatusValues();

  Bus& bus_;
  PlannerNodeOptions options_;
  Planner planner_;
  StatusReporter status_;
  bool have_pose_ = false;
  int64_t last_pose_seq_ = -1;
  int64_t last_pose_utime_ = 0;
  int64_t commands_ = 0;
  int64_t late_poses_ = 0;
  Phase logged_phase_ = Phase::kExplore;
  bool shutdown_sent_ = false;
  bool finished_ = false;
  std::optional<PinholeCamera> first_camera_;  // the accepted camera_info (a different later one is rejected)
};

}  // namespace objscan
