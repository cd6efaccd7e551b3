// ObjectFinderNode: the "object_finder" process, a thin LCM adapter around ObjectFinder (object_finder.h).
// Inputs:
//   LANDMARKS       landmarks_t (frame "world"): one ObjectFinder update per message, with the camera pose of the
//                   message's keyframe (the CAMERA_POSE of the same seq, else the newest one before it) and the
//                   latest CAMERA_INFO. A message whose seq is below the last one used is rejected; the same seq again
//                   (the pose solver's final map after its global adjustment) is a normal update.
//   CAMERA_POSE     pose_t world_from_camera (mm); the last 64 by seq are kept (a late republication of a seq
//                   replaces it); STATUS_LOST poses are ignored (counted in the status value lost_poses).
//   CAMERA_INFO     camera_info_t: fx, fy, cx, cy, width, height (distortion is ignored: the region is a box outline).
//   ROBOT_ODOMETRY  odometry_t: the robot position for "nearest first" when there is no camera pose yet, and the pan
//                   angle. With a pose, the base is under the pan axis: camera centre minus the camera offset of
//                   common/robot_model.h's RobotGeometry defaults (40 mm forward in the tilt frame; mast offsets 0).
//   OBJSCAN_CONTROL control_t COMMAND_END_OF_STREAM (target "*", "" or the process name): writes
//                   output_dir/target.json (when set), publishes TARGET once more and control_t COMMAND_FINISHED
//                   (sender = name, last_seq / utime = the last map's keyframe, -1 / the message's utime if none);
//                   then Finished() (with exit_when_finished). With a target and final_pose_channel, FINISHED waits
//                   for the pose solver's FINISHED (sender "pose_solver"; at most 120 s, or FINALIZE): target.json
//                   is then rewritten in the final poses' frame (the Sim(3) from the online to the final camera
//                   centres of the frames since the confirmation; kept online, with a warning, when that is not
//                   rigid within 20 mm RMS or fewer than 10 frames have both). With model_channel as well, that
//                   target.json is written at once and FINISHED then waits for the dense modeler's MODEL (at most
//                   600 s, until the dense modeler's FINISHED without it, or FINALIZE): the box is measured again on
//                   the model's voxels (BoxFromModel in object_finder.h; the landmarks' box was 29-47 mm off on mesh
//                   targets whose model was within 1 mm) and target.json rewritten with "box_source": "model"; when
//                   that fails (no model, its file unreadable on this host, too few voxels, a model elsewhere) the
//                   landmarks' box stays ("box_source": "landmarks", "model_box_error": why) with a warning.
//   CAMERA_POSE_FINAL pose_t: the final poses (tracking / relocalized ones), by seq.
//   MODEL           model_t: the dense modeler's final model (voxels_ply_path, voxel_size_mm); the last one kept.
// Outputs:
//   TARGET          target_t after every update (utime/seq of the map's keyframe, frame "world", state, centre,
//                   size, yaw, confidence, roi in that keyframe's image), repeated every target_period_s (stateless).
//                   Nothing is published before the first update.
//   PROCESS_STATUS  values: state (target_t::STATE_*), candidates, clusters, floor_points, update_ms (wall clock),
//                   confirmed_seq (-1 when none), views, landmarks, dropped_landmarks (non-finite, in the last map),
//                   lost_poses.
// State changes are logged in one line each ("candidate at (x, y) mm, 150x120x140 mm, ...", "confirmed at ...",
// "lost ...", "found again ...", "dropped ..."), and the other candidates whenever their set changes.
// Rejections (counted, logged once per reason, never fatal): "landmarks: malformed" (declared array sizes checked
// against the byte count before decoding, common/message_size_check.h), "landmarks: not in world frame",
// "landmarks: array length mismatch", "landmarks: out of order", "landmarks: no camera pose",
// "landmarks: no camera_info", "landmarks: finder error", "pose: malformed" and PoseFromMessage's reasons,
// "pose: not in world frame", "camera_info: malformed" and CameraFromMessage's reasons, "odometry: malformed" and
// OdometryFromMessage's reasons, "control: malformed".
// target.json: {"state": "confirmed", "centre_mm": [x, y, z], "size_mm": [x, y, z], "yaw_rad", "confidence",
// "confirmed_seq", "confirmed_utime", "views", "points", "seq", "utime", "updates", "frame": "world",
// "other_candidates": [{"centre_mm", "size_mm", "points"}], "floor": {"found", "normal": [3], "offset_mm"},
// "box_source": "landmarks" | "model", with "model": "landmarks_centre_mm", "landmarks_size_mm", "model_voxels";
// "model_box_error" when the model was expected but not used}
// (world frame = the pose solver's, as trajectory.txt; zeros when searching; height(p) = normal . p + offset_mm).
// Handlers run inside Bus::Handle() on the caller's thread; not thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/node.h"
#include "common/status.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/model_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/target_t.hpp"
#include "processes/object_finder/object_finder.h"

