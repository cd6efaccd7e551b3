// Robot simulation (LCM-free): true motion of a differential-drive robot with a pan-tilt camera (common/robot_model.h)
// in discrete frames at a fixed rate, and the wheel/encoder odometry it would report, with configurable, seeded
// errors. Frame i has seq = i and utime = llround(i * 1e6 / rate).
//
// Modes:
//   orbit    the base drives a circle of radius R around P (tangentially, counter-clockwise for positive degrees),
//            frame i at angle start + degrees * i / frames; the head pans/tilts so that the optical axis passes
//            through the look-at point (default the target's centre). Velocities are those of the circle.
//   command  the robot follows SimCommand's (velocity, goal, head-only, stop); it starts at the scene's `robot`
//            line pose when the scene has one (Scene::robot_start, head at its pan/tilt), else at the orbit's
//            frame-0 pose (head aimed at the look-at point). Goals are in the odometry frame and are driven to with
//            the robot's own (erroneous) odometry, as a real robot would. Speeds and head rates are limited.
//
// Collisions (footprint.h): the base is a circle of footprint_radius_mm. In command mode a base step whose path would
// make it overlap an object's floor footprint is not applied (the heading still turns, the true velocity is 0 and the
// odometry measures no translation); such a frame is "blocked" and an entry into contact is one collision
// (ContactCounter). In orbit mode the motion is never changed, but frames whose footprint overlaps an object are
// counted the same way (a scripted orbit through an object is reported).
//
// Odometry error model (all seeded by `seed`, per frame, in frame order, so the readings never depend on timing):
//   distance   d_meas = d_true * (1 + scale_error) + N(0, (distance_noise * |d_true|)^2)
//   heading    dtheta_meas = dtheta_true * (1 + yaw_scale_error) + heading_drift * |d_true| (rad per mm)
//              + N(0, heading_noise^2 * |d_true| / 1000 mm)
//   integrated as constant-curvature arcs from the robot's start pose (odometry_origin "start": the odometry frame is
//   the robot's start pose, as in odometry_t.lcm; "world": the odometry starts at the true start pose in the world)
//   head       pan_meas = pan + pan_bias + N(0, head_noise^2), tilt likewise (the head servos the *measured* angle
//              to its command, so in command mode the true angle is command - bias)
//   time       the reading is latched with the image but stamped utime + sync_offset (a stamping error)
//   velocities v_meas = v_true * (1 + scale_error), omega_meas = omega_true * (1 + yaw_scale_error); head rates true.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/robot_model.h"
#include "common/sensor_data.h"
#include "drivers/robot_sim/footprint.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {

struct OdometryErrorModel {
  double scale_error = 0.02;      // relative distance error (wheel slip / wheel radius), 0.02 = +2 %
  double yaw_scale_error = 0.01;  // relative error of measured heading changes
  double heading_drift_rad_per_mm = 0.5 * 3.14159265358979323846 / 180.0 / 1000.0;  // rad per mm travelled
  double distance_noise = 0.01;  // std of the per-frame distance noise as a fraction of the step
  double heading_noise_rad_per_sqrt_m = 0.2 * 3.14159265358979323846 / 180.0;  // random walk, rad per sqrt(m)
  double pan_bias_rad = 0.5 * 3.14159265358979323846 / 180.0;                  // rad, constant pan encoder offset
  double tilt_bias_rad = 0.5 * 3.14159265358979323846 / 180.0;                 // rad, constant tilt encoder offset
  double head_noise_rad = 0.05 * 3.14159265358979323846 / 180.0;  // rad, std of white pan/tilt reading noise
  int64_t sync_offset_us = 15000;                                 // µs, odometry utime minus image utime
};

struct RobotState {
  double x_mm = 0, y_mm = 0, theta_rad = 0;  // base pose in the world
  double pan_rad = 0, tilt_rad = 0;          // head joint angles
  double v_mm_s = 0, omega_rad_s = 0;        // base velocities
  double pan_rate_rad_s = 0, tilt_rate_rad_s = 0;
};

struct SimCommand {
  enum Mode { kStop = 0, kVelocity = 1, kGoal = 2, kHeadOnly = 3 };
  Mode mode = kStop;
  double v_mm_s = 0, omega_rad_s = 0;                       // kVelocity
  double goal_x_mm = 0, goal_y_mm = 0, goal_theta_rad = 0;  // kGoal, odometry frame
  bool has_pan_tilt = false;                                // also move the head (any mode)
  double pan_rad = 0, tilt_rad = 0;                         // head targets (measured angles)
};

