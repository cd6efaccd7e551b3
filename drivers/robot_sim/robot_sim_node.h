// The simulated robot driver node (process "robot_sim"), standing in for the real robot: simulates the robot
// (robot_sim.h) in a scene (scene.h), renders the camera view (renderer.h) and publishes, per frame i and in this
// order:
//   CAMERA_INFO        camera_info_t (ideal pinhole, distortion "none")
//   ROBOT_ODOMETRY     odometry_t with the error model of robot_sim.h (seq = i, utime = image utime + sync offset);
//                      not with --odometry=false (images only)
//   GROUND_TRUTH_POSE  pose_t world_from_camera (mm), STATUS_GROUND_TRUTH, SCALE_TRUE, seq = i (evaluation only)
//   CAMERA_IMAGE       image_t (rgb8 by default; bgr8, gray8 or jpeg), seq = i, utime = llround(i * 1e6 / rate)
// and after the last frame control_t COMMAND_END_OF_STREAM (sender "robot_sim", last_seq) on OBJSCAN_CONTROL.
// PROCESS_STATUS at 1 Hz (values frames_published, render_ms, lockstep_timeouts, commands, collisions,
// blocked_frames).
//
// Driving: the node is a driver, so it publishes from Tick(wall_utime) rather than from message handlers; main runs
// it with RunNode(bus, node) and a 1 ms tick (Handle() waits at most 1 ms, so commands and lockstep messages are
// still dispatched between frames). At most one frame is published per Tick():
//   --realtime (default)   frame i no earlier than start + utime_i of wall time (late frames follow back to back);
//   --realtime=false       as fast as possible;
//   --lockstep-channel CH  frame i+1 (and END_OF_STREAM) only after a message with seq >= i - lockstep_lag arrived
//                          on CH (seq = bytes 16..23 big-endian of the raw message); after --lockstep-timeout-ms it
//                          warns once and goes on (counted in lockstep_timeouts; 0 = wait forever).
// Command mode (--mode command): a ROBOT_COMMAND (robot_command_t) received before frame i is published governs the
// motion from frame i to i+1;
// invalid commands (unknown mode, non-finite values) are rejected and counted. control_t COMMAND_SHUTDOWN for
// "robot_sim" or "*" on OBJSCAN_CONTROL ends the stream early (END_OF_STREAM follows).
// Determinism: messages depend only on the scene, options and seed (and in command mode on the commands received
// before each frame), never on timing, except PROCESS_STATUS.
// Collisions (robot_sim.h, footprint.h): the base is a circle of robot.cfg's footprint_radius_mm; in command mode it stops
// instead of driving into an object or a wall; each new collision is logged (frame, object) and counted.
// --ground-truth-dir DIR writes target_surface.ply, target_mesh.ply, scene.txt at start-up, poses_gt.txt,
// robot_gt.txt per frame and sim_outcome.json at the end of the stream (frames, collisions, blocked_frames,
// path_length_mm of the true base, the target's truth: name, shape, center_mm, size_mm, yaw_rad of its bounding box
// in its own yawed frame, scene.h ObjectBox).
#pragma once

#include <cstdint>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "common/node.h"
#include "common/recorded_run.h"
#include "common/status.h"
#include "drivers/robot_sim/renderer.h"
#include "drivers/robot_sim/robot_sim.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {

class Bus;
class OptionParser;

