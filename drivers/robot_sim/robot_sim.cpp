#include "drivers/robot_sim/robot_sim.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace objscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

double WrapAngle(double a) {
  a = std::fmod(a + kPi, 2 * kPi);
  if (a < 0) a += 2 * kPi;
  return a - kPi;
}

bool Finite(double v) { return std::isfinite(v); }

}  // namespace

bool ValidateRobotSimOptions(const RobotSimOptions& o, std::string* why) {
  auto fail = [why](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  if (o.mode != "orbit" && o.mode != "command") return fail("--mode must be orbit or command");
  if (o.frames < 0) return fail("--frames must be >= 0");
  if (o.mode == "orbit" && o.frames < 1) return fail("--frames must be >= 1 in orbit mode");
  if (!Finite(o.rate_hz) || o.rate_hz <= 0 || o.rate_hz > 10000) return fail("--rate must be in (0, 10000] Hz");
  if (!Finite(o.orbit_radius_mm) || o.orbit_radius_mm <= 0) return fail("--orbit-radius must be > 0 mm");
  if (!o.orbit_center_mm.allFinite() || !o.look_at_mm.allFinite()) return fail("orbit centre / look-at not finite");
  if (!Finite(o.orbit_degrees) || std::abs(o.orbit_degrees) > 3600) return fail("--orbit-degrees must be in +-3600");
  if (!Finite(o.orbit_start_deg)) return fail("orbit_start_deg must be finite");
  std::string geometry_why;
  if (!o.geometry.IsValid(&geometry_why)) return fail(geometry_why);
  const OdometryErrorModel& e = o.errors;
  if (!Finite(e.scale_error) || std::abs(e.scale_error) >= 0.5)
    return fail("odometry scale error must be in (-0.5, 0.5)");
  if (!Finite(e.yaw_scale_error) || std::abs(e.yaw_scale_error) >= 0.5)
    return fail("odometry yaw scale error must be in (-0.5, 0.5)");
  if (!Finite(e.heading_drift_rad_per_mm) || !Finite(e.pan_bias_rad) || !Finite(e.tilt_bias_rad))
    return fail("odometry drift / bias must be finite");
  if (!Finite(e.distance_noise) || e.distance_noise < 0 || !Finite(e.heading_noise_rad_per_sqrt_m) ||
      e.heading_noise_rad_per_sqrt_m < 0 || !Finite(e.head_noise_rad) || e.head_noise_rad < 0)
    return fail("odometry noise levels must be >= 0");
  if (o.odometry_origin != "start" && o.odometry_origin != "world")
    return fail("odometry_origin must be start or world");
  if (!Finite(o.max_speed_mm_s) || o.max_speed_mm_s <= 0 || !Finite(o.max_omega_rad_s) || o.max_omega_rad_s <= 0 ||
      !Finite(o.max_head_rate_rad_s) || o.max_head_rate_rad_s <= 0)
    return fail("speed limits must be > 0");
  if (!Finite(o.goal_tolerance_mm) || o.goal_tolerance_mm <= 0 || !Finite(o.goal_heading_gain) ||
      o.goal_heading_gain <= 0)
    return fail("goal tolerance and gain must be > 0");
  if (o.command_timeout_us < 0) return fail("command_timeout_us must be >= 0");
  if (!Finite(o.footprint_radius_mm) || o.footprint_radius_mm <= 0 || o.footprint_radius_mm > 5000)
    return fail("the footprint radius (robot.cfg's footprint_radius_mm) must be in (0, 5000] mm");
  return true;
}

namespace {

const RobotSimOptions& Validated(const RobotSimOptions& options) {
  std::string why;
  if (!ValidateRobotSimOptions(options, &why)) throw std::invalid_argument(why);
  return options;
}

}  // namespace

RobotSimulator::RobotSimulator(const Scene& scene, const RobotSimOptions& options)
    : options_(Validated(options)), footprint_(scene, options.footprint_radius_mm), rng_(MixSeed(options.seed, 0x0d0)) {
  const Eigen::Vector3d target = scene.target_index >= 0 ? scene.TargetCenter() : Eigen::Vector3d::Zero();
  orbit_center_ = options_.orbit_center_auto ? Eigen::Vector2d(target.x(), target.y()) : options_.orbit_center_mm;
  look_at_ = options_.look_at_auto ? target : options_.look_at_mm;
  if (options_.mode == "command" && scene.has_robot_start) {
    const RobotStart& start = scene.robot_start;
    state_ = RobotState();
    state_.x_mm = start.x_mm;
    state_.y_mm = start.y_mm;
    state_.theta_rad = start.theta_rad;
    state_.pan_rad = start.pan_rad;
    state_.tilt_rad = start.tilt_rad;
    start_state_ = state_;
  } else {
    start_state_ = OrbitState(0);
    state_ = start_state_;
    state_.v_mm_s = state_.omega_rad_s = state_.pan_rate_rad_s = state_.tilt_rate_rad_s = 0;
  }
  if (options_.odometry_origin == "world") {
    odo_x_ = start_state_.x_mm;
    odo_y_ = start_state_.y_mm;
    odo_theta_ = start_state_.theta_rad;
  }
}

int64_t RobotSimulator::UtimeOf(int64_t seq) const {
  return std::llround(static_cast<double>(seq) * 1e6 / options_.rate_hz);
}

bool RobotSimulator::Done() const { return options_.frames > 0 && next_seq_ >= options_.frames; }

RobotState RobotSimulator::OrbitState(int64_t seq) const {
  const double sweep = options_.orbit_degrees * kPi / 180.0;
  const double frames = static_cast<double>(std::max<int64_t>(1, options_.frames));
  const double start = options_.orbit_start_deg * kPi / 180.0;
  const double r = options_.orbit_radius_mm;
  const double direction = sweep >= 0 ? 1.0 : -1.0;
  auto pose_at = [&](double s, RobotState* st) {
    const double a = start + sweep * s / frames;
    st->x_mm = orbit_center_.x() + r * std::cos(a);
    st->y_mm = orbit_center_.y() + r * std::sin(a);
    st->theta_rad = WrapAngle(a + direction * kPi / 2);
    AimHead(options_.geometry, st->x_mm, st->y_mm, st->theta_rad, look_at_, &st->pan_rad, &st->tilt_rad);
  };
  RobotState state, before, after;
  pose_at(static_cast<double>(seq), &state);
  pose_at(static_cast<double>(seq) - 1, &before);
  pose_at(static_cast<double>(seq) + 1, &after);
  const double omega = sweep / frames * options_.rate_hz;  // rad/s of the orbit = yaw rate
  state.omega_rad_s = omega;
  state.v_mm_s = r * std::abs(omega);
  state.pan_rate_rad_s = WrapAngle(after.pan_rad - before.pan_rad) * options_.rate_hz / 2;
  state.tilt_rate_rad_s = (after.tilt_rad - before.tilt_rad) * options_.rate_hz / 2;
  return state;
}

void RobotSimulator::SetCommand(const SimCommand& command, int64_t receive_utime) {
  command_ = command;
  command_utime_ = receive_utime;
  has_command_ = true;
}

void RobotSimulator::AdvanceCommand(double dt) {
  const int64_t now = UtimeOf(next_seq_);
  double v = 0, omega = 0;
  const bool timed_out =
      has_command_ && options_.command_timeout_us > 0 && now - command_utime_ > options_.command_timeout_us;
  if (has_command_ && !timed_out) {
    if (command_.mode == SimCommand::kVelocity) {
      v = command_.v_mm_s;
      omega = command_.omega_rad_s;
    } else if (command_.mode == SimCommand::kGoal) {
      // Drive to the goal with the robot's own belief (odometry), like a real robot.
      const double dx = command_.goal_x_mm - odo_x_, dy = command_.goal_y_mm - odo_y_;
      const double dist = std::hypot(dx, dy);
      double heading_error;
      if (dist > options_.goal_tolerance_mm) {
        heading_error = WrapAngle(std::atan2(dy, dx) - odo_theta_);
        if (std::abs(heading_error) < 0.3) v = std::min(options_.max_speed_mm_s, 1.5 * dist);
      } else {
        heading_error = WrapAngle(command_.goal_theta_rad - odo_theta_);
        if (std::abs(heading_error) < 0.005) heading_error = 0;
      }
      omega = options_.goal_heading_gain * heading_error;
      if (std::abs(omega * dt) > std::abs(heading_error)) omega = heading_error / dt;
    }
  }
  v = std::clamp(std::isfinite(v) ? v : 0.0, -options_.max_speed_mm_s, options_.max_speed_mm_s);
  omega = std::clamp(std::isfinite(omega) ? omega : 0.0, -options_.max_omega_rad_s, options_.max_omega_rad_s);
  RobotState next = state_;
  if (std::abs(omega) < 1e-12) {
    next.x_mm += v * dt * std::cos(state_.theta_rad);
    next.y_mm += v * dt * std::sin(state_.theta_rad);
  } else {
    next.x_mm += v / omega * (std::sin(state_.theta_rad + omega * dt) - std::sin(state_.theta_rad));
    next.y_mm -= v / omega * (std::cos(state_.theta_rad + omega * dt) - std::cos(state_.theta_rad));
  }
  next.theta_rad = WrapAngle(state_.theta_rad + omega * dt);
  next.v_mm_s = v;
  next.omega_rad_s = omega;
  // Collisions: a step into an object's footprint is not applied; the base still turns in place.
  pending_object_ = -1;
  pending_contact_ = ContactCounter::Frame::kIdle;
  if (std::abs(v * dt) > 1e-9) {
    if (footprint_.StepBlocked(state_.x_mm, state_.y_mm, state_.theta_rad, v * dt, omega * dt, &pending_object_)) {
      next.x_mm = state_.x_mm;
      next.y_mm = state_.y_mm;
      next.v_mm_s = 0;
      pending_contact_ = ContactCounter::Frame::kBlocked;
    } else {
      pending_contact_ = ContactCounter::Frame::kFree;
    }
  }
  next.pan_rate_rad_s = next.tilt_rate_rad_s = 0;
  if (has_command_ && command_.has_pan_tilt && std::isfinite(command_.pan_rad) && std::isfinite(command_.tilt_rad)) {
    // The head servos its measured angle (true + bias) to the command.
    const double max_step = options_.max_head_rate_rad_s * dt;
    const double pan_goal = command_.pan_rad - options_.errors.pan_bias_rad;
    const double tilt_goal = command_.tilt_rad - options_.errors.tilt_bias_rad;
    const double pan_step = std::clamp(WrapAngle(pan_goal - state_.pan_rad), -max_step, max_step);
    const double tilt_step = std::clamp(tilt_goal - state_.tilt_rad, -max_step, max_step);
    next.pan_rad = WrapAngle(state_.pan_rad + pan_step);
    next.tilt_rad = state_.tilt_rad + tilt_step;
    next.pan_rate_rad_s = pan_step / dt;
    next.tilt_rate_rad_s = tilt_step / dt;
  }
  state_ = next;
}

void RobotSimulator::UpdateOdometry(const RobotState& previous, const RobotState& current) {
  const double c = std::cos(previous.theta_rad), s = std::sin(previous.theta_rad);
  const double wx = current.x_mm - previous.x_mm, wy = current.y_mm - previous.y_mm;
  const double forward = c * wx + s * wy;
  const double chord = std::hypot(wx, wy);
  const double dtheta = WrapAngle(current.theta_rad - previous.theta_rad);
  double distance = chord;
  if (std::abs(dtheta) > 1e-9) distance = chord * (dtheta / 2) / std::sin(dtheta / 2);
  if (forward < 0) distance = -distance;
  const OdometryErrorModel& e = options_.errors;
  const double noise_d = rng_.Gaussian(), noise_theta = rng_.Gaussian();
  const double d_meas = distance * (1 + e.scale_error) + noise_d * e.distance_noise * std::abs(distance);
  const double theta_meas = dtheta * (1 + e.yaw_scale_error) + e.heading_drift_rad_per_mm * std::abs(distance) +
                            noise_theta * e.heading_noise_rad_per_sqrt_m * std::sqrt(std::abs(distance) / 1000.0);
  // exact for a constant-curvature arc: chord = d * sin(dtheta/2) / (dtheta/2) along the mean heading
  const double half = theta_meas / 2;
  const double chord_meas = std::abs(half) > 1e-9 ? d_meas * std::sin(half) / half : d_meas;
  odo_x_ += chord_meas * std::cos(odo_theta_ + half);
  odo_y_ += chord_meas * std::sin(odo_theta_ + half);
  odo_theta_ = WrapAngle(odo_theta_ + theta_meas);
}

SimFrame RobotSimulator::Step() {
  SimFrame frame;
  frame.seq = next_seq_;
  frame.utime = UtimeOf(next_seq_);
  frame.truth = options_.mode == "orbit" ? OrbitState(next_seq_) : state_;
  ContactCounter::Frame contact = pending_contact_;
  frame.collision_object = pending_object_;
  if (options_.mode == "orbit") {
    const bool overlaps =
        footprint_.Overlaps(Eigen::Vector2d(frame.truth.x_mm, frame.truth.y_mm), &frame.collision_object);
    contact = overlaps ? ContactCounter::Frame::kBlocked : ContactCounter::Frame::kFree;
  }
  frame.blocked = contact == ContactCounter::Frame::kBlocked;
  if (!frame.blocked) frame.collision_object = -1;
  frame.new_collision = contacts_.Record(contact);
  if (has_previous_) {
    path_length_mm_ += std::hypot(frame.truth.x_mm - previous_truth_.x_mm, frame.truth.y_mm - previous_truth_.y_mm);
    UpdateOdometry(previous_truth_, frame.truth);
  }
  previous_truth_ = frame.truth;
  has_previous_ = true;
  const RobotState& t = frame.truth;
  frame.world_from_camera = WorldFromCamera(options_.geometry, t.x_mm, t.y_mm, t.theta_rad, t.pan_rad, t.tilt_rad);
  const OdometryErrorModel& e = options_.errors;
  OdometryReading& odo = frame.odometry;
  odo.utime = frame.utime + e.sync_offset_us;
  odo.seq = frame.seq;
  odo.x_mm = odo_x_;
  odo.y_mm = odo_y_;
  odo.theta_rad = odo_theta_;
  const double noise_pan = rng_.Gaussian(), noise_tilt = rng_.Gaussian();
  odo.pan_rad = WrapAngle(t.pan_rad + e.pan_bias_rad + noise_pan * e.head_noise_rad);
  odo.tilt_rad = t.tilt_rad + e.tilt_bias_rad + noise_tilt * e.head_noise_rad;
  odo.v_mm_s = t.v_mm_s * (1 + e.scale_error);
  odo.omega_rad_s = t.omega_rad_s * (1 + e.yaw_scale_error);
  odo.pan_rate_rad_s = t.pan_rate_rad_s;
  odo.tilt_rate_rad_s = t.tilt_rate_rad_s;
  ++next_seq_;
  if (options_.mode == "command") AdvanceCommand(1.0 / options_.rate_hz);
  return frame;
}

}  // namespace objscan
