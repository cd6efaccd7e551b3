// Planner: drives the robot through the object-modeling mission, LCM-free. One decision per camera pose (Step).
//
// Phases (values as in PROCESS_STATUS "phase"):
//   0 EXPLORE     a gentle forward arc into the start_free_mm ahead of the start, the head fixating a floor point
//                 ahead (one camera sees depth only once it moves, and the pose solver's factorization needs the
//                 camera to turn about scene points: turning in place gives it neither), then frontier
//                 exploration (a slow turn in place with the head low, then up, only while nothing reachable is
//                 known): drive to the nearest reachable frontier (free cells next to unknown ones) along the
//                 shortest path on the inflated map, the head looking at the floor ~1.2 m ahead along the path.
//                 A CANDIDATE (or LOST, not yet confirmed) target is investigated: the robot drives to points 0.9-1.5 m
//                 from it with the head on it, so the finder sees it from several places (4 at most; with no free
//                 place to go, 5 s shuttling on the trail, head on it, count as one). A candidate the finder stops
//                 reporting is given up after 5 s, or 20 s after a map restart or a pose regained (the finder's
//                 clusters were the old map's points), and a candidate found again after such a change starts its
//                 places afresh. Ends when the target is
//                 CONFIRMED (-> APPROACH), or after explore_budget_s or with nothing left to explore (-> NO_TARGET;
//                 a candidate still reported then gets up to 2 more rounds of 4 places first).
//                 Nothing reachable at all (no usable camera pose yet): the look-around starts again.
//   1 APPROACH    to the nearest reachable free point of the orbit circle (orbit_radius_mm around the target centre),
//                 head on the target centre; while none is reachable, exploring frontiers (the orbit starts only at
//                 the circle, never at a frontier). After approach_budget_s of that without a path to it (-> NEXT_VIEWS, which
//                 ends "partial" when the views it can reach leave the coverage under min_coverage).
//   2 ORBIT       counter-clockwise around the target at orbit_radius_mm and orbit_speed_mm_s, head on the target.
//                 An obstacle on the next 0.9 m of circle: the radius rises locally (up to +600 mm) where that is
//                 free; else (unknown floor ahead: the camera looks at the target, not ahead) the head looks at the
//                 blocked arc for up to 3 s while the robot creeps on, then the robot takes the shortest path past
//                 the blocked part to the next free circle point. A LOST target pauses the orbit (head on its last
//                 position, sweeping) for at most lost_search_s, unless an obstacle of the map lies on the line of
//                 sight (hidden, not lost: the orbit goes on). Ends after a full turn, arcs skipped by bypasses
//                 included (-> NEXT_VIEWS).
//   3 NEXT_VIEWS  next-best-view (next_best_view.h) from the coverage model: go to the view, turn along its ring,
//                 aim the head, drive capture_arc_deg along the ring (frames for motion stereo), choose again; until
//                 coverage_target, max_next_views, next_views_budget_s, or no view adds coverage (-> FINISH).
//   4 FINISH      stop. Outcome "modeled" ("partial" under min_coverage: an error of the run).
//   5 NO_TARGET   stop. Outcome "no_target".
// Every command: v in [0, max speed], |omega| <= tracking_turn_rad_s (<= the base limit), pan/tilt within the joint
// limits, the camera's yaw rate (base + pan) and the tilt rate <= tracking_turn_rad_s (the tracker must keep up);
// the swept footprint over the next 0.5 s never enters an obstacle's or an unknown cell (SafeVelocity).
// Times are data times (the poses' utime); the planner never reads a clock except to measure its own compute time.
// Inputs that are non-finite or invalid are ignored (the node counts them).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "common/robot_model.h"
#include "common/sensor_data.h"
#include "processes/object_finder/floor_plane.h"
#include "processes/planner/coverage.h"
#include "processes/planner/motion.h"
#include "processes/planner/next_best_view.h"
#include "processes/planner/occupancy_map.h"
#include "processes/planner/path_search.h"
#include "processes/planner/planner_geometry.h"
#include "processes/planner/pose_estimator.h"

