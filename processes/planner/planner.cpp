#include "processes/planner/planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int64_t kSecond = 1000000;  // µs
constexpr double kLookAroundTiltRad = 25 * kDeg;  // the floor from ~0.45 m to beyond the view range
constexpr double kShuttleLegMm = 400;             // mm, one leg of the look-around shuttle
constexpr int kMaxBypassRepeats = 2;               // bypasses to the same goal without orbit progress ...
constexpr double kBypassProgressRad = 10 * kDeg;   // ... (less than this much azimuth) before the arc is given up
constexpr double kShuttleSpeed = 100;             // mm/s
constexpr double kMinTrailMm = 150;               // mm, shortest trail a shuttle runs on
constexpr double kTrailToleranceMm = 60;          // mm, how far off its trail a shuttle may drive unchecked
// Lost pose: after kRelocalizeAfterFrames steps without a pose the base retraces up to kRelocalizeTrailMm of its
// trail, for at most kRelocalizeBudgetS; kPoseBackFrames poses in a row end it.
constexpr int kRelocalizeAfterFrames = 15;
constexpr int kPoseBackFrames = 5;
constexpr double kRelocalizeTrailMm = 400;
constexpr double kRelocalizeBudgetS = 60;
constexpr double kRelocalizeFixationMm = 900;  // mm, distance of the floor point the head fixates meanwhile
constexpr double kStartArcSpeed = 100;          // mm/s
constexpr double kStartArcTurn = 8 * kDeg;      // rad/s: the start span needs rotation as well as translation
constexpr double kFixationMm = 1800;            // mm ahead on the path: the floor point the head fixates
constexpr double kFixationRenewMm = 900;        // mm, a nearer fixation point is replaced   // head up: the floor from ~0.6 m to the view range
constexpr double kLookAheadMm = 1200;           // mm, where the head looks along a path while exploring
constexpr double kGoalToleranceMm = 60;         // mm, a view or orbit point counts as reached
constexpr double kMaxDetourMm = 600;            // mm, largest local detour outward from the orbit circle
constexpr int64_t kReplanUs = 3 * kSecond;      // µs between routine replans
constexpr double kOrbitMappingMm = 1600;         // mm from the target: unknown floor the orbit maps first
constexpr int kMaxOrbitMappings = 6;             // such trips per orbit at most
constexpr double kCameraTurnPerMm = 0.2 * kDeg;  // rad per mm of base travel (see Motion)
constexpr double kStillCameraTurn = 2 * kDeg;    // rad/s the camera may turn without travel
constexpr double kInPlaceSpeedMm = 20;           // mm/s: slower base motion with a turn is a turn in place
// The camera's yaw may swing this far (rad) from where travel last took it (camera_anchor_yaw_), whatever the motion
// but a head-only look-around: beyond, it follows only at the rate travel allows (the pan limit aside: a head at its
// limit is carried by the base, see ReverseTurnAtPanLimit). A camera swept round while the base turns in place sees
// unmapped scene without parallax and loses the pose solver's map (rooms 03 and 04 on 41af2aa: 3 of 3 pose losses
// came 55 deg into such a sweep at 30 deg/s, the pan held while the base turned: a lost-target search, a bypass).
constexpr double kFreeSwing = 15 * kDeg;

// rad/s the camera's yaw may turn for the base's travel at v_mm_s (the budget of the motions that need translation,
// and the rate camera_anchor_yaw_ follows the camera at).
double TravelTurnRate(double v_mm_s) { return kStillCameraTurn + kCameraTurnPerMm * std::abs(v_mm_s); }

std::string Mm(const Eigen::Vector2d& p) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "(%.0f, %.0f) mm", p.x(), p.y());
  return buffer;
}

double Ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

const char* PhaseName(Phase phase) {
  switch (phase) {
    case Phase::kExplore: return "EXPLORE";
    case Phase::kApproach: return "APPROACH";
    case Phase::kOrbit: return "ORBIT";
    case Phase::kNextViews: return "NEXT_VIEWS";
    case Phase::kFinish: return "FINISH";
    case Phase::kNoTarget: return "NO_TARGET";
  }
  return "?";
}

bool ValidatePlannerOptions(const PlannerOptions& o, std::string* why) {
  std::ostringstream e;
  std::string sub;
  if (!o.robot.IsValid(&sub)) e << sub << "; ";
  if (!ValidateOccupancyMapOptions(o.map, &sub)) e << sub << "; ";
  auto positive = [&](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) e << name << " must be > 0; ";
  };
  positive(o.limits.max_speed_mm_s, "max speed");
  positive(o.limits.max_omega_rad_s, "max yaw rate");
  positive(o.limits.max_pan_rad, "pan limit");
  if (!(o.limits.max_tilt_rad > o.limits.min_tilt_rad)) e << "tilt limits: max must be > min; ";
  positive(o.orbit_speed_mm_s, "orbit speed");
  positive(o.explore_speed_mm_s, "explore speed");
  positive(o.capture_speed_mm_s, "capture speed");
  positive(o.tracking_turn_rad_s, "tracking turn rate");
  positive(o.explore_budget_s, "explore budget");
  positive(o.approach_budget_s, "approach budget");
  if (!(o.start_free_mm >= 0) || !std::isfinite(o.start_free_mm)) e << "start free must be >= 0 mm; ";
  positive(o.next_views_budget_s, "next views budget");
  if (!(o.lost_search_s >= 0)) e << "lost search time must be >= 0; ";
  for (double speed : {o.orbit_speed_mm_s, o.explore_speed_mm_s, o.capture_speed_mm_s})
    if (speed > o.limits.max_speed_mm_s) e << "speeds must be <= the max speed; ";
  if (o.tracking_turn_rad_s > o.limits.max_omega_rad_s) e << "tracking turn rate must be <= the max yaw rate; ";
  const double clear = o.map.footprint_radius_mm + o.map.safety_margin_mm;
  if (!(o.orbit_radius_mm > clear) || !std::isfinite(o.orbit_radius_mm))
    e << "orbit radius must be > footprint radius + safety margin; ";
  if (!(o.coverage_target > 0 && o.coverage_target <= 1)) e << "coverage target must be in (0, 1]; ";
  if (!(o.min_coverage >= 0 && o.min_coverage <= 1)) e << "min coverage must be in [0, 1]; ";
  if (o.min_coverage > o.coverage_target) e << "min coverage must be <= the coverage target; ";
  if (o.max_next_views < 0) e << "max next views must be >= 0; ";
  positive(o.coverage.sample_mm, "coverage sample spacing");
  positive(o.coverage.max_range_mm, "coverage range");
  if (!(o.coverage.max_incidence_deg > 0 && o.coverage.max_incidence_deg <= 90))
    e << "max incidence must be in (0, 90] deg; ";
  if (o.coverage.views_needed < 1) e << "views needed must be >= 1; ";
  if (o.next_view.radii_mm.empty()) e << "next-view radii must not be empty; ";
  for (double r : o.next_view.radii_mm)
    if (!(r > o.map.footprint_radius_mm) || !std::isfinite(r)) e << "next-view radii must be > the footprint; ";
  if (!(o.next_view.azimuth_step_deg > 0 && o.next_view.azimuth_step_deg <= 180))
    e << "next-view azimuth step must be in (0, 180] deg; ";
  if (!(o.next_view.capture_arc_deg >= 0 && o.next_view.capture_arc_deg <= 90))
    e << "capture arc must be in [0, 90] deg; ";
  const std::string message = e.str();
  if (message.empty()) return true;
  if (why) *why = message.substr(0, message.size() - 2);
  return false;
}

namespace {
const PlannerOptions& ValidatedOrThrow(const PlannerOptions& o) {
  std::string why;
  if (!ValidatePlannerOptions(o, &why)) throw std::invalid_argument("planner: " + why);
  return o;
}
}  // namespace

Planner::Planner(const PlannerOptions& options)
    : options_(ValidatedOrThrow(options)),
      estimator_(options_.robot),
      map_(options_.map),
      coverage_(options_.coverage) {
  coverage_.SetCamera(camera_);
}

void Planner::SetCamera(const CameraIntrinsics& camera) {
  if (!camera.IsValid()) return;
  camera_ = camera;
  coverage_.SetCamera(camera);
}

bool Planner::AddOdometry(const OdometryReading& reading) {
  if (!estimator_.AddOdometry(reading)) return false;
  if (!head_initialised_) {
    pan_command_ = std::clamp(reading.pan_rad, -options_.limits.max_pan_rad, options_.limits.max_pan_rad);
    tilt_command_ = std::clamp(reading.tilt_rad, options_.limits.min_tilt_rad, options_.limits.max_tilt_rad);
    head_initialised_ = true;
  }
  return true;
}