struct RobotSimOptions {
  std::string mode = "orbit";                                 // orbit or command
  int64_t frames = 200;                                       // frames to simulate (command mode: 0 = no limit)
  double rate_hz = 30;                                        // Hz, frame rate (timestamps)
  double orbit_radius_mm = 800;                               // mm
  bool orbit_center_auto = true;                              // true: P = the target centre projected on the floor
  Eigen::Vector2d orbit_center_mm = Eigen::Vector2d::Zero();  // mm, P when not automatic
  double orbit_degrees = 360;    // deg, angle covered over the frames (negative = clockwise)
  double orbit_start_deg = -90;  // deg, angle of the robot around P at frame 0 (0 = +x side of P)
  bool look_at_auto = true;      // true: aim the camera at the target centre
  Eigen::Vector3d look_at_mm = Eigen::Vector3d::Zero();  // mm, look-at point when not automatic
  RobotGeometry geometry;                                // mast, camera offset, wheel base
  OdometryErrorModel errors;
  std::string odometry_origin = "start";  // start (odometry frame = start pose) or world
  uint64_t seed = 1;                      // odometry error seed
  double max_speed_mm_s = 400;            // command mode limit
  double max_omega_rad_s = 1.5;           // command mode limit
  double max_head_rate_rad_s = 2.0;       // command mode head slew limit
  double goal_tolerance_mm = 10;          // command mode: goal reached within this distance
  double goal_heading_gain = 2.0;         // command mode goal controller: omega = gain * heading error
  int64_t command_timeout_us = 1000000;   // µs of sim time without a command after which the base stops (0 = never)
  double footprint_radius_mm = 200;       // mm, radius of the base's circular footprint (collisions)
};

// False with a reason for invalid options.
bool ValidateRobotSimOptions(const RobotSimOptions& options, std::string* why);

struct SimFrame {
  int64_t seq = 0;
  int64_t utime = 0;                    // µs, image time
  RobotState truth;                     // true state at utime
  Eigen::Isometry3d world_from_camera;  // true camera pose (mm)
  OdometryReading odometry;             // what the robot reports (errors applied)
  // Contact: command mode = the base step into this frame was refused; orbit mode = this frame's footprint
  // overlaps an object.
  bool blocked = false;
  bool new_collision = false;  // this frame starts a collision (contact episode)
  int collision_object = -1;   // Scene object index of the contact (when blocked), else -1
};

class RobotSimulator {
 public:
  // Throws std::invalid_argument for invalid options. Keeps no reference to the scene.
  RobotSimulator(const Scene& scene, const RobotSimOptions& options);

  // True once all frames were produced (never in command mode with frames = 0).
  bool Done() const;
  // Produces frame seq = frames_produced() and advances the simulation by one frame period.
  SimFrame Step();
  int64_t frames_produced() const { return next_seq_; }
  // Command mode: the command that governs the motion after the next Step() (that Step returns the state already
  // reached; the motion to the following frame uses this command). Ignored in orbit mode. receive_utime is the sim
  // time (µs) at which it arrived (for the command timeout).
  void SetCommand(const SimCommand& command, int64_t receive_utime);

  // Contact statistics over the frames produced so far.
  int64_t collisions() const { return contacts_.collisions(); }
  int64_t blocked_frames() const { return contacts_.blocked_frames(); }
  // mm, length of the true base path over the frames produced so far (sum of the frame-to-frame chords).
  double path_length_mm() const { return path_length_mm_; }
  const FootprintChecker& footprint() const { return footprint_; }
  // The true state at frame 0 (command mode: the scene's robot start if any; orbit mode: the orbit's first pose).
  const RobotState& start_state() const { return start_state_; }

  Eigen::Vector2d orbit_center() const { return orbit_center_; }
  Eigen::Vector3d look_at() const { return look_at_; }
  const RobotSimOptions& options() const { return options_; }
  int64_t UtimeOf(int64_t seq) const;


 private:
  RobotState OrbitState(int64_t seq) const;
  void AdvanceCommand(double dt);
  void UpdateOdometry(const RobotState& previous, const RobotState& current);

  RobotSimOptions options_;
  FootprintChecker footprint_;
  ContactCounter contacts_;
  ContactCounter::Frame pending_contact_ = ContactCounter::Frame::kIdle;  // command mode: the step into the next frame
  int pending_object_ = -1;
  double path_length_mm_ = 0;
  RobotState start_state_;
  Eigen::Vector2d orbit_center_;
  Eigen::Vector3d look_at_;
  int64_t next_seq_ = 0;
  RobotState state_;  // command mode: the current true state
  SimCommand command_;
  int64_t command_utime_ = 0;
  bool has_command_ = false;
  RobotState previous_truth_;
  bool has_previous_ = false;
  // odometry integrator (odometry frame)
  double odo_x_ = 0, odo_y_ = 0, odo_theta_ = 0;
  Eigen::Isometry3d world_from_odometry_start_ = Eigen::Isometry3d::Identity();
  SimRng rng_;
};

}  // namespace objscan