namespace objscan {

enum class Phase : int { kExplore = 0, kApproach = 1, kOrbit = 2, kNextViews = 3, kFinish = 4, kNoTarget = 5 };
const char* PhaseName(Phase phase);

// The object finder's view of the target (target_t).
enum class TargetState : int { kSearching = 0, kCandidate = 1, kConfirmed = 2, kLost = 3 };
struct TargetObservation {
  int64_t utime = 0;  // µs
  int64_t seq = 0;
  TargetState state = TargetState::kSearching;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();  // world
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();    // box extents
  double yaw_rad = 0;
  double confidence = 0;
};

struct PlannerOptions {
  RobotGeometry robot;
  RobotLimits limits;
  OccupancyMapOptions map;
  CoverageOptions coverage;
  NextViewOptions next_view;
  double orbit_radius_mm = 800;                    // mm
  double orbit_speed_mm_s = 200;                   // mm/s
  double explore_speed_mm_s = 200;                 // mm/s, exploring and approaching
  double capture_speed_mm_s = 100;                 // mm/s, along the ring at a next view
  double tracking_turn_rad_s = 30 * M_PI / 180;    // rad/s, fastest base and camera rotation
  double explore_budget_s = 300;                   // s of EXPLORE before NO_TARGET
  double approach_budget_s = 120;                  // s of APPROACH exploring frontiers without a path to the
                                                   // circle before NEXT_VIEWS without an orbit (a circle whose
                                                   // floor the map never shows free: the search would go on until
                                                   // the frame budget)
  double start_free_mm = 400;                      // mm of floor ahead of the start taken as free: one camera sees
                                                   // depth only once it moves, so the robot's first motion (a
                                                   // gentle forward arc that starts the pose solver's map) goes
                                                   // there; place the robot accordingly
  double coverage_target = 0.95;                   // coverage fraction that ends NEXT_VIEWS
  double min_coverage = 0.6;                       // a plan that ends (FINISH) with less coverage is "partial", a
                                                   // failure: the model misses part of the target (room_04, 7 Dec:
                                                   // orbit and next views unreachable, coverage 52 %, the model 48.5 %
                                                   // of the target and its centre 26 mm off, with status ok). The
                                                   // coverage estimate is within about 15 points of the model's true
                                                   // completeness where the poses held (rooms 01-07: 84/97, 87/77,
                                                   // 96/85, 52/49, 67/83, 78/84 %; not room_05's distorted map: 90/42),
                                                   // hence well under the coverage target, [0, 1]
  int max_next_views = 12;                         // views NEXT_VIEWS adds at most
  double next_views_budget_s = 240;                // s of NEXT_VIEWS at most
  double lost_search_s = 15;                       // s an ORBIT waits for a LOST target before going on
};

bool ValidatePlannerOptions(const PlannerOptions& options, std::string* why);

struct PlannerCommand {
  bool stop = true;  // true: MODE_STOP; false: velocity with pan/tilt
  double v_mm_s = 0, omega_rad_s = 0;
  double pan_rad = 0, tilt_rad = 0;
};

struct PhaseRecord {
  Phase phase = Phase::kExplore;
  int64_t start_utime = 0;
  int64_t end_utime = -1;  // -1 while running
};

struct NextViewRecord {
  int64_t utime = 0;  // µs, when it was chosen
  double x_mm = 0, y_mm = 0, pan_rad = 0, tilt_rad = 0;
  double radius_mm = 0, azimuth_rad = 0;
  int gain = 0;                // uncovered samples it was expected to see
  double coverage_before = 0;  // fraction
  double coverage_after = -1;  // fraction after its capture (-1 until known)
};

struct PlanSummary {
  Phase phase = Phase::kExplore;
  std::vector<PhaseRecord> phases;
  double path_length_mm = 0;  // estimated
  int64_t frames = 0;         // camera poses handled
  int64_t views = 0;          // of them with a usable pose
  double orbit_percent = 0;
  std::vector<NextViewRecord> next_views;
  double coverage = 0;
  int coverage_samples = 0;
  double min_coverage = 0;     // the options' min_coverage: FINISH with less coverage is the outcome "partial"
  std::string finish_reason;   // why the last phase change happened (e.g. "no reachable view adds coverage: ...")
  PoseDisagreement max_disagreement;
  bool target_confirmed = false;
  TargetObservation target;           // last confirmed estimate (or last candidate)
  int64_t confirmed_seq = -1;         // frame of the first confirmation
  int64_t safety_stops = 0;           // decisions whose speed the swept-footprint check cut
  int64_t pan_limit_reversals = 0;    // turns in place reversed to keep the head within its pan limit
  int orbit_glances = 0;              // ORBIT looked at a blocked arc ahead (target out of view meanwhile)
  int relocalizations = 0;            // times the base retraced its trail for a new map after the pose was lost
  int map_restarts = 0;               // landmark sets under half the one before (a restarted, unjoined map)
  int contacts = 0;                   // times the base was driven but its odometry stood: obstacles felt, not seen
};

class Planner {
 public:
  // Throws std::invalid_argument on invalid options.
  explicit Planner(const PlannerOptions& options);