// Heights for the map are taken above the floor fitted among the landmarks (object_finder's FitFloor), not world z:
// the pose solver's world is the odometry frame at its start, and a floor a few degrees off z = 0 in it makes the
// far floor an obstacle (1 deg at 3 m = 52 mm; room_01's early map was 7.6 deg off).
void Planner::SetLandmarks(const std::vector<MapLandmark>& landmarks) {
  // A set less than half the last one: the pose solver restarted its map without joining it and sends the new one
  // only; what the old one showed standing stays an obstacle, and its floor free but unexplored
  // (OccupancyMap::RememberOldMap).
  constexpr size_t kMinLandmarksForRestart = 200;
  if (last_landmark_count_ >= kMinLandmarksForRestart && 2 * landmarks.size() < last_landmark_count_) {
    map_.RememberOldMap();
    ++map_restarts_;
    last_map_change_us_ = now_;
    Event("the sparse map restarted (" + std::to_string(last_landmark_count_) + " -> " +
          std::to_string(landmarks.size()) +
          " landmarks): its obstacles and free floor are kept until the new map shows otherwise");
  }
  last_landmark_count_ = landmarks.size();
  std::vector<Eigen::Vector3d> points;
  points.reserve(landmarks.size());
  for (const MapLandmark& l : landmarks)
    if (l.position_mm.allFinite()) points.push_back(l.position_mm.cast<double>());
  const FloorFit fit = FitFloor(points, FloorFitOptions{}, have_floor_ ? &floor_ : nullptr);
  if (fit.found) {
    floor_ = fit.plane;
    have_floor_ = true;
  }
  if (!have_floor_) {
    map_.SetLandmarks(landmarks);
    return;
  }
  std::vector<MapLandmark> above_floor = landmarks;
  for (MapLandmark& l : above_floor)
    if (l.position_mm.allFinite()) l.position_mm.z() = static_cast<float>(floor_.Height(l.position_mm.cast<double>()));
  map_.SetLandmarks(above_floor);
}

void Planner::SetVoxels(const VoxelCloud& voxels) { coverage_.SetVoxels(voxels); }

void Planner::SetTarget(const TargetObservation& t) {
  if (!t.centre_mm.allFinite() || !t.size_mm.allFinite() || !std::isfinite(t.yaw_rad)) return;
  const TargetState previous = target_state_;
  target_state_ = t.state;
  const Eigen::Vector2d xy = t.centre_mm.head<2>();
  switch (t.state) {
    case TargetState::kConfirmed:
      if (!confirmed_) {
        confirmed_ = true;
        confirmed_seq_ = t.seq;
        Event("target confirmed at " + Mm(xy) + ", frame " + std::to_string(t.seq));
      }
      target_ = t;
      have_target_position_ = true;
      coverage_.SetTarget({t.centre_mm, t.size_mm, t.yaw_rad});
      break;
    case TargetState::kCandidate:
      if (confirmed_) break;  // the confirmed estimate stays
      if (!have_target_position_ || (target_.centre_mm.head<2>() - xy).norm() > 500) {
        Event("candidate at " + Mm(xy));
        investigate_spots_.clear();
      } else if (previous == TargetState::kSearching && last_map_change_us_ > spots_reset_for_map_change_us_ &&
                 now_ - last_map_change_us_ < 30 * kSecond) {
        // Found again on a new map (once per map change): the places it was looked at from while forgotten, and
        // before on the old map, do not count against it.
        Event("candidate found again at " + Mm(xy) + " after the map changed");
        investigate_spots_.clear();
        spots_reset_for_map_change_us_ = last_map_change_us_;
      }
      target_ = t;
      have_target_position_ = true;
      break;
    case TargetState::kLost:
      if (previous != TargetState::kLost && have_target_position_) Event("target lost (last seen at " + Mm(xy) + ")");
      break;
    case TargetState::kSearching:
      // The finder dropped the target it had confirmed (later views rejected it). After the orbit (NEXT_VIEWS) the
      // object was circled and modeled; a drop then came from the map around it changing (room_08: after an
      // unjoined map restart its cluster merged with the floor, "too large"): the mission ends with that model.
      if (confirmed_ && phase_ == Phase::kNextViews) {
        Event("the finder dropped the confirmed target at " + Mm(target_.centre_mm.head<2>()) +
              " after the orbit: the model built so far is kept");
        EnterPhase(Phase::kFinish, "target dropped after the orbit");
        break;
      }
      // Before: it was not the object.
      if (confirmed_ && !done()) {
        Event("the finder dropped the confirmed target at " + Mm(target_.centre_mm.head<2>()) + ": exploring again");
        confirmed_ = false;
        have_target_position_ = false;
        investigate_spots_.clear();
        follower_.Clear();
        explore_step_ = ExploreStep::kFrontier;
        if (phase_ != Phase::kExplore) EnterPhase(Phase::kExplore, "target dropped");
      }
      break;
  }
}

void Planner::Event(const std::string& text) {
  char when[32];  // data time, so a log line can be matched with the frames
  std::snprintf(when, sizeof(when), "%.1f s: ", now_ * 1e-6);
  events_.push_back(when + text);
}

std::vector<std::string> Planner::TakeEvents() {
  std::vector<std::string> out;
  out.swap(events_);
  return out;
}

// A contact (ContactDetector): what the base touched is not in the landmarks (an untextured object has none:
// room_05's base touched a plain cylinder 6 times, room_02's a plain sphere), so the cells ahead of the footprint
// (behind it when reversing) are marked felt: obstacles for the rest of the mission, which paths and the safety check
// then keep clear of.
void Planner::CheckContact(double dt) {
  if (!have_odometry_base_ || !have_base_) return;
  if (!contact_.Update(commanded_v_mm_s_, base_.theta_rad, odometry_base_.position(), dt, now_)) return;
  const double sign = commanded_v_mm_s_ > 0 ? 1.0 : -1.0;
  const double reach = options_.map.footprint_radius_mm + 0.5 * options_.map.cell_mm;
  const Eigen::Vector2d ahead = sign * Eigen::Vector2d(std::cos(base_.theta_rad), std::sin(base_.theta_rad));
  const Eigen::Vector2d at = base_.position() + reach * ahead;
  // Where on the front the footprint touched is unknown: the arc of +-40 deg ahead (about 300 mm wide) is marked,
  // or the robot slides along and touches the same object a cell further (toy room: 11 contacts with one cell each).
  for (double a = -40 * kDeg; a <= 40 * kDeg + 1e-9; a += 10 * kDeg)
    map_.MarkFelt(base_.position() + reach * (Eigen::Rotation2Dd(a) * ahead));
  ++contacts_;
  char text[200];
  std::snprintf(text, sizeof(text),
                "contact (%s): driven %.0f mm in %.1f s, moved %.0f mm: something the map does not show at (%.0f, "
                "%.0f) mm, marked as an obstacle",
                activity_.c_str(), contact_.expected_mm(), contact_.window_s(), contact_.moved_mm(), at.x(), at.y());
  Event(text);
}

bool Planner::HeldLongerThan(int64_t us) const { return blocked_since_ >= 0 && now_ - blocked_since_ > us; }

bool Planner::Stuck() const {
  const bool held_by_the_map = HeldLongerThan(2 * kSecond);
  const bool not_moving = std::abs(commanded_v_mm_s_) > 20 && now_ - progress_utime_ > 3 * kSecond;
  return held_by_the_map || not_moving;
}

double Planner::PhaseSeconds() const {
  return phases_.empty() ? 0.0 : (now_ - phases_.back().start_utime) * 1e-6;
}

void Planner::EnterPhase(Phase phase, const std::string& why) {
  const Phase from = phase_;
  if (!phases_.empty()) phases_.back().end_utime = now_;
  phases_.push_back({phase, now_, -1});
  if (phase == Phase::kFinish || phase == Phase::kNoTarget) phases_.back().end_utime = now_;
  phase_ = phase;
  last_phase_reason_ = why;
  follower_.Clear();
  approach_exploring_since_ = -1;
  if (phase == Phase::kExplore && from == Phase::kExplore)
    Event(std::string("phase ") + PhaseName(phase) + ": " + why);
  else
    Event(std::string("phase ") + PhaseName(from) + " -> " + PhaseName(phase) + ": " + why);
}

double Planner::orbit_percent() const {
  int n = 0;
  for (uint8_t b : orbit_bins_) n += b;
  return n * 100.0 / static_cast<double>(orbit_bins_.size());
}

PlannerCommand Planner::Step(const CameraPoseEstimate& pose) {
  const auto start = std::chrono::steady_clock::now();
  now_ = pose.utime;
  double dt = 1.0 / 30.0;
  if (last_step_utime_ >= 0 && now_ > last_step_utime_) dt = std::clamp((now_ - last_step_utime_) * 1e-6, 1e-3, 0.2);
  last_step_utime_ = now_;
  ++frames_;
  if (phases_.empty()) EnterPhase(Phase::kExplore, "start");
  const bool used = estimator_.AddCameraPose(pose);
  lost_frames_ = used ? 0 : lost_frames_ + 1;
  tracked_frames_ = used ? tracked_frames_ + 1 : 0;
  if (tracked_frames_ >= kPoseBackFrames) relocalize_gave_up_ = false;
  if (pose.world_from_camera.matrix().allFinite()) camera_pose_ = pose.world_from_camera;
  const BasePose base = estimator_.Estimate();
  if (const OdometryReading* r = estimator_.latest_odometry()) {  // the trail shuttles follow (never jumps)
    odometry_base_ = OdometryPose(*r);
    have_odometry_base_ = true;
    if (odometry_trail_.empty() || (odometry_base_.position() - odometry_trail_.back()).norm() >= 25)
      odometry_trail_.push_back(odometry_base_.position());
    if (odometry_trail_.size() > 400) odometry_trail_.erase(odometry_trail_.begin(), odometry_trail_.begin() + 200);
  }
  if (have_base_) {
    const double moved = (base.position() - base_.position()).norm();
    if (moved < 300) path_length_mm_ += moved;  // a relocalization jump is no travel
    if (path_.empty() || (base.position() - path_.back()).norm() >= 50) path_.push_back(base.position());
  }
  if (!have_base_ || (base.position() - progress_position_).norm() > 30 || std::abs(commanded_v_mm_s_) <= 20) {
    progress_position_ = base.position();
    progress_utime_ = now_;
  }
  base_ = base;
  have_base_ = true;
  if (used) {
    ++views_;
    coverage_.AddView(pose.world_from_camera);
    const Eigen::Isometry3d& c = pose.world_from_camera;
    const double moved = (c.translation() - last_marked_.translation()).norm();
    const double turned = Eigen::AngleAxisd(last_marked_.linear().transpose() * c.linear()).angle();
    if (!marked_once_ || moved >= 50 || turned >= 3 * kDeg) {
      map_.MarkView(c, camera_);
      last_marked_ = c;
      marked_once_ = true;
    }
  }
  map_.MarkFootprint(base_.position());
  CheckContact(dt);
  map_.Update();
  if (confirmed_ && frames_ % 30 == 0) coverage_.Update();  // ~1 Hz for the status
  dt_ = dt;
  Motion motion;
  if (!done() && UpdateRelocalizing()) {
    motion = Relocalize();
  } else switch (phase_) {
    case Phase::kExplore: motion = Explore(); break;
    case Phase::kApproach: motion = Approach(); break;
    case Phase::kOrbit: motion = Orbit(); break;
    case Phase::kNextViews: motion = NextViews(); break;
    default: break;
  }
  PlannerCommand command;
  if (!done()) command = Finalize(motion, dt);
  else activity_ = "stopped";
  last_step_ms_ = Ms(start);
  return command;
}

