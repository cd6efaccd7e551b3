// PoseSolverNode: the "pose_solver" process. Subscribes FEATURE_TRACKS (feature_tracks_t), CAMERA_INFO
// (camera_info_t) and ROBOT_ODOMETRY (odometry_t); runs the PoseEstimator (pose_estimator.h) and publishes
//   CAMERA_POSE        one pose_t per accepted track frame (world_from_camera, mm; status INITIALIZING while the
//                      preliminary phase runs (pose = odometry's camera pose, or identity without odometry), TRACKING,
//                      LOST (pose = last good pose, num_inliers 0: ignore it), RELOCALIZED; scale_source says what
//                      fixes the metric scale); when the preliminary phase succeeds, the earlier frames of its
//                      window that the new map poses are published again (same seq and utime, late, in frame
//                      order, before the current frame's pose),
//   LANDMARKS          landmarks_t at every keyframe (frame "world", rgb is a constant grey: no images here; after
//                      a restart not joined to the old map only the new map's landmarks, see Landmarks(true)),
//   CAMERA_POSE_FINAL  after the final global BA: one pose_t per frame, in frame order,
//   then final LANDMARKS and control_t COMMAND_FINISHED (sender = name, last_seq = last frame's seq) on
//   OBJSCAN_CONTROL. The final phase runs on control_t COMMAND_FINISHED from sender finish_on_sender ("tracker")
//   with target "*", "" or this name. With output_dir set it writes DIR/trajectory.txt (final, TUM, mm),
//   DIR/trajectory_online.txt (as published; a late republication replaces the first), DIR/landmarks.ply,
//   DIR/colmap/{cameras,images,points3D}.txt.
// Inputs before the first valid CAMERA_INFO: up to pending_tracks_capacity track frames are buffered and processed
// when it arrives; more are rejected. Odometry is interpolated at the frame time (optional: without it the scale
// source is NONE unless the floor/camera height fixes it in 4-DOF mode).
// Rejections (counted in PROCESS_STATUS, never fatal, never reach the map):
//   "tracks: malformed", "tracks: array length mismatch", "tracks: non-finite coordinate", "tracks: duplicate id",
//   "tracks: out of order or repeated", "tracks: implausible seq jump" (common/status.h), "tracks: coordinate outside the image", "tracks: image size differs from
//   camera_info", "tracks: no camera_info (buffer full)", "tracks: no camera_info at end of stream",
//   "tracks: after end of stream", "tracks: estimator error", "camera_info: malformed" + CameraFromMessage reasons,
//   "camera_info: changed" (a different calibration after the first: ignored), "odometry: malformed",
//   "odometry: non-finite value", "odometry: out of order", "control: malformed".
// Status values: frames, keyframes, landmarks, inliers, rms_px, lost_frames, frame_ms, final_ba_ms,
// final_bend_percent (PoseEstimator::final_bend_fraction in %; -1 = not checked) and final_ba_dropped (1: the global
// BA bent a map and the windowed adjustments' poses were kept, with a warning).
// Handlers run inside Bus::Handle() on the caller's thread; the final BA blocks it (about a second for 200 frames).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "common/node.h"
#include "common/status.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/odometry_t.hpp"
#include "processes/pose_solver/output.h"
#include "processes/pose_solver/pose_estimator.h"

namespace objscan {

class Bus;
class OptionParser;

struct PoseSolverNodeOptions {
  std::string name = "pose_solver";                      // process name (status name, control sender)
  std::string tracks_channel = "FEATURE_TRACKS";         // input tracks (feature_tracks_t)
  std::string info_channel = "CAMERA_INFO";              // input calibration (camera_info_t)
  std::string odometry_channel = "ROBOT_ODOMETRY";       // input odometry (odometry_t); "" = none
  std::string pose_channel = "CAMERA_POSE";              // output per-frame poses (pose_t)
  std::string final_pose_channel = "CAMERA_POSE_FINAL";  // output final poses after global BA (pose_t)
  std::string landmarks_channel = "LANDMARKS";           // output landmarks (landmarks_t)
  std::string control_channel = "OBJSCAN_CONTROL";       // control_t in/out
  std::string status_channel = "PROCESS_STATUS";         // process status (process_status_t)
  std::string finish_on_sender = "tracker";              // COMMAND_FINISHED from this sender starts the final phase
  std::string model = "6dof";                            // camera model: "6dof" or "4dof" (robot floor model)
  int pending_tracks_capacity = 30;                      // track frames buffered before the first camera_info (>= 0)
  int tracks_queue_capacity = 200;                       // messages the tracks subscription buffers (>= 1)
  double max_odometry_gap_s = 0.5;                       // s, odometry further than this from a frame is not used
  double status_period_s = 1.0;                          // s, status publication period (> 0)
  bool exit_when_finished = true;                        // Finished() turns true after the final phase
  std::string robot_file;  // robot.cfg (common/recorded_run.h) whose geometry replaces estimator.robot ("" = none)
  std::string output_dir;                                // write trajectory/landmarks/COLMAP files here ("" = none)
  double min_posed_fraction = 0.9;                       // the final phase is STATE_ERROR (the session fails) when
                                                         // fewer than this fraction of the frames got a final pose,
                                                         // [0, 1]; 0 = never
  PoseEstimatorOptions estimator;                        // the estimator's options (model set from `model`)
};

// Registers the options a user sets on the command line (the rest keep their defaults; code and tests set the
// struct's fields directly).
void AddPoseSolverNodeOptions(OptionParser& parser, PoseSolverNodeOptions* options);
bool ValidatePoseSolverNodeOptions(const PoseSolverNodeOptions& options, std::string* why);

class PoseSolverNode : public Node {
 public:
  // Subscribes on bus (which must outlive the node). Throws std::invalid_argument on invalid options.
  PoseSolverNode(Bus& bus, const PoseSolverNodeOptions& options);

  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return finished_ && options_.exit_when_finished; }
  void OnShutdown() override;

  const StatusReporter& status() const { return status_; }
  bool final_phase_done() const { return finished_; }
  const PoseEstimator* estimator() const { return estimator_.get(); }

 private:
  void OnTracks(const feature_tracks_t& msg);
  void OnCameraInfo(const camera_info_t& msg);
  void OnOdometry(const odometry_t& msg);
  void OnControl(const control_t& msg);
  void ProcessFrame(const TrackFrame& frame);
  // current_map_only: PoseEstimator::Landmarks(true) (at keyframes); the final map is published whole.
  void PublishLandmarks(int64_t utime, int64_t seq, bool current_map_only);
  void RunFinalPhase(const control_t& msg);

  Bus& bus_;
  PoseSolverNodeOptions options_;
  StatusReporter status_;
  PinholeCamera camera_;
  bool have_camera_ = false;
  std::unique_ptr<PoseEstimator> estimator_;
  OdometryBuffer odometry_;
  std::deque<TrackFrame> pending_;
  std::vector<CameraPoseEstimate> online_poses_;
  std::unique_ptr<ObservationSpool> spool_;  // with output_dir: every frame's observations, on disk, for the COLMAP
                                             // model written at the end (memory stays flat over a long stream)
  int64_t last_seq_ = -1, last_utime_ = 0;
  int64_t frames_without_map_ = 0;
  bool odometry_seen_ = false;  // an odometry reading was accepted (a robot, not an image folder)  // frames in a row without a map (start or lost)
  int64_t lost_frames_ = 0;
  bool finished_ = false;
};

}  // namespace objscan