  void SetCamera(const CameraIntrinsics& camera);
  bool AddOdometry(const OdometryReading& reading);
  // The sparse map (world); obstacle heights are taken above the floor plane fitted among these landmarks.
  void SetLandmarks(const std::vector<MapLandmark>& landmarks);
  void SetTarget(const TargetObservation& target);
  void SetVoxels(const VoxelCloud& voxels);
  // The decision for one camera pose (any status; LOST / INITIALIZING poses dead-reckon).
  PlannerCommand Step(const CameraPoseEstimate& pose);

  Phase phase() const { return phase_; }
  bool done() const { return phase_ == Phase::kFinish || phase_ == Phase::kNoTarget; }
  std::string activity() const { return activity_; }  // what the phase is doing now, e.g. "frontier"
  PlanSummary Summary() const;
  // Log lines since the last call (phase changes, candidate / confirmed at ..., orbit %, next views).
  std::vector<std::string> TakeEvents();

  BasePose estimate() const { return base_; }
  double coverage() const { return coverage_.Fraction(); }
  double orbit_percent() const;
  int num_next_views() const { return static_cast<int>(next_views_.size()); }
  double path_length_mm() const { return path_length_mm_; }
  double last_step_ms() const { return last_step_ms_; }
  double last_next_view_ms() const { return last_next_view_ms_; }
  const RobotPoseEstimator& pose_estimator() const { return estimator_; }
  const OccupancyMap& map() const { return map_; }
  // The estimated base positions (world mm) every 50 mm of travel.
  const std::vector<Eigen::Vector2d>& path() const { return path_; }
  const CoverageModel& coverage_model() const { return coverage_; }
  const PlannerOptions& options() const { return options_; }

 private:
  struct Motion {  // what a phase wants this step
    Velocity velocity;
    bool aim_at_point = true;
    Eigen::Vector3d aim_point = Eigen::Vector3d::Zero();  // world
    double pan_rad = 0, tilt_rad = 0;                      // when not aiming at a point
    // The camera's yaw may turn only as fast as the base translates (kCameraTurnPerMm, plus kStillCameraTurn at a
    // standstill): a camera that swings to unmapped floor while the base turns in place loses the pose solver's
    // track (room_03: lost at the first U-turn, restarted on a pure rotation, map 1.3x off in scale).
    bool camera_turn_needs_translation = false;
    // A look-around by the head alone (the base can travel neither way): the camera sweeps at the tracking rate,
    // free of kFreeSwing; the pose may be lost, and the lost-pose retrace follows.
    bool head_only_sweep = false;
    // The robot's own trail this motion follows (TrailBack of the odometry trail, odometry frame): the
    // swept-footprint check lets it pass while the odometry pose keeps within kTrailToleranceMm of it, where the map
    // alone would hold it (room_07: a start 168 mm from a wall that the map drew 50-100 mm nearer).
    const std::vector<Eigen::Vector2d>* trail = nullptr;
  };
  // Back and forth along the robot's own trail, from where the shuttle began back to the trail's far end and again.
  struct TrailShuttle {
    std::vector<Eigen::Vector2d> back, forth;  // from the start back along the trail; the same reversed
    bool outbound = true;  // on `back` (else on `forth`)
    bool backing = true;   // this leg backs up (chosen at its start: whichever way the trail leads with less turning)
    int64_t leg_start_us = 0;
  };