double Planner::CameraTurnRate(const Motion& motion, double v_mm_s) const {
  const double turn = std::min(options_.tracking_turn_rad_s, options_.limits.max_omega_rad_s);
  if (!motion.camera_turn_needs_translation) return turn;
  return std::min(turn, TravelTurnRate(v_mm_s));
}

void Planner::CameraTurnBounds(const Motion& motion, double v_mm_s, double dt, double* lowest,
                               double* highest) const {
  const double camera_step = CameraTurnRate(motion, v_mm_s) * dt;
  if (motion.head_only_sweep || !camera_anchor_set_) {
    *lowest = -camera_step;
    *highest = camera_step;
    return;
  }
  const double off_anchor = WrapAngle(AnchorFrameHeading() + pan_command_ - camera_anchor_yaw_);
  *lowest = std::max(-camera_step, std::min(0.0, -kFreeSwing - off_anchor));
  *highest = std::min(camera_step, std::max(0.0, kFreeSwing - off_anchor));
}

double Planner::AnchorFrameHeading() const {
  return have_odometry_base_ ? odometry_base_.theta_rad : base_.theta_rad;
}

// A base turning in place with the head at its pan limit takes the camera round with it: a pure rotation at the base's
// rate, which loses the pose solver's map (ten-room run on e1489ea: 7 of 9 pose losses came after 46-54 frames of
// turning in place at 30 deg/s with the pan at -170 deg, each one a map restart). Decided before the safety check and
// the aim, on the aim as seen from the base now: for a base turn t this step, the head moves the camera by at most
// its budget towards the aim (error e, short way round) and must then stand at pan_command + clamp(e) - t; beyond the
// limit it cannot, and the camera is swept by the base. When the other direction sweeps less, the base turns that way
// round (the long way to its heading), as a true turn in place (v = 0: always free for a round base), until the
// motion's own request turns that way, the activity changes, or the forced direction would sweep too.
void Planner::ReverseTurnAtPanLimit(const Motion& motion, double dt, Velocity* v) {
  const RobotLimits& l = options_.limits;
  const bool in_place = std::abs(v->v_mm_s) < kInPlaceSpeedMm && std::abs(v->omega_rad_s) > 1e-6;
  if (!in_place || activity_ != forced_turn_activity_) forced_turn_sign_ = 0;
  if (!in_place) return;
  double aim_pan = motion.pan_rad, aim_tilt = motion.tilt_rad;
  if (motion.aim_at_point) AimHead(options_.robot, base_, motion.aim_point, &aim_pan, &aim_tilt);
  if (!std::isfinite(aim_pan)) return;
  double lowest, highest;
  CameraTurnBounds(motion, 0.0, dt, &lowest, &highest);  // turning in place: no travel
  const double towards_aim = std::clamp(WrapAngle(aim_pan - pan_command_), lowest, highest);
  auto overshoot = [&](double base_turn) {  // rad the head would have to go past its limit (<= 0: none)
    return std::abs(pan_command_ + towards_aim - base_turn) - l.max_pan_rad;
  };
  const double rate = std::abs(v->omega_rad_s);
  if (forced_turn_sign_ != 0) {
    if ((v->omega_rad_s > 0) == (forced_turn_sign_ > 0) || overshoot(forced_turn_sign_ * rate * dt) > 1e-9) {
      forced_turn_sign_ = 0;  // the request turns that way by itself now, or that way sweeps the camera too
    } else {
      *v = Velocity{0.0, forced_turn_sign_ * rate};
      return;
    }
  }
  const double b = v->omega_rad_s * dt;
  if (overshoot(b) > 1e-9 && overshoot(-b) < overshoot(b)) {
    forced_turn_sign_ = v->omega_rad_s > 0 ? -1 : 1;
    forced_turn_activity_ = activity_;
    *v = Velocity{0.0, forced_turn_sign_ * rate};
    ++pan_limit_reversals_;
  }
}

PlannerCommand Planner::Finalize(const Motion& motion, double dt) {
  const RobotLimits& l = options_.limits;
  const double turn = std::min(options_.tracking_turn_rad_s, l.max_omega_rad_s);
  Velocity v = motion.velocity;
  v.v_mm_s = std::clamp(std::isfinite(v.v_mm_s) ? v.v_mm_s : 0.0, -l.max_reverse_mm_s, l.max_speed_mm_s);
  v.omega_rad_s = std::clamp(std::isfinite(v.omega_rad_s) ? v.omega_rad_s : 0.0, -turn, turn);
  if (!camera_anchor_set_ || camera_anchor_by_odometry_ != have_odometry_base_) {  // first command, or new frame
    camera_anchor_yaw_ = WrapAngle(AnchorFrameHeading() + pan_command_);
    camera_anchor_by_odometry_ = have_odometry_base_;
    camera_anchor_set_ = true;
  }
  ReverseTurnAtPanLimit(motion, dt, &v);
  bool limited = false;
  const bool wants_to_move = std::abs(v.v_mm_s) > 1;
  // The trail is where the base has been, so the map may hold it back there (a wall drawn too near); not into a cell
  // it has felt (contact) within half a second's drive (the toy room: a look-around shuttle pushed into a felt box on
  // its trail once a second for 9 s).
  const bool on_trail = motion.trail != nullptr && wants_to_move && have_odometry_base_ &&
                        StaysOnTrail(*motion.trail, odometry_base_, v, 0.5, kTrailToleranceMm) &&
                        !map_.FeltWithin(Integrate(base_, v, 0.5).position(),
                                         options_.map.footprint_radius_mm + options_.map.cell_mm);
  if (!on_trail) v = SafeVelocity(map_, base_, v, 0.5, &limited);
  if (limited) ++safety_stops_;
  if (wants_to_move && v.v_mm_s == 0) {
    if (blocked_since_ < 0) blocked_since_ = now_;
  } else {
    blocked_since_ = -1;
  }
  double pan = motion.pan_rad, tilt = motion.tilt_rad;
  if (motion.aim_at_point) AimHead(options_.robot, Integrate(base_, v, dt), motion.aim_point, &pan, &tilt);
  if (!std::isfinite(pan) || !std::isfinite(tilt)) {
    pan = pan_command_;
    tilt = tilt_command_;
  }
  pan = std::clamp(pan, -l.max_pan_rad, l.max_pan_rad);
  tilt = std::clamp(tilt, l.min_tilt_rad, l.max_tilt_rad);
  // The camera's yaw (base + pan) and the tilt turn at most `turn` rad/s; the yaw within CameraTurnBounds.
  const double step = turn * dt;
  const double base_turn = v.omega_rad_s * dt;
  double lowest, highest;
  CameraTurnBounds(motion, v.v_mm_s, dt, &lowest, &highest);
  const double camera_turn = std::clamp(base_turn + (pan - pan_command_), lowest, highest);
  pan = std::clamp(pan_command_ + camera_turn - base_turn, -l.max_pan_rad, l.max_pan_rad);
  // The anchor follows the camera as travel allows (a head-only sweep takes it along).
  const double follow = motion.head_only_sweep ? M_PI : TravelTurnRate(v.v_mm_s) * dt;
  camera_anchor_yaw_ = WrapAngle(
      camera_anchor_yaw_ +
      std::clamp(WrapAngle(AnchorFrameHeading() + base_turn + pan - camera_anchor_yaw_), -follow, follow));
  tilt = std::clamp(tilt_command_ + std::clamp(tilt - tilt_command_, -step, step), l.min_tilt_rad, l.max_tilt_rad);
  pan_command_ = pan;
  tilt_command_ = tilt;
  commanded_v_mm_s_ = v.v_mm_s;
  PlannerCommand command;
  command.stop = false;
  command.v_mm_s = v.v_mm_s;
  command.omega_rad_s = v.omega_rad_s;
  command.pan_rad = pan;
  command.tilt_rad = tilt;
  return command;
}

Planner::Motion Planner::Hold(const Eigen::Vector3d& point) {
  Motion m;
  m.aim_point = point;
  return m;
}