namespace objscan {

class Bus;
class OptionParser;

struct ObjectFinderNodeOptions {
  std::string name = "object_finder";               // process name (status name, control sender)
  std::string landmarks_channel = "LANDMARKS";      // input sparse map (landmarks_t)
  std::string pose_channel = "CAMERA_POSE";         // input camera poses (pose_t)
  std::string info_channel = "CAMERA_INFO";         // input intrinsics (camera_info_t)
  std::string odometry_channel = "ROBOT_ODOMETRY";  // input odometry (odometry_t); "" = none
  std::string target_channel = "TARGET";            // output (target_t)
  std::string control_channel = "OBJSCAN_CONTROL";  // control_t in/out
  std::string status_channel = "PROCESS_STATUS";    // process status (process_status_t)
  double target_period_s = 1.0;                     // s, the latest TARGET is repeated this often (> 0)
  double status_period_s = 1.0;                     // s, status publication period (> 0)
  bool exit_when_finished = true;                   // Finished() turns true after end of stream was answered
  std::string output_dir;                           // write target.json here at end of stream ("" = none)
  std::string final_pose_channel = "CAMERA_POSE_FINAL";  // input final poses (pose_t): target.json is re-expressed
                                                         // in their frame ("" = keep the online poses' frame)
  std::string model_channel = "MODEL";              // input final model (model_t): target.json's box is measured on
                                                    // its voxels ("" = the landmarks' box, no wait)
  ObjectFinderOptions finder;                       // the finder's options
};

// Registers the options a user sets on the command line (the finder's without prefix, e.g. --target-min-size; the
// rest keep their defaults: code and tests set the struct's fields directly).
void AddObjectFinderNodeOptions(OptionParser& parser, ObjectFinderNodeOptions* options);
bool ValidateObjectFinderNodeOptions(const ObjectFinderNodeOptions& options, std::string* why);

// How target.json's box was measured.
struct BoxSource {
  bool from_model = false;   // the dense model's voxels (else the landmarks')
  TargetBox landmarks_box;   // with from_model: the landmarks' box it replaced
  int model_voxels = 0;      // with from_model: voxels in the boxed part of the model
  std::string model_error;   // the model was expected but not used: why ("" otherwise)
};

// target.json text for a result (see above). updates: updates so far.
std::string TargetJson(const FinderResult& result, int updates, const BoxSource& source = {});

class ObjectFinderNode : public Node {
 public:
  // Subscribes on bus (which must outlive the node). Throws std::invalid_argument on invalid options.
  ObjectFinderNode(Bus& bus, const ObjectFinderNodeOptions& options);

  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_ && options_.exit_when_finished; }
  void OnShutdown() override;

  const StatusReporter& status() const { return status_; }
  const ObjectFinder& finder() const { return finder_; }
  bool end_of_stream_answered() const { return finished_; }

 private:
  void OnLandmarks(const landmarks_t& msg);
  void OnPose(const pose_t& msg);
  void OnCameraInfo(const camera_info_t& msg);
  void OnOdometry(const odometry_t& msg);
  void OnControl(const control_t& msg);
  void OnFinalPose(const pose_t& msg);
  void OnModel(const model_t& msg);
  // Carries the result into the final poses' frame (when they came) and writes target.json; then waits for the
  // model (model_channel) or completes at once.
  void FinishTarget(const std::string& why);
  // Measures the box on the model when one came (why: why there is none otherwise), writes target.json, publishes
  // TARGET and FINISHED: the end.
  void CompleteTarget(const std::string& why);
  bool ExpectsModel(const FinderResult& r) const;  // a target, output_dir and model_channel
  void WriteTargetJson(const FinderResult& r, const BoxSource& source);
  bool RobotPosition(Eigen::Vector2d* xy_mm) const;
  void PublishTarget(int64_t wall_utime);
  void LogChanges(const FinderResult& r);
  void SetStatusValues(const FinderResult& r, double update_ms, int landmarks);

  Bus& bus_;
  ObjectFinderNodeOptions options_;
  ObjectFinder finder_;
  StatusReporter status_;
  std::map<int64_t, Eigen::Isometry3d> poses_;  // world_from_camera by seq, the last kPoseHistory
  // Camera centres (mm) by seq of the online and the final poses: the Sim(3) between them over the frames since the
  // target was confirmed carries target.json into trajectory.txt's frame (a map restart joined or re-chained in the
  // final phase moves whole stretches: room_07, 117 mm).
  std::map<int64_t, Eigen::Vector3d> online_centres_, final_centres_;
  bool awaiting_final_ = false;      // end of stream answered in part: target.json waits for the final poses
  bool awaiting_model_ = false;      // target.json written in the final poses' frame: waits for MODEL
  int64_t awaiting_since_us_ = 0;    // wall clock
  FinderResult final_result_;        // the result in the final poses' frame (while awaiting_model_)
  bool have_model_ = false;          // a MODEL arrived
  model_t model_;                    // the last MODEL
  int64_t end_utime_ = 0;            // utime of the end-of-stream message
  bool have_camera_ = false;
  PinholeCamera first_camera_;  // the accepted camera_info (a different later one is rejected)
  FinderCamera camera_;
  bool have_odometry_ = false;
  double odometry_x_mm_ = 0, odometry_y_mm_ = 0, odometry_pan_rad_ = 0;
  int64_t last_landmarks_seq_ = -1;
  int64_t lost_poses_ = 0;
  bool have_target_ = false;
  target_t target_;                  // the latest TARGET
  int64_t target_published_us_ = 0;  // wall clock of its last publication
  TargetState logged_state_ = TargetState::kSearching;
  int64_t searching_updates_ = 0;  // updates while searching (the rejected clusters are logged every 20)
  int64_t candidate_updates_ = 0;  // updates with a candidate (what its confirmation lacks is logged every 10)
  int logged_track_ = -1;
  std::vector<int> logged_others_;
  bool logged_floor_ = false;
  bool logged_dropped_landmarks_ = false;
  bool finished_ = false;
};

}  // namespace objscan