  void EnterPhase(Phase phase, const std::string& why);
  void Event(const std::string& text);
  double PhaseSeconds() const;
  // True when the swept-footprint check has held a robot that wants to move for more than `us` (µs).
  bool HeldLongerThan(int64_t us) const;
  // True when the swept-footprint check has held the robot still for > 2 s although the phase wants to move.
  bool Stuck() const;
  Motion Explore();
  Motion LookAround();
  // Starts a shuttle on the trail behind the robot (up to length_mm); false when less than kMinTrailMm lies behind.
  bool StartShuttle(TrailShuttle* shuttle, double length_mm);
  // Turns the shuttle to its other leg (the first leg: outbound).
  void NextShuttleLeg(TrailShuttle* shuttle);
  // This step's velocity on the shuttle's current leg (the next leg when this one is done or *held); *trail = it.
  Velocity ShuttleStep(TrailShuttle* shuttle, bool held, const std::vector<Eigen::Vector2d>** trail);
  // Whether this step relocalizes (see Relocalize); starts and ends the episodes.
  bool UpdateRelocalizing();
  Motion Relocalize();
  Motion StartArc();
  Motion Frontier();
  Motion Investigate();
  Motion Approach();
  Motion Orbit();
  // The orbit's lost-target search (see the definition): true and *m while it runs.
  bool SearchLostTarget(const Eigen::Vector3d& centre, const Eigen::Vector2d& r, bool hidden, Motion* m);
  Motion NextViews();
  Motion FollowPathLookingAt(const Eigen::Vector3d& point, double speed);
  Motion LookAhead(const Velocity& v);
  Motion Hold(const Eigen::Vector3d& point);
  // A frontier goal (known free floor next to unknown, reachable, not visited), the cheapest by path cost and
  // turn; with `near`, only goals within within_mm of it. False when there is none.
  bool ChooseFrontier(const Eigen::Vector2d* near = nullptr, double within_mm = 0);
  bool PlanToOrbit();
  bool StartBypass(double azimuth);
  // Ends a skipping bypass's accounting: orbit_progress_ gains the skipped arc when it was reached, else the azimuth
  // driven during it (signed, summed per frame). No-op outside such a bypass.
  void SettleBypassProgress(bool reached);
  // Orbit radius (circle first, then up to kMaxDetourMm outward) whose next 0.9 m of arc is Traversable; -1 when
  // none. *blocked_azimuth: the first blocked point of the circle itself.
  double OrbitRadiusAhead(double azimuth, double* blocked_azimuth) const;
  // True when an obstacle cell lies on the line of sight from the camera to the target (a LOST target there is
  // only hidden: the orbit goes on).
  bool TargetHidden() const;
  void ChooseView();
  PlannerCommand Finalize(const Motion& motion, double dt_s);
  // Finalize's first step: a turn in place that would sweep the camera round with the head at its pan limit turns
  // the other way round (see the definition); *v is replaced then.
  void ReverseTurnAtPanLimit(const Motion& motion, double dt, Velocity* v);
  // rad/s the camera's yaw may turn this step (the tracking turn rate; while the motion needs translation for it,
  // only kStillCameraTurn plus kCameraTurnPerMm per mm/s of base speed). Every motion also keeps the camera within
  // kFreeSwing of camera_anchor_yaw_ (Finalize).
  double CameraTurnRate(const Motion& motion, double v_mm_s) const;
  // The camera yaw's turn this step (rad, dt s) lies in [*lowest, *highest]: CameraTurnRate, and within kFreeSwing
  // of camera_anchor_yaw_ (beyond it already: no further away) unless the motion is a head-only sweep.
  void CameraTurnBounds(const Motion& motion, double v_mm_s, double dt, double* lowest, double* highest) const;
  // The base heading in camera_anchor_yaw_'s frame (rad).
  double AnchorFrameHeading() const;
  Eigen::Vector3d TargetCentre() const { return target_.centre_mm; }

  PlannerOptions options_;
  CameraIntrinsics camera_;
  RobotPoseEstimator estimator_;
  OccupancyMap map_;
  CoverageModel coverage_;
  PathFollower follower_;
  CostField cost_field_;