Planner::Motion Planner::FollowPathLookingAt(const Eigen::Vector3d& point, double speed) {
  Motion m;
  m.velocity = follower_.Follow(map_, base_, speed, options_.tracking_turn_rad_s);
  m.aim_point = point;
  return m;
}

// The head fixates a floor point ahead on the path and keeps it while the robot drives towards it, so the camera
// turns about a point of the scene (what the pose solver's factorization and motion stereo need; a point that moves
// with the robot makes the camera translate along its axis only: 6-DOF ATE 214 mm, scale 0.61 in room_01). A new
// point is taken when the robot comes within kFixationRenewMm of it or it falls more than 60 deg off the heading.
Planner::Motion Planner::LookAhead(const Velocity& v) {
  Motion m;
  m.velocity = v;
  m.camera_turn_needs_translation = true;
  const Eigen::Vector2d offset = fixation_ - base_.position();
  const double off_heading = std::abs(WrapAngle(std::atan2(offset.y(), offset.x()) - base_.theta_rad));
  if (!has_fixation_ || offset.norm() < kFixationRenewMm || off_heading > 60 * kDeg) {
    fixation_ = follower_.PointAhead(base_, kFixationMm);
    has_fixation_ = true;
  }
  m.aim_point = Eigen::Vector3d(fixation_.x(), fixation_.y(), 0);
  return m;
}

// ---------------------------------------------------------------- EXPLORE

Planner::Motion Planner::Explore() {
  if (confirmed_) {
    EnterPhase(Phase::kApproach, "target confirmed at " + Mm(target_.centre_mm.head<2>()));
    return Approach();
  }
  if (PhaseSeconds() >= options_.explore_budget_s) {
    EnterPhase(Phase::kNoTarget, "exploration budget of " + std::to_string(options_.explore_budget_s) +
                                     " s spent, no target found");
    return {};
  }
  const bool candidate = have_target_position_ &&
                         (target_state_ == TargetState::kCandidate || target_state_ == TargetState::kLost);
  if (candidate && explore_step_ != ExploreStep::kInvestigate && investigate_spots_.size() < 4) {
    explore_step_ = ExploreStep::kInvestigate;
    candidate_missing_since_ = -1;
    follower_.Clear();
  }
  switch (explore_step_) {
    case ExploreStep::kStartArc: return StartArc();
    case ExploreStep::kLookAround: return LookAround();
    case ExploreStep::kFrontier: return Frontier();
    case ExploreStep::kInvestigate: return Investigate();
  }
  return {};
}

Planner::Motion Planner::StartArc() {
  activity_ = "start arc";
  if (!start_marked_) {  // the floor ahead of the start, as the operator put the robot down
    start_marked_ = true;
    start_position_ = base_.position();
    BasePose along = base_;  // the footprint swept by the arc
    const Velocity arc{kStartArcSpeed, kStartArcTurn};
    const double step_s = 0.5 * options_.map.cell_mm / kStartArcSpeed;
    for (double d = 0; d <= options_.start_free_mm; d += 0.5 * options_.map.cell_mm) {
      map_.MarkFootprint(along.position());
      along = Integrate(along, arc, step_s);
    }
    map_.Update();
    // The fixated point is where the optical axis meets the floor now (when it does, 0.5-3 m ahead), so the head does
    // not swing at the start: a turn of the head alone, without translation, gave the pose solver a start span of
    // 4 frames on pure rotation in room_03 and a map 1.3 m off.
    const Eigen::Vector2d heading(std::cos(base_.theta_rad), std::sin(base_.theta_rad));
    fixation_ = start_position_ + kFixationMm * heading;
    const Eigen::Vector3d centre = camera_pose_.translation(), axis = camera_pose_.linear().col(2);
    if (axis.z() < -1e-3) {
      const Eigen::Vector3d hit = centre - (centre.z() / axis.z()) * axis;
      const double distance = (hit.head<2>() - start_position_).norm();
      if (distance >= 500 && distance <= 3000) fixation_ = hit.head<2>();
    }
    has_fixation_ = true;
  }
  const double travelled = (base_.position() - start_position_).norm();
  if (travelled >= 0.8 * options_.start_free_mm || PhaseSeconds() > 3 * options_.start_free_mm / kStartArcSpeed ||
      contacts_ > 0) {  // the floor ahead of the start was not free after all
    explore_step_ = ExploreStep::kFrontier;
    return Frontier();
  }
  Motion m;
  m.velocity.v_mm_s = kStartArcSpeed;
  m.velocity.omega_rad_s = kStartArcTurn;
  m.aim_point = Eigen::Vector3d(fixation_.x(), fixation_.y(), 0);
  return m;
}

// Looks around from where the robot stands without turning the camera faster than the base travels (a camera turned
// in place onto unmapped floor loses the pose solver's track): the base shuttles straight back and forth, reversing
// first over the floor it came from, in legs of kShuttleLegMm (a leg also ends when the swept-footprint check holds
// it for a second), while the head sweeps the camera to one pan limit and then to the other at the rate the travel
// allows. A base that can travel neither way (two legs in a row under 30 mm) sweeps with the head alone.
Planner::Motion Planner::LookAround() {
  activity_ = shuttle_stalled_ ? "look around (head only)" : "look around";
  const RobotLimits& l = options_.limits;
  if (!looking_around_) {
    looking_around_ = true;
    ++look_arounds_;
    sweep_target_rad_ = pan_command_ >= 0 ? l.max_pan_rad : -l.max_pan_rad;
    sweep_ends_reached_ = 0;
    shuttle_direction_ = -1;
    shuttle_leg_start_ = base_.position();
    shuttle_leg_start_us_ = now_;
    shuttle_short_legs_ = 0;
    shuttle_stalled_ = false;
    follower_.Clear();
    if (!StartShuttle(&look_shuttle_, kShuttleLegMm)) look_shuttle_ = TrailShuttle{};
  }
  if (std::abs(pan_command_ - sweep_target_rad_) < 2 * kDeg) {
    sweep_target_rad_ = -sweep_target_rad_;
    if (++sweep_ends_reached_ >= 2) {
      looking_around_ = false;
      explore_step_ = ExploreStep::kFrontier;
      next_replan_ = now_;
      return Frontier();
    }
  }
  const bool held = HeldLongerThan(kSecond);
  if (!look_shuttle_.back.empty()) {  // legs on the trail: the floor the robot came over
    Motion m;
    m.velocity = ShuttleStep(&look_shuttle_, held, &m.trail);
    m.camera_turn_needs_translation = true;
    m.aim_at_point = false;
    m.pan_rad = sweep_target_rad_;
    m.tilt_rad = kLookAroundTiltRad;
    return m;
  }
  const double travelled = (base_.position() - shuttle_leg_start_).norm();
  if (!shuttle_stalled_ && (travelled >= kShuttleLegMm || held)) {
    shuttle_short_legs_ = travelled < 30 ? shuttle_short_legs_ + 1 : 0;
    shuttle_stalled_ = shuttle_short_legs_ >= 2;
    shuttle_direction_ = -shuttle_direction_;
    shuttle_leg_start_ = base_.position();
    shuttle_leg_start_us_ = now_;
    blocked_since_ = -1;
  }
  Motion m;
  if (!shuttle_stalled_) m.velocity.v_mm_s = shuttle_direction_ * std::min(kShuttleSpeed, l.max_reverse_mm_s);
  m.camera_turn_needs_translation = !shuttle_stalled_;
  m.head_only_sweep = shuttle_stalled_;
  m.aim_at_point = false;
  m.pan_rad = sweep_target_rad_;
  m.tilt_rad = kLookAroundTiltRad;
  return m;
}

bool Planner::StartShuttle(TrailShuttle* shuttle, double length_mm) {
  if (!have_odometry_base_) {
    *shuttle = TrailShuttle{};
    return false;
  }
  shuttle->back = TrailBack(odometry_trail_, odometry_base_.position(), length_mm, kMinTrailMm);
  shuttle->forth.assign(shuttle->back.rbegin(), shuttle->back.rend());
  shuttle->outbound = false;
  NextShuttleLeg(shuttle);
  return !shuttle->back.empty();
}

void Planner::NextShuttleLeg(TrailShuttle* shuttle) {
  shuttle->outbound = !shuttle->outbound;
  shuttle->leg_start_us = now_;
  blocked_since_ = -1;
  const std::vector<Eigen::Vector2d>& trail = shuttle->outbound ? shuttle->back : shuttle->forth;
  if (trail.empty()) return;
  // The way the trail leads from here: its point ~100 mm on (or its end).
  Eigen::Vector2d ahead = trail.back();
  for (const Eigen::Vector2d& p : trail)
    if ((p - odometry_base_.position()).norm() >= 100) {
      ahead = p;
      break;
    }
  const double bearing = std::atan2(ahead.y() - odometry_base_.y_mm, ahead.x() - odometry_base_.x_mm);
  shuttle->backing = std::abs(WrapAngle(bearing - odometry_base_.theta_rad)) > M_PI / 2;
}

Velocity Planner::ShuttleStep(TrailShuttle* shuttle, bool held, const std::vector<Eigen::Vector2d>** trail) {
  const double speed = std::min(kShuttleSpeed, options_.limits.max_reverse_mm_s);
  const int64_t leg_limit_us = static_cast<int64_t>((2 * PathLength(shuttle->back) / speed + 5) * kSecond);
  Velocity v;
  for (int attempt = 0; attempt < 2; ++attempt) {  // the next leg at once when this one is done
    bool reached = false;
    v = FollowTrail(odometry_base_, shuttle->outbound ? shuttle->back : shuttle->forth, shuttle->backing, speed,
                    options_.tracking_turn_rad_s, &reached);
    if (!reached && !held && now_ - shuttle->leg_start_us <= leg_limit_us) break;
    NextShuttleLeg(shuttle);
    held = false;
  }
  *trail = shuttle->outbound ? &shuttle->back : &shuttle->forth;
  return v;
}