struct RobotSimNodeOptions {
  std::string scene = std::string(OBJSCAN_ROBOT_SIM_SCENES_DIR) + "/sphere.scene";  // scene file
  std::string mode = "orbit";                                                       // orbit or command
  int64_t frames = 200;  // frames to publish (command mode: 0 = until stopped)
  double rate_hz = 30;   // Hz, frame timestamps (and wall-clock pace with --realtime)
  bool realtime = true;  // publish at the rate in wall time; false = as fast as possible
  int64_t seed = 1;      // seed (>= 0) of the odometry errors and the image noise
  // orbit
  double orbit_radius_mm = 800;  // mm, orbit radius
  std::string orbit_center;      // "x,y" mm; empty = the target centre projected on the floor
  double orbit_degrees = 360;    // deg, angle covered over the frames (negative = clockwise)
  double orbit_start_deg = -90;  // deg, robot's angle around the centre at frame 0
  std::string look_at;           // "x,y,z" mm the camera aims at; empty = the target centre
  // robot geometry (robot_file, when set, replaces these five)
  std::string robot_file;          // robot.cfg (common/recorded_run.h): the robot's geometry; "" = the fields below
  double mast_height_mm = 400;     // mm, pan/tilt axes above the floor
  double mast_offset_x_mm = 0;     // mm, mast forward of the base centre
  double mast_offset_y_mm = 0;     // mm, mast left of the base centre
  double camera_offset_x_mm = 40;  // mm, optical centre in front of the tilt axis
  double wheel_base_mm = 300;      // mm, distance between the wheels
  // camera
  int width = 640;                  // px
  int height = 480;                 // px
  double fx = 800, fy = 800;        // px
  double cx = 319.5, cy = 239.5;    // px
  std::string camera_name = "sim";  // camera_name in image_t / camera_info_t
  double noise_sigma = 2.0;         // grey levels, image noise std per channel
  std::string blank;                // "FIRST,COUNT": frames FIRST..FIRST+COUNT-1 rendered as a uniform grey view
                                    // (lens covered, texture-less wall: a tracking loss test); "" = none
  bool trilinear = false;           // trilinear texture filtering (slower)
  std::string encoding = "rgb8";    // rgb8, bgr8, gray8 or jpeg
  int jpeg_quality = 90;            // 1..100 for jpeg
  // odometry errors
  double odometry_scale_error = 0.02;         // relative distance error (slip), +2 %
  double odometry_yaw_scale_error = 0.01;     // relative error of heading changes
  double heading_drift_deg_per_m = 0.5;       // deg of heading error per metre travelled
  double distance_noise = 0.01;               // per-frame distance noise std, fraction of the step
  double heading_noise_deg_per_sqrt_m = 0.2;  // heading random walk, deg per sqrt(m)
  double pan_bias_deg = 0.5;                  // deg, pan encoder bias
  double tilt_bias_deg = 0.5;                 // deg, tilt encoder bias
  double head_noise_deg = 0.05;               // deg, pan/tilt reading noise std
  double sync_offset_ms = 15;                 // ms, odometry utime minus image utime
  std::string odometry_origin = "start";      // start (odometry frame = start pose, as odometry_t.lcm) or world
  // command mode
  double max_speed_mm_s = 400;       // mm/s
  double max_omega_deg_s = 90;       // deg/s
  double max_head_rate_deg_s = 120;  // deg/s
  int command_timeout_ms = 1000;     // ms of sim time without a command before the base stops (0 = never)
  double footprint_radius_mm = 200;  // mm, radius of the base's circular footprint (collisions)
  // timing
  std::string session_id;          // the session's id stamped on image/info/odometry (hex; "" = a random one)
  std::string lockstep_channel;    // wait for seq >= i - lockstep_lag here before frame i+1 ("" = off)
  int lockstep_lag = 0;            // frames the consumer may lag behind
  int lockstep_timeout_ms = 5000;  // ms, go on after waiting this long (0 = forever)
  // ground truth
  std::string ground_truth_dir;          // write ground-truth files here ("" = off)
  double surface_density_per_mm2 = 1.0;  // points per mm^2 in target_surface.ply
  bool publish_ground_truth = true;      // publish GROUND_TRUTH_POSE
  bool publish_odometry = true;          // publish ROBOT_ODOMETRY (false: images only, as a camera without a robot;
                                         // orbit mode only: the command mode's planner steers by it)
  // channels
  std::string image_channel = "CAMERA_IMAGE";              // image_t out
  std::string info_channel = "CAMERA_INFO";                // camera_info_t out
  std::string odometry_channel = "ROBOT_ODOMETRY";         // odometry_t out
  std::string ground_truth_channel = "GROUND_TRUTH_POSE";  // pose_t out
  std::string command_channel = "ROBOT_COMMAND";           // robot_command_t in (command mode)
  std::string control_channel = "OBJSCAN_CONTROL";         // control_t out (END_OF_STREAM) and in (SHUTDOWN)
  std::string status_channel = "PROCESS_STATUS";           // process_status_t out
  bool exit_when_finished = true;                          // Finished() turns true after END_OF_STREAM
};