  std::vector<Eigen::Vector2d> path_;
  size_t last_landmark_count_ = 0;  // landmarks in the last set (a set under half of it: a restarted map)
  int map_restarts_ = 0;
  // The base's positions by odometry (odometry frame, every 25 mm, the newest 200-400): the trail the shuttles
  // retrace. Odometry never jumps, unlike the estimate after an unjoined map restart (room_07: a look-around trail
  // taken from the estimates led the base into a wall 6 times).
  std::vector<Eigen::Vector2d> odometry_trail_;
  BasePose odometry_base_;  // the latest odometry pose
  bool have_odometry_base_ = false;
  FloorPlane floor_;  // the floor among the landmarks (heights for the map are taken above it)
  bool have_floor_ = false;
  Eigen::Isometry3d camera_pose_ = Eigen::Isometry3d::Identity();  // world_from_camera of the current step
  bool has_fixation_ = false;
  Eigen::Vector2d fixation_ = Eigen::Vector2d::Zero();  // world, the floor point the head fixates while exploring
  bool start_marked_ = false;
  Eigen::Vector2d start_position_ = Eigen::Vector2d::Zero();
  Phase phase_ = Phase::kExplore;
  std::string activity_ = "waiting";
  std::string last_phase_reason_;  // EnterPhase's why, for the summary
  bool approach_to_circle_ = false;  // APPROACH: the follower's goal is a point of the orbit circle (not a frontier)
  int64_t approach_exploring_since_ = -1;  // µs, APPROACH: since when no path to the circle was found (-1: one is)
  std::vector<PhaseRecord> phases_;
  std::vector<std::string> events_;
  int64_t now_ = 0;             // µs, utime of the current pose
  int64_t last_step_utime_ = -1;
  BasePose base_;               // the estimate used for this step
  bool have_base_ = false;
  double path_length_mm_ = 0;
  int64_t frames_ = 0, views_ = 0, safety_stops_ = 0;
  Eigen::Isometry3d last_marked_ = Eigen::Isometry3d::Identity();
  bool marked_once_ = false;
  double pan_command_ = 0, tilt_command_ = 0;  // last commanded head angles
  // The camera yaw (rad, in the odometry's frame, which never jumps; the estimate's without odometry) the map is
  // taken to know around: the commanded camera yaw may swing at most kFreeSwing from it (the pan limit aside); it
  // follows the camera at kStillCameraTurn plus kCameraTurnPerMm per mm/s of base speed. Set at the first command.
  double camera_anchor_yaw_ = 0;
  bool camera_anchor_set_ = false;
  bool camera_anchor_by_odometry_ = false;
  bool head_initialised_ = false;
  double dt_ = 1.0 / 30.0;      // s, period of the current step
  int64_t blocked_since_ = -1;  // µs, since when the safety check holds a robot that wants to move
  // A base that is told to drive but does not move (held by something the map does not show; room_08's base touched
  // a table and stood against it for 6 367 frames while the planner followed its bypass): the last position that
  // was 30 mm from the one before, when it was reached, and the speed last commanded.
  Eigen::Vector2d progress_position_ = Eigen::Vector2d::Zero();
  int64_t progress_utime_ = 0;
  double commanded_v_mm_s_ = 0;
  int forced_turn_sign_ = 0;         // a turn in place reversed at the head's pan limit (+1 ccw, -1 cw; 0 none)
  std::string forced_turn_activity_;  // the activity it was reversed for (another activity drops it)
  int64_t pan_limit_reversals_ = 0;   // turns in place reversed so (plan.json)
  ContactDetector contact_;  // the odometry stood still while the base was driven (CheckContact)
  int contacts_ = 0;
  void CheckContact(double dt);
  double last_step_ms_ = 0, last_next_view_ms_ = 0;

  // target
  TargetObservation target_;     // last confirmed (after confirmation) or last candidate / lost position
  bool have_target_position_ = false;
  bool confirmed_ = false;
  TargetState target_state_ = TargetState::kSearching;
  int64_t confirmed_seq_ = -1;

  // EXPLORE
  enum class ExploreStep { kStartArc, kLookAround, kFrontier, kInvestigate } explore_step_ = ExploreStep::kStartArc;
  bool looking_around_ = false;
  int look_arounds_ = 0;             // look-arounds since the last frontier goal was reached
  double sweep_target_rad_ = 0;      // pan the head sweeps to (+-max_pan)
  int sweep_ends_reached_ = 0;
  int shuttle_direction_ = -1;       // -1 reversing, +1 forward
  Eigen::Vector2d shuttle_leg_start_ = Eigen::Vector2d::Zero();
  int64_t shuttle_leg_start_us_ = 0;
  int shuttle_short_legs_ = 0;       // consecutive legs that could not travel
  bool shuttle_stalled_ = false;     // the base cannot move either way: the head sweeps alone
  TrailShuttle look_shuttle_;        // the look-around's legs on the trail (empty: straight legs)