// ---------------------------------------------------------------- LOST POSE

// Without a pose (tracking lost, the pose solver waiting for a new map) the base retraces its own trail back and
// forth (floor it drove over: free whatever the map says) while the head fixates one floor point to the side, so
// the camera translates and turns about a point of the scene: the span a new map needs (>= 50 mm of travel and
// >= 8 deg of rotation without a standstill); turning in place or sweeping the head gives neither (room_07: lost in
// a head-only look-around, no new map in 1 420 frames). It ends when poses are back (kPoseBackFrames in a row), or
// after kRelocalizeBudgetS: then the phase goes on by odometry until the pose is back. Not before the first pose,
// nor without kMinTrailMm of trail behind the robot.
bool Planner::UpdateRelocalizing() {
  char text[200];
  if (relocalizing_) {
    const double seconds = (now_ - relocalize_start_us_) * 1e-6;
    if (tracked_frames_ >= kPoseBackFrames) {
      relocalizing_ = false;
      last_map_change_us_ = now_;
      std::snprintf(text, sizeof(text), "pose back after %.1f s retracing the trail", seconds);
      Event(text);
      follower_.Clear();
      next_replan_ = now_;
      return false;
    }
    if (seconds > kRelocalizeBudgetS) {
      relocalizing_ = false;
      relocalize_gave_up_ = true;
      std::snprintf(text, sizeof(text),
                    "no pose after %.0f s retracing the trail: going on by odometry (the pose solver's log says what "
                    "its new map waits for)",
                    seconds);
      Event(text);
      follower_.Clear();
      return false;
    }
    return true;
  }
  if (relocalize_gave_up_ || views_ == 0 || lost_frames_ < kRelocalizeAfterFrames) return false;
  if (!StartShuttle(&relocalize_shuttle_, kRelocalizeTrailMm)) return false;
  relocalizing_ = true;
  relocalize_start_us_ = now_;
  ++relocalizations_;
  // The fixated point: 60 deg to the side with more room around it (a wall close by fills the view).
  double best = -1;
  for (int side : {1, -1}) {
    const double a = base_.theta_rad + side * 60 * kDeg;
    const Eigen::Vector2d p = base_.position() + kRelocalizeFixationMm * Eigen::Vector2d(std::cos(a), std::sin(a));
    int index;
    const double clearance = map_.IndexOf(p, &index) ? map_.ObstacleDistanceMm(index) : 0;
    if (clearance > best) {
      best = clearance;
      relocalize_fixation_ = p;
    }
  }
  std::snprintf(text, sizeof(text), "pose lost for %d frames: retracing %.0f mm of the trail for a new map",
                lost_frames_, PathLength(relocalize_shuttle_.back));
  Event(text);
  follower_.Clear();
  return true;
}

Planner::Motion Planner::Relocalize() {
  activity_ = "relocalize: retracing the trail";
  Motion m;
  m.velocity = ShuttleStep(&relocalize_shuttle_, HeldLongerThan(kSecond), &m.trail);
  m.aim_point = Eigen::Vector3d(relocalize_fixation_.x(), relocalize_fixation_.y(), 0);
  m.camera_turn_needs_translation = true;
  return m;
}

bool Planner::ChooseFrontier(const Eigen::Vector2d* near, double within_mm) {
  cost_field_.Compute(map_, base_.position());
  const double frontier_distance = options_.map.footprint_radius_mm + 2 * options_.map.cell_mm;
  const Eigen::Vector2d current_goal = follower_.empty() ? Eigen::Vector2d(1e12, 1e12) : follower_.goal();
  int best = -1;
  double best_score = 0;
  reachable_cells_ = 0;
  frontier_cells_near_visited_ = 0;
  for (int i = 0; i < map_.num_cells(); ++i) {
    if (!cost_field_.Reachable(i)) continue;
    ++reachable_cells_;
    if (!map_.Traversable(i) || map_.UnexploredDistanceMm(i) > frontier_distance) continue;
    if (map_.UnexploredCellsNear(i, 500) < 10) continue;  // a sliver of unexplored floor is not worth the trip
    const Eigen::Vector2d c = map_.CentreOf(i);
    if (near != nullptr && (c - *near).norm() > within_mm) continue;
    const double cost = cost_field_.CostMm(i);
    if (cost < 250) continue;
    bool visited = false;
    for (const Eigen::Vector2d& g : visited_goals_) visited = visited || (g - c).norm() < 500;
    if (visited) {
      ++frontier_cells_near_visited_;
      continue;
    }
    const double turn = std::abs(WrapAngle(std::atan2(c.y() - base_.y_mm, c.x() - base_.x_mm) - base_.theta_rad));
    double score = cost + 300 * turn;
    if ((c - current_goal).norm() < 200) score *= 0.7;  // keep the goal unless another is clearly nearer
    if (best < 0 || score < best_score) {
      best = i;
      best_score = score;
    }
  }
  if (best < 0) return false;
  std::vector<Eigen::Vector2d> path = cost_field_.PathTo(map_, best);
  const double length = PathLength(path);
  follower_.SetPath(std::move(path));
  goal_deadline_ = now_ + static_cast<int64_t>((2 * length / options_.explore_speed_mm_s + 15) * kSecond);
  return true;
}

Planner::Motion Planner::Frontier() {
  activity_ = "frontier";
  bool replan = follower_.empty() || now_ >= next_replan_ || !follower_.StillFree(map_, 1000);
  if (!follower_.empty() && (follower_.Reached(base_, 150) || now_ > goal_deadline_ || Stuck())) {
    blocked_since_ = -1;
    if (follower_.Reached(base_, 150)) look_arounds_ = 0;
    visited_goals_.push_back(follower_.goal());
    follower_.Clear();
    replan = true;
  }
  if (replan) {
    next_replan_ = now_ + kReplanUs;
    // Frontiers left only near goals given up before (a deadline or a stall while the pose was lost, a goal the
    // map restart moved): tried again, up to 3 times and each after 1 m of driving (a look-around at the start
    // spent all three at once in room_07), before the room counts as explored (room_01: "explored" after
    // 3.2 m in a 5.3 x 5.9 m room, with the pose lost and the map restarted on the way).
    bool chosen = ChooseFrontier();
    if (!chosen && frontier_cells_near_visited_ > 0 && visited_goal_resets_ < kMaxVisitedGoalResets &&
        path_length_mm_ >= path_at_visited_goal_reset_ + kVisitedGoalResetPathMm) {
      ++visited_goal_resets_;
      path_at_visited_goal_reset_ = path_length_mm_;
      Event("frontiers left only near " + std::to_string(visited_goals_.size()) +
            " goals given up before: trying them again (" + std::to_string(visited_goal_resets_) + " of " +
            std::to_string(kMaxVisitedGoalResets) + ")");
      visited_goals_.clear();
      chosen = ChooseFrontier();
    }
    if (!chosen) {
      follower_.Clear();
      const double reachable_m2 = reachable_cells_ * options_.map.cell_mm * options_.map.cell_mm * 1e-6;
      if (views_ == 0 || reachable_m2 < 1.0) {  // no map around the robot yet: look around (again)
        char text[160];
        if (look_arounds_ >= 3) {
          std::snprintf(text, sizeof(text),
                        "boxed in: %.2f m2 reachable after %d look-arounds, no target found; try a start with more "
                        "free floor around the robot",
                        reachable_m2, look_arounds_);
          EnterPhase(Phase::kNoTarget, text);
          return {};
        }
        std::snprintf(text, sizeof(text), "nothing reachable to explore yet (%.2f m2 known): looking around",
                      reachable_m2);
        Event(text);
        explore_step_ = ExploreStep::kLookAround;
        return LookAround();
      }
      // A candidate the finder still reports but could not confirm from its 4 places: with the room explored, it
      // is the only lead left, so it gets new rounds of places before the mission gives up.
      const bool candidate = have_target_position_ &&
                             (target_state_ == TargetState::kCandidate || target_state_ == TargetState::kLost);
      if (candidate && candidate_rounds_ < kMaxCandidateRounds) {
        ++candidate_rounds_;
        Event("room explored, the candidate at " + Mm(target_.centre_mm.head<2>()) +
              " not confirmed yet: looking at it again from new places (round " + std::to_string(candidate_rounds_) +
              " of " + std::to_string(kMaxCandidateRounds) + ")");
        investigate_spots_.clear();
        candidate_missing_since_ = -1;
        explore_step_ = ExploreStep::kInvestigate;
        return Investigate();
      }
      EnterPhase(Phase::kNoTarget,
                 candidate ? "room explored (no frontier left), the candidate at " +
                                 Mm(target_.centre_mm.head<2>()) + " never confirmed: no target found"
                           : std::string("room explored (no frontier left), no target found"));
      return {};
    }
  }
  return LookAhead(follower_.Follow(map_, base_, options_.explore_speed_mm_s, options_.tracking_turn_rad_s));
}