// Registers the RobotSimNodeOptions fields a user sets on the command line (--scene, --mode, --frames, --rate,
// --realtime, ...; the rest keep their defaults: code and tests set the struct's fields directly).
void AddRobotSimNodeOptions(OptionParser& parser, RobotSimNodeOptions* options);
// Checks the option values (not the scene file), reading robot_file once. False with *why on the first problem;
// true with the simulation part of the options in *sim_options and the robot's description (robot_file's, with its
// head limits and encoder conventions, else the defaults with the options' geometry, speeds and footprint) in *robot
// (each when not null).
bool ValidateRobotSimNodeOptions(const RobotSimNodeOptions& options, std::string* why,
                                 RobotSimOptions* sim_options = nullptr, RobotDescription* robot = nullptr);
// The simulation part of the node options; robot_file (the parsed options.robot_file, null when none) replaces the
// geometry, speed limits and footprint fields.
RobotSimOptions ToRobotSimOptions(const RobotSimNodeOptions& options, const RobotDescription* robot_file);
PinholeCamera ToCamera(const RobotSimNodeOptions& options);

class RobotSimNode : public Node {
 public:
  static constexpr const char* kProcessName = "robot_sim";

  // Validates the options, loads the scene, writes the start-up ground-truth files. Throws std::invalid_argument on
  // invalid options and std::runtime_error when the scene cannot be loaded or the ground-truth dir not written.
  RobotSimNode(Bus& bus, const RobotSimNodeOptions& options);
  ~RobotSimNode() override;

  // Publishes the next frame when due (see the header comment), END_OF_STREAM at the end, status at 1 Hz.
  void Tick(int64_t wall_utime) override;
  bool Finished() const override { return end_of_stream_sent_ && options_.exit_when_finished; }
  // Publishes END_OF_STREAM if not sent yet (stop signal), so downstream nodes can finish.
  void OnShutdown() override;

  int64_t frames_published() const { return frames_published_; }
  bool end_of_stream_sent() const { return end_of_stream_sent_; }
  int64_t lockstep_timeouts() const { return lockstep_timeouts_; }
  const StatusReporter& status() const { return status_; }
  const Scene& scene() const { return *scene_; }
  const RobotSimulator& simulator() const { return *sim_; }
  // The true state of every published frame (index = seq).
  const std::vector<RobotState>& truth_history() const { return truth_history_; }
  const RobotGeometry& geometry() const { return sim_options_.geometry; }

 private:
  // Writes the start-up ground-truth files in options_.ground_truth_dir (target_surface.ply, target_mesh.ply,
  // scene.txt, robot.cfg) and opens poses_gt.txt / robot_gt.txt with their headers; throws std::runtime_error when
  // a file cannot be written.
  void WriteGroundTruthFiles();
  // Subscribes to ROBOT_COMMAND (command mode), OBJSCAN_CONTROL (SHUTDOWN) and the lock-step channel (when set).
  void SubscribeInputs();
  bool LockstepReady(int64_t wall_utime);
  void PublishFrame();
  void FinishStream();
  void WriteOutcome();
  template <class Msg>
  void Publish(const std::string& channel, Msg msg);  // stamped with session_id_ (StampSession)

  Bus& bus_;
  RobotSimNodeOptions options_;
  RobotSimOptions sim_options_;
  RobotDescription robot_description_;  // written to the ground-truth folder's robot.cfg
  PinholeCamera camera_;
  int8_t encoding_ = 1;
  int64_t blank_first_ = 0, blank_count_ = 0;  // options_.blank: frames rendered grey
  std::unique_ptr<Scene> scene_;
  std::unique_ptr<Renderer> renderer_;
  std::unique_ptr<RobotSimulator> sim_;
  StatusReporter status_;
  RenderOutput render_;
  std::vector<RobotState> truth_history_;
  std::ofstream poses_gt_, robot_gt_;

  bool started_ = false;
  bool stop_requested_ = false;
  int64_t start_wall_ = 0;
  int64_t frames_published_ = 0;
  int64_t last_utime_ = 0;
  bool end_of_stream_sent_ = false;
  int64_t publish_failures_ = 0;
  int64_t session_id_ = 0;  // stamped on what Publish sends
  int64_t commands_ = 0;
  double render_ms_ = 0;
  int64_t lockstep_max_seq_ = -1;
  int64_t lockstep_waiting_for_ = -1;
  int64_t lockstep_wait_start_ = 0;
  int64_t lockstep_released_ = -1;
  int64_t lockstep_timeouts_ = 0;
  bool lockstep_warned_ = false;
};

}  // namespace objscan