  // Lost pose (any phase)
  int lost_frames_ = 0;              // consecutive steps without a usable pose
  int tracked_frames_ = 0;           // consecutive steps with one
  bool relocalizing_ = false;
  bool relocalize_gave_up_ = false;  // until the pose is back: the phase goes on by odometry
  int64_t relocalize_start_us_ = 0;
  int relocalizations_ = 0;
  TrailShuttle relocalize_shuttle_;
  Eigen::Vector2d relocalize_fixation_ = Eigen::Vector2d::Zero();  // world, the floor point the head fixates
  int reachable_cells_ = 0;     // cells the last cost field reached
  int64_t goal_deadline_ = 0;
  int64_t next_replan_ = 0;
  std::vector<Eigen::Vector2d> visited_goals_;  // frontier goals reached or given up (not chosen again)
  int frontier_cells_near_visited_ = 0;           // frontier cells the last ChooseFrontier skipped for visited_goals_
  int visited_goal_resets_ = 0;                   // times visited_goals_ was forgotten because only they were left
  double path_at_visited_goal_reset_ = -1e9;     // mm, path_length_mm_ at the last reset
  static constexpr int kMaxVisitedGoalResets = 3;
  static constexpr double kVisitedGoalResetPathMm = 1000;
  std::vector<Eigen::Vector2d> investigate_spots_;
  // Rounds of 4 places given again to a candidate still unconfirmed once the room is explored (room_01, 7 Dec: the
  // sphere a candidate for 22 s, then "no target" with 134 s of the budget left).
  int candidate_rounds_ = 0;
  static constexpr int kMaxCandidateRounds = 2;
  static constexpr int64_t kInvestigateHoldUs = 5000000;  // µs, a candidate with nowhere to look from: look at it
  int64_t investigate_hold_until_ = -1;  // µs, until then (data time), shuttling on the trail with the head on it
  TrailShuttle investigate_shuttle_;
  int64_t candidate_missing_since_ = -1;
  int64_t last_map_change_us_ = -1;  // µs (data time), last map restart or pose back after a loss (-1: none)
  int64_t spots_reset_for_map_change_us_ = -1;  // last_map_change_us_ whose re-found candidate reset the places

  // ORBIT
  bool orbit_started_ = false;
  double orbit_progress_ = 0;   // rad, counter-clockwise azimuth driven plus the arcs bypasses skipped
  double orbit_last_azimuth_ = 0;
  std::vector<uint8_t> orbit_bins_ = std::vector<uint8_t>(360, 0);
  double orbit_radius_set_ = 0;
  bool orbit_bypass_ = false;
  // Bypasses that lead back to where the last one went without orbit progress (room_09: the same bypass goal every
  // 5.6 s for 255 s, until the frame budget ended the mission): after kMaxBypassRepeats the arc counts as blocked.
  Eigen::Vector2d last_bypass_goal_ = Eigen::Vector2d::Constant(1e12);
  double last_bypass_progress_ = 0;  // rad, orbit_progress_ when it was chosen
  int bypass_repeats_ = 0;
  int64_t bypass_deadline_ = 0;  // µs, data time by which the current bypass should have been driven
  // A bypass counts as the counter-clockwise arc it skips, whichever way its path goes round the target (room_09
  // rerun: bypasses east -> west -> east whose paths went clockwise took back the progress they made; the orbit
  // stood at 25 % for 150 s until the frame budget). < 0: the progress follows the base (a way back to the circle).
  double bypass_skip_rad_ = -1;      // rad, from the bypass's start to its goal, counter-clockwise
  double bypass_travelled_rad_ = 0;  // rad, azimuth driven since the bypass started (signed, per-frame sum)
  bool orbit_mapping_ = false;     // driving to unknown floor near the target (the circle ran into it)
  int orbit_mappings_ = 0;
  bool glancing_ = false;          // looking at the blocked arc ahead
  int64_t glance_start_ = 0;
  double glanced_azimuth_ = 0;     // rad, blocked point looked at last (when glances_ > 0)
  int glances_ = 0;
  int64_t lost_since_ = -1;
  // The lost-target search's shuttle on the trail (empty: too little trail, the search stands and sweeps the head).
  TrailShuttle search_shuttle_;
  int orbit_reported_quarter_ = 0;

  // NEXT_VIEWS
  enum class ViewStep { kChoose, kTravel, kAlign, kCapture } view_step_ = ViewStep::kChoose;
  std::set<int> used_views_;
  std::vector<NextViewRecord> next_views_;
  ViewCandidate current_view_;
  double capture_start_azimuth_ = 0;
  bool capture_clockwise_ = false;
  int64_t step_started_ = 0;
};

}  // namespace objscan