Planner::Motion Planner::Investigate() {
  activity_ = "investigate candidate";
  const Eigen::Vector3d centre = TargetCentre();
  if (target_state_ == TargetState::kSearching) {
    // Given up 5 s after the finder stopped reporting it, but not within 20 s of a map restart or a pose lost and
    // back: the finder's clusters were the old map's landmarks, and the new map has points on the object only once
    // it has seen it again (room_10: the target a candidate twice, "gone" at once after each restart, and never
    // found again once the room was explored).
    if (candidate_missing_since_ < 0) candidate_missing_since_ = now_;
    int64_t give_up = candidate_missing_since_ + 5 * kSecond;
    if (last_map_change_us_ >= 0) give_up = std::max(give_up, last_map_change_us_ + 20 * kSecond);
    if (now_ > give_up) {
      Event("candidate gone: exploring again");
      explore_step_ = ExploreStep::kFrontier;
      have_target_position_ = false;
      follower_.Clear();
      return Frontier();
    }
  } else {
    candidate_missing_since_ = -1;
  }
  // Nowhere to look from a moment ago (the floor around unknown, e.g. just after a map restart: the new map's first
  // floor points only): the base shuttles on its own trail with the head on the candidate, so the camera translates
  // and turns about it and the new map gets points on it and on the floor around, before trying again; each such
  // wait counts as one of the places (room_10: without it the 4 places were used up in 0.2 s after a restart).
  if (follower_.empty() && now_ < investigate_hold_until_) {
    if (investigate_shuttle_.back.empty()) return Hold(centre);
    Motion m;
    m.velocity = ShuttleStep(&investigate_shuttle_, HeldLongerThan(kSecond), &m.trail);
    m.aim_point = centre;
    m.camera_turn_needs_translation = true;
    return m;
  }
  const bool reached = !follower_.empty() && follower_.Reached(base_, 150);
  if (reached) investigate_spots_.push_back(follower_.goal());
  if (follower_.empty() || reached || now_ > goal_deadline_ || !follower_.StillFree(map_, 1000) || Stuck()) {
    blocked_since_ = -1;
    if (!follower_.empty() && !reached) investigate_spots_.push_back(follower_.goal());
    follower_.Clear();
    if (investigate_spots_.size() >= 4) {
      Event("candidate not confirmed from 4 places: exploring again");
      explore_step_ = ExploreStep::kFrontier;
      return Frontier();
    }
    cost_field_.Compute(map_, base_.position());
    int best = -1;
    for (int i = 0; i < map_.num_cells(); ++i) {
      if (!cost_field_.Reachable(i) || !map_.Traversable(i)) continue;
      const Eigen::Vector2d c = map_.CentreOf(i);
      const double d = (c - centre.head<2>()).norm();
      if (d < 900 || d > 1500 || (c - base_.position()).norm() < 300) continue;
      bool used = false;
      for (const Eigen::Vector2d& s : investigate_spots_) used = used || (s - c).norm() < 600;
      if (!used && (best < 0 || cost_field_.CostMm(i) < cost_field_.CostMm(best))) best = i;
    }
    if (best < 0) {  // nowhere to look from: turn to it where we are
      investigate_spots_.push_back(base_.position());
      investigate_hold_until_ = now_ + kInvestigateHoldUs;
      const bool shuttle = StartShuttle(&investigate_shuttle_, kShuttleLegMm);
      if (!shuttle) investigate_shuttle_ = TrailShuttle{};
      Event(std::string("no free place to see the candidate from: ") +
            (shuttle ? "shuttling on the trail" : "standing") + " with the head on it for 5 s (place " +
            std::to_string(investigate_spots_.size()) + " of 4)");
      return Hold(centre);
    }
    std::vector<Eigen::Vector2d> path = cost_field_.PathTo(map_, best);
    const double length = PathLength(path);
    follower_.SetPath(std::move(path));
    goal_deadline_ = now_ + static_cast<int64_t>((2 * length / options_.explore_speed_mm_s + 10) * kSecond);
  }
  return FollowPathLookingAt(centre, options_.explore_speed_mm_s);
}

// ---------------------------------------------------------------- APPROACH

bool Planner::PlanToOrbit() {
  cost_field_.Compute(map_, base_.position());
  const Eigen::Vector2d c = TargetCentre().head<2>();
  for (double extra = 0; extra <= 400; extra += 100) {
    const double r = options_.orbit_radius_mm + extra;
    int best = -1;
    for (int k = 0; k < 72; ++k) {
      const double a = k * 5 * kDeg;
      int index;
      if (!map_.IndexOf(c + r * Eigen::Vector2d(std::cos(a), std::sin(a)), &index)) continue;
      if (!map_.Traversable(index) || !cost_field_.Reachable(index)) continue;
      if (best < 0 || cost_field_.CostMm(index) < cost_field_.CostMm(best)) best = index;
    }
    if (best >= 0) {
      std::vector<Eigen::Vector2d> path = cost_field_.PathTo(map_, best);
      const double length = PathLength(path);
      follower_.SetPath(std::move(path));
      goal_deadline_ = now_ + static_cast<int64_t>((2 * length / options_.explore_speed_mm_s + 15) * kSecond);
      return true;
    }
  }
  return false;
}

Planner::Motion Planner::Approach() {
  activity_ = "approach";
  const Eigen::Vector3d centre = TargetCentre();
  const double d = (base_.position() - centre.head<2>()).norm();
  // On the circle, or at the circle point PlanToOrbit chose (radius up to 400 mm more) - not at a frontier the
  // approach explores while the circle is out of reach (room_04, 7 Dec: "on the orbit circle (3601 mm from the
  // target)" at a frontier goal, then no orbit, no model).
  if ((std::abs(d - options_.orbit_radius_mm) <= kGoalToleranceMm && map_.TraversableAt(base_.position())) ||
      (approach_to_circle_ && !follower_.empty() && follower_.Reached(base_, kGoalToleranceMm))) {
    EnterPhase(Phase::kOrbit, "on the orbit circle (" + std::to_string(static_cast<int>(d)) + " mm from the target)");
    return Orbit();
  }
  if (approach_exploring_since_ >= 0 &&
      now_ - approach_exploring_since_ >= static_cast<int64_t>(options_.approach_budget_s * kSecond)) {
    char why[220];
    std::snprintf(why, sizeof(why),
                  "the orbit circle was not reachable for %.0f s of exploring (its floor is not free in the map: not "
                  "seen, untextured or blocked; try another --radius)",
                  options_.approach_budget_s);
    EnterPhase(Phase::kNextViews, why);
    return NextViews();
  }
  const bool replan = follower_.empty() || now_ >= next_replan_ || now_ > goal_deadline_ ||
                      !follower_.StillFree(map_, 1000) || Stuck() ||
                      (!approach_to_circle_ && follower_.Reached(base_, kGoalToleranceMm));
  if (replan) {
    next_replan_ = now_ + kReplanUs;
    blocked_since_ = -1;
    approach_to_circle_ = PlanToOrbit();
    if (approach_to_circle_) {
      approach_exploring_since_ = -1;
    } else {
      if (!ChooseFrontier()) {
        EnterPhase(Phase::kNextViews, "the orbit circle is not reachable and nothing is left to explore");
        return NextViews();
      }
      if (approach_exploring_since_ < 0) {
        approach_exploring_since_ = now_;
        Event("approach: the orbit circle is not reachable yet: exploring frontiers");
      }
      activity_ = "approach: circle not reachable yet, exploring";
    }
  }
  return FollowPathLookingAt(centre, options_.explore_speed_mm_s);
}

// ---------------------------------------------------------------- ORBIT

bool Planner::StartBypass(double azimuth) {
  if (orbit_bypass_) SettleBypassProgress(false);  // replaced on the way: its progress counts before the repeat test
  cost_field_.Compute(map_, base_.position());
  const Eigen::Vector2d c = TargetCentre().head<2>();
  const double r = options_.orbit_radius_mm;
  bool passed_block = false;  // the goal lies beyond the blocked part of the circle
  for (double delta = 5 * kDeg; delta <= 1.5 * M_PI; delta += 5 * kDeg) {
    const double a = azimuth + delta;
    int index;
    if (!map_.IndexOf(c + r * Eigen::Vector2d(std::cos(a), std::sin(a)), &index)) continue;
    if (!map_.Traversable(index)) {
      passed_block = true;
      continue;
    }
    if (!passed_block || !cost_field_.Reachable(index)) continue;
    const Eigen::Vector2d goal = map_.CentreOf(index);
    const bool same = (goal - last_bypass_goal_).norm() < 150 &&
                      std::abs(orbit_progress_ - last_bypass_progress_) < kBypassProgressRad;
    bypass_repeats_ = same ? bypass_repeats_ + 1 : 0;
    if (!same) {
      last_bypass_goal_ = goal;
      last_bypass_progress_ = orbit_progress_;
    }
    if (bypass_repeats_ >= kMaxBypassRepeats) {
      Event("orbit: the bypass to " + Mm(goal) + " was tried " + std::to_string(bypass_repeats_ + 1) +
            " times without orbit progress: that arc counts as blocked");
      return false;
    }
    std::vector<Eigen::Vector2d> path = cost_field_.PathTo(map_, index);
    // Time to get there (room_08: a bypass followed for 150 s, neither reached nor stuck, until the frame budget).
    bypass_deadline_ =
        now_ + static_cast<int64_t>((2 * PathLength(path) / options_.orbit_speed_mm_s + 15) * kSecond);
    follower_.SetPath(std::move(path));
    orbit_bypass_ = true;
    bypass_skip_rad_ = delta;
    bypass_travelled_rad_ = 0;
    Event("orbit: circle blocked ahead, bypass to " + Mm(goal));
    return true;
  }
  return false;
}

void Planner::SettleBypassProgress(bool reached) {
  if (bypass_skip_rad_ < 0) return;
  orbit_progress_ += reached ? bypass_skip_rad_ : bypass_travelled_rad_;
  bypass_skip_rad_ = -1;
  bypass_travelled_rad_ = 0;
}

bool Planner::TargetHidden() const {
  const OdometryReading* odometry = estimator_.latest_odometry();
  if (odometry == nullptr) return false;
  const Eigen::Vector2d camera =
      WorldFromCamera(options_.robot, base_, odometry->pan_rad, odometry->tilt_rad).translation().head<2>();
  const Eigen::Vector2d target = TargetCentre().head<2>();
  const double target_radius = 0.5 * target_.size_mm.head<2>().norm() + 2 * options_.map.cell_mm;
  const Eigen::Vector2d d = target - camera;
  const double length = d.norm();
  for (double s = 0; s < length - target_radius; s += 0.5 * options_.map.cell_mm) {
    int index;
    if (map_.IndexOf(camera + d * (s / length), &index) && map_.StateOf(index) == OccupancyMap::State::kOccupied)
      return true;
  }
  return false;
}

double Planner::OrbitRadiusAhead(double azimuth, double* blocked_azimuth) const {
  const Eigen::Vector2d c = TargetCentre().head<2>();
  *blocked_azimuth = azimuth;
  auto arc_free = [&](double radius, bool note_block) {
    for (double s = 100; s <= 900; s += 100) {
      const double a = azimuth + s / radius;
      if (!map_.TraversableAt(c + radius * Eigen::Vector2d(std::cos(a), std::sin(a)))) {
        if (note_block) *blocked_azimuth = a;
        return false;
      }
    }
    return true;
  };
  if (arc_free(options_.orbit_radius_mm, true)) return options_.orbit_radius_mm;
  for (double extra = 100; extra <= kMaxDetourMm; extra += 100) {
    const double radius = options_.orbit_radius_mm + extra;
    if (!arc_free(radius, false)) continue;
    // 100 mm more where free: the obstacle's far side, not seen yet, may reach farther out than its near side.
    return extra + 100 <= kMaxDetourMm && arc_free(radius + 100, false) ? radius + 100 : radius;
  }
  return -1;
}

// The orbit's pause while the target is LOST (not hidden behind an obstacle, not during a glance): for
// lost_search_s, back and forth on the trail with the head on the target: the travel lets the camera turn back to it
// (a standing search may only re-aim by kFreeSwing, and the target is often far off the axis after a glance, floor
// mapping or a bypass: room_05, two 20-s searches, orbit unfinished) and gives the pose solver parallax; without
// trail, standing with the head swept over its last position. True (and *m) while searching.
bool Planner::SearchLostTarget(const Eigen::Vector3d& centre, const Eigen::Vector2d& r, bool hidden, Motion* m) {
  if (target_state_ == TargetState::kLost && !glancing_ && !hidden) {
    if (lost_since_ < 0) {
      lost_since_ = now_;
      if (!StartShuttle(&search_shuttle_, kShuttleLegMm)) search_shuttle_ = TrailShuttle{};
      Event(std::string("orbit paused: target lost, searching") +
            (search_shuttle_.back.empty() ? "" : " (shuttling on the trail, the head on the target)"));
    }
    if (now_ - lost_since_ >= static_cast<int64_t>(options_.lost_search_s * kSecond)) return false;
    activity_ = "orbit paused: searching the target";
    if (!search_shuttle_.back.empty()) {
      *m = Motion{};
      m->velocity = ShuttleStep(&search_shuttle_, HeldLongerThan(kSecond), &m->trail);
      m->aim_point = centre;
      m->camera_turn_needs_translation = true;
      return true;
    }
    const double sweep = 0.25 * std::sin(2 * M_PI * (now_ - lost_since_) * 1e-6 / 4.0);  // ~±14 deg
    const Eigen::Vector2d side(-r.y(), r.x());
    *m = Hold(centre + Eigen::Vector3d(side.x(), side.y(), 0) * sweep);
    return true;
  }
  if (lost_since_ >= 0 && target_state_ != TargetState::kLost) {
    lost_since_ = -1;
    Event("orbit continues: target found again");
  }
  return false;
}

Planner::Motion Planner::Orbit() {
  activity_ = "orbit";
  const Eigen::Vector3d centre = TargetCentre();
  const Eigen::Vector2d c = centre.head<2>();
  const Eigen::Vector2d r = base_.position() - c;
  const double azimuth = std::atan2(r.y(), r.x());
  if (!orbit_started_) {
    orbit_started_ = true;
    orbit_last_azimuth_ = azimuth;
    orbit_progress_ = 0;
    orbit_radius_set_ = options_.orbit_radius_mm;
  }
  // (during a bypass that skips an arc the azimuth driven is kept apart: see SettleBypassProgress)
  (orbit_bypass_ && bypass_skip_rad_ >= 0 ? bypass_travelled_rad_ : orbit_progress_) +=
      WrapAngle(azimuth - orbit_last_azimuth_);
  orbit_last_azimuth_ = azimuth;
  const bool hidden = TargetHidden();
  Motion search;
  if (SearchLostTarget(centre, r, hidden, &search)) return search;
  if (orbit_progress_ >= 2 * M_PI) {
    char text[96];
    std::snprintf(text, sizeof(text), "orbit complete (%.0f %% of the circle driven)", orbit_percent());
    EnterPhase(Phase::kNextViews, text);
    return NextViews();
  }
  const int quarter = static_cast<int>(orbit_progress_ / (M_PI / 2));
  if (quarter > orbit_reported_quarter_) {
    orbit_reported_quarter_ = quarter;
    Event("orbit " + std::to_string(25 * quarter) + " %");
  }
  if (orbit_mapping_) {  // driving to unmapped floor near the target, the camera ahead (see below)
    if (follower_.empty() || follower_.Reached(base_, 150) || now_ > goal_deadline_ || Stuck()) {
      blocked_since_ = -1;
      if (!follower_.empty()) visited_goals_.push_back(follower_.goal());
      follower_.Clear();
      orbit_mapping_ = false;
      if (PlanToOrbit()) {
        SettleBypassProgress(false);
        orbit_bypass_ = true;
        Event("orbit: back to the circle");
      }
    } else {
      activity_ = "orbit: mapping the floor around the target";
      return LookAhead(follower_.Follow(map_, base_, options_.explore_speed_mm_s, options_.tracking_turn_rad_s));
    }
  }
  if (orbit_bypass_) {
    if (now_ > bypass_deadline_ && !follower_.empty() && !follower_.Reached(base_, 80))
      Event("orbit: the bypass to " + Mm(follower_.goal()) + " was not reached in time");
    if (follower_.empty() || follower_.Reached(base_, 80) || Stuck() || now_ > bypass_deadline_) {
      SettleBypassProgress(!follower_.empty() && follower_.Reached(base_, 80));
      blocked_since_ = -1;
      orbit_bypass_ = false;
      follower_.Clear();
    } else if (follower_.StillFree(map_, 1000) || StartBypass(azimuth)) {
      activity_ = "orbit: bypass";
      return FollowPathLookingAt(centre, options_.orbit_speed_mm_s);
    } else {  // its path blocked, no other: the circle goes on from here
      SettleBypassProgress(false);
      orbit_bypass_ = false;
      follower_.Clear();
    }
  }
  double blocked_azimuth;
  double wanted = OrbitRadiusAhead(azimuth, &blocked_azimuth);
  if (Stuck()) {  // the circle (or its detour) cannot be driven from here: take the shortest path past it
    blocked_since_ = -1;
    glancing_ = false;
    glances_ += glances_ == 0 ? 1 : 0;
    glanced_azimuth_ = blocked_azimuth;
    wanted = -1;
  }
  if (wanted < 0) {
    // Blocked ahead. Unknown floor may only be unseen (the camera looks at the target): look at it once while
    // creeping along, then take the shortest path past the blocked part.
    if (!glancing_ && (glances_ == 0 || std::abs(WrapAngle(blocked_azimuth - glanced_azimuth_)) > 20 * kDeg)) {
      glancing_ = true;
      glance_start_ = now_;
      glanced_azimuth_ = blocked_azimuth;
      ++glances_;
    }
    if (glancing_ && now_ - glance_start_ < 3 * kSecond) {
      activity_ = "orbit: looking ahead";
      const double sweep = 300 * std::sin(2 * M_PI * (now_ - glance_start_) * 1e-6 / 2.0);
      const double a = glanced_azimuth_ + sweep / options_.orbit_radius_mm;
      Motion m;
      m.velocity = FollowCircle(base_, c, orbit_radius_set_, 0.5 * options_.orbit_speed_mm_s,
                                options_.tracking_turn_rad_s);
      m.aim_point = Eigen::Vector3d(c.x() + options_.orbit_radius_mm * std::cos(a),
                                    c.y() + options_.orbit_radius_mm * std::sin(a), 0);
      return m;
    }
    glancing_ = false;
    if (!StartBypass(azimuth)) {
      // The circle runs into floor the map does not know (the camera looked at the target, not at the floor
      // around it; room_03 gave up 3 s into the orbit): map the nearest unknown floor within kOrbitMappingMm of
      // the target first, looking where the robot drives, then go back to the circle.
      const Eigen::Vector2d near = c;
      if (orbit_mappings_ < kMaxOrbitMappings && ChooseFrontier(&near, kOrbitMappingMm)) {
        ++orbit_mappings_;
        orbit_mapping_ = true;
        bypass_repeats_ = 0;  // the map will know more: bypasses may lead somewhere after the trip
        has_fixation_ = false;
        Event("orbit: the circle runs into unmapped floor: mapping it first (" + std::to_string(orbit_mappings_) +
              " of " + std::to_string(kMaxOrbitMappings) + ")");
        activity_ = "orbit: mapping the floor around the target";
        return LookAhead(follower_.Follow(map_, base_, options_.explore_speed_mm_s, options_.tracking_turn_rad_s));
      }
      EnterPhase(Phase::kNextViews, "the rest of the orbit circle is not reachable");
      return NextViews();
    }
    activity_ = "orbit: bypass";
    return FollowPathLookingAt(centre, options_.orbit_speed_mm_s);
  }
  glancing_ = false;
  if (target_state_ == TargetState::kLost && hidden) activity_ = "orbit: target behind an obstacle";
  orbit_radius_set_ += std::clamp(wanted - orbit_radius_set_, -400 * dt_, 400 * dt_);
  const double off_circle = std::abs(r.norm() - orbit_radius_set_);
  if (orbit_radius_set_ > options_.orbit_radius_mm + 5)
    activity_ = "orbit: detour outward";
  else if (off_circle > 30)
    activity_ = "orbit: joining the circle";
  else if (hidden)
    activity_ = "orbit: target behind an obstacle";
  const int bin = static_cast<int>(std::floor((WrapAngle(azimuth) + M_PI) / (2 * M_PI) * 360.0)) % 360;
  orbit_bins_[static_cast<size_t>(bin)] = 1;
  Motion m;
  m.velocity = FollowCircle(base_, c, orbit_radius_set_, options_.orbit_speed_mm_s, options_.tracking_turn_rad_s);
  m.aim_point = centre;
  return m;
}

// ---------------------------------------------------------------- NEXT_VIEWS

void Planner::ChooseView() {
  const auto start = std::chrono::steady_clock::now();
  coverage_.Update();
  const double fraction = coverage_.Fraction();
  char text[160];
  if (!next_views_.empty() && next_views_.back().coverage_after < 0) {
    next_views_.back().coverage_after = fraction;
    std::snprintf(text, sizeof(text), "next view %zu done: coverage %.1f %%", next_views_.size(), 100 * fraction);
    Event(text);
  }
  std::snprintf(text, sizeof(text), "coverage %.1f %% of %d samples", 100 * fraction, coverage_.num_samples());
  const std::string coverage_text = text;
  if (fraction >= options_.coverage_target) return EnterPhase(Phase::kFinish, "coverage target reached: " + coverage_text);
  if (static_cast<int>(next_views_.size()) >= options_.max_next_views)
    return EnterPhase(Phase::kFinish, "next-view budget of " + std::to_string(options_.max_next_views) +
                                          " views used: " + coverage_text);
  if (PhaseSeconds() >= options_.next_views_budget_s)
    return EnterPhase(Phase::kFinish, "next-view time budget spent: " + coverage_text);
  cost_field_.Compute(map_, base_.position());
  const NextViewResult result = ChooseNextView(coverage_, map_, cost_field_, options_.robot, options_.limits,
                                               options_.next_view, used_views_);
  last_next_view_ms_ = Ms(start);
  if (!result.found) return EnterPhase(Phase::kFinish, "no reachable view adds coverage: " + coverage_text);
  const ViewCandidate& v = result.best;
  used_views_.insert(v.key);
  current_view_ = v;
  NextViewRecord record;
  record.utime = now_;
  record.x_mm = v.base.x_mm;
  record.y_mm = v.base.y_mm;
  record.pan_rad = v.pan_rad;
  record.tilt_rad = v.tilt_rad;
  record.radius_mm = v.radius_mm;
  record.azimuth_rad = v.azimuth_rad;
  record.gain = v.gain;
  record.coverage_before = fraction;
  next_views_.push_back(record);
  std::snprintf(text, sizeof(text),
                "next view %zu at (%.0f, %.0f) mm: radius %.0f mm, azimuth %.0f deg, tilt %.0f deg, %d new samples "
                "expected (%s, %.0f ms)",
                next_views_.size(), v.base.x_mm, v.base.y_mm, v.radius_mm, v.azimuth_rad / kDeg, v.tilt_rad / kDeg,
                v.gain, coverage_text.c_str(), last_next_view_ms_);
  Event(text);
  int index;
  map_.IndexOf(v.base.position(), &index);
  std::vector<Eigen::Vector2d> path = cost_field_.PathTo(map_, index);
  const double length = PathLength(path);
  follower_.SetPath(std::move(path));
  goal_deadline_ = now_ + static_cast<int64_t>((2 * length / options_.explore_speed_mm_s + 20) * kSecond);
  view_step_ = ViewStep::kTravel;
}

Planner::Motion Planner::NextViews() {
  const Eigen::Vector3d centre = TargetCentre();
  const Eigen::Vector2d r = base_.position() - centre.head<2>();
  const double azimuth = std::atan2(r.y(), r.x());
  if (view_step_ == ViewStep::kChoose) {
    ChooseView();
    if (done()) return {};
  }
  const std::string k = std::to_string(next_views_.size());
  if (view_step_ == ViewStep::kTravel) {
    activity_ = "next view " + k + ": travelling";
    if (follower_.Reached(base_, kGoalToleranceMm) || follower_.empty()) {
      view_step_ = ViewStep::kAlign;
      step_started_ = now_;
      follower_.Clear();
    } else if (now_ > goal_deadline_ || Stuck()) {
      blocked_since_ = -1;
      Event("next view " + k + " not reached: choosing another");
      view_step_ = ViewStep::kChoose;
      return Hold(centre);
    } else if (!follower_.StillFree(map_, 1000)) {
      std::vector<Eigen::Vector2d> path;
      if (PlanPath(map_, base_.position(), current_view_.base.position(), &path)) {
        follower_.SetPath(std::move(path));
      } else {
        Event("next view " + k + " no longer reachable: choosing another");
        view_step_ = ViewStep::kChoose;
        return Hold(centre);
      }
    } else {
      return FollowPathLookingAt(centre, options_.explore_speed_mm_s);
    }
  }
  if (view_step_ == ViewStep::kAlign) {
    activity_ = "next view " + k + ": aiming";
    if (now_ == step_started_) {  // along the ring in the direction that needs the smaller turn
      const double ccw = WrapAngle(current_view_.azimuth_rad + M_PI / 2);
      const double arc = options_.next_view.capture_arc_deg * kDeg;
      auto ring_free = [&](double a) {
        return map_.TraversableAt(centre.head<2>() + current_view_.radius_mm * Eigen::Vector2d(std::cos(a), std::sin(a)));
      };
      const bool cw_free = ring_free(current_view_.azimuth_rad - arc), ccw_free = ring_free(current_view_.azimuth_rad + arc);
      capture_clockwise_ = cw_free && (!ccw_free || std::abs(WrapAngle(ccw - base_.theta_rad)) > M_PI / 2);
      current_view_.base.theta_rad = capture_clockwise_ ? WrapAngle(ccw + M_PI) : ccw;
    }
    const double error = WrapAngle(current_view_.base.theta_rad - base_.theta_rad);
    Motion m = Hold(current_view_.aim_mm);
    m.velocity.omega_rad_s = std::clamp(2.0 * error, -options_.tracking_turn_rad_s, options_.tracking_turn_rad_s);
    if (std::abs(error) < 5 * kDeg && now_ - step_started_ >= kSecond / 2) {
      view_step_ = ViewStep::kCapture;
      step_started_ = now_;
      capture_start_azimuth_ = azimuth;
    }
    return m;
  }
  // kCapture: a short arc along the view's ring, head on the view's aim point.
  activity_ = "next view " + k + ": capturing";
  const double arc = options_.next_view.capture_arc_deg * kDeg;
  const double swept = WrapAngle(azimuth - capture_start_azimuth_) * (capture_clockwise_ ? -1 : 1);
  if (swept >= arc || now_ - step_started_ > 15 * kSecond) {
    view_step_ = ViewStep::kChoose;
    return Hold(current_view_.aim_mm);
  }
  Motion m;
  m.velocity = FollowCircle(base_, centre.head<2>(), current_view_.radius_mm, options_.capture_speed_mm_s,
                            options_.tracking_turn_rad_s, capture_clockwise_);
  m.aim_point = current_view_.aim_mm;
  return m;
}

PlanSummary Planner::Summary() const {
  PlanSummary s;
  s.phase = phase_;
  s.phases = phases_;
  s.path_length_mm = path_length_mm_;
  s.frames = frames_;
  s.views = views_;
  s.orbit_percent = orbit_percent();
  s.next_views = next_views_;
  s.coverage = coverage_.Fraction();
  s.coverage_samples = coverage_.num_samples();
  s.min_coverage = options_.min_coverage;
  s.finish_reason = last_phase_reason_;
  s.max_disagreement = estimator_.max_disagreement();
  s.target_confirmed = confirmed_;
  s.target = target_;
  s.confirmed_seq = confirmed_seq_;
  s.safety_stops = safety_stops_;
  s.pan_limit_reversals = pan_limit_reversals_;
  s.contacts = contacts_;
  s.orbit_glances = glances_;
  s.relocalizations = relocalizations_;
  s.map_restarts = map_restarts_;
  return s;
}

}  // namespace objscan
