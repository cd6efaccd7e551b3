// Closed-loop tests of the Planner in the toy world (toy_world.h): explore, find, approach, orbit, next views,
// finish; a room without a target; an obstacle on the orbit circle; a target lost during the orbit.
#include "processes/planner/planner.h"
#include "processes/planner/plan_report.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "processes/planner/toy_world.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct RunLog {
  Phase end_phase = Phase::kExplore;
  int64_t frames = 0;
  int collisions = 0;
  double min_clearance_mm = 1e9;    // footprint to the nearest true surface (mm)
  std::string min_clearance_where;
  bool commands_within_limits = true;
  std::string limit_violation;
  int64_t orbit_frames_checked = 0;    // ORBIT frames on the circle (settled, not paused or detouring)
  double orbit_max_radius_error_mm = 0;
  double orbit_max_off_axis_deg = 0;
  double orbit_max_off_axis_all_deg = 0;  // every ORBIT frame but pauses, glances ahead and bypasses (detours too)
  int64_t orbit_paused_frames = 0;
  int64_t orbit_frames = 0;
  double orbit_max_radius_mm = 0;      // truth, all ORBIT frames
  int64_t first_seq[6] = {-1, -1, -1, -1, -1, -1};  // first frame of each phase
  PlanSummary summary;
  double true_disagreement_mm = 0;     // |odometry - true base| at the end
  // Exploring (frontier paths and the look-around shuttle): the most the commanded camera yaw turned beyond what the
  // base's travel allows it (2 deg/s + 0.2 deg per mm), deg/s; and the frames that looked around.
  double explore_camera_turn_excess_deg_s = 0;
  int64_t look_around_frames = 0;
  bool backed_up = false;
  int64_t longest_push_frames = 0;  // frames in a row the planner drove a base that a solid held
  std::vector<std::string> events;  // the planner's events, "[seq] text"
  // Frames turning in place (> 5 deg/s, < 20 mm/s) with the pan command at its limit: the camera swept round with
  // the base, a pure rotation that loses the pose solver's map (the ten-room run's main cause of map restarts).
  int64_t pan_limit_turn_frames = 0;
  // The commanded camera yaw's largest swing while the base stands or turns in place (v = 0), deg: away from
  // its yaw when that stretch began, less 2 deg/s of its duration (the slow re-aim the pose solver follows); where
  // (phase / activity, frame). A camera swept round without travel sees unmapped scene without parallax and loses
  // the pose solver's map (rooms 03 and 04 on 41af2aa: 55 deg at 30 deg/s while the base turned, pan held). The
  // planner keeps the camera within 15 deg of a yaw that follows it only as travel allows: up to 30 deg from one
  // side of it to the other (before: 39-61 deg in 7 of these missions).
  double max_in_place_swing_deg = 0;
  std::string max_in_place_swing_where;
};

PlannerOptions TestOptions() {
  PlannerOptions o;
  o.map.size_mm = 12000;
  o.explore_budget_s = 240;
  return o;
}

// Where the room's target stands (mm, world); the origin when it has none.
Eigen::Vector2d TargetXy(const toy::Room& room) {
  for (const toy::Solid& s : room.solids)
    if (s.is_target) return s.centre_mm;
  return Eigen::Vector2d::Zero();
}

bool Verbose() { return std::getenv("PLANNER_TEST_VERBOSE") != nullptr; }

// Called every frame after the planner's step (may change the world, e.g. force the finder to lose the target).
using Hook = std::function<void(const Planner&, toy::ToyWorld&)>;

// The camera poses are INITIALIZING (unusable) for the first initializing_s seconds, as while the pose solver has
// not initialised its map.
// pose_status (when set) gives each camera pose's status instead (called before the step).
using PoseGate = std::function<PoseStatus(const toy::ToyWorld&)>;
RunLog RunMission(toy::ToyWorld& world, const PlannerOptions& options, int64_t max_frames, const Hook& hook = {},
                  double initializing_s = 0, const PoseGate& pose_status = {}) {
  RunLog log;
  Planner planner(options);
  planner.SetCamera(CameraIntrinsics{});
  const Eigen::Vector3d target = world.TargetCentre();
  int64_t orbit_start = -1;
  int64_t last_looking_away = -1000;
  double last_pan = 0;
  std::vector<MapLandmark> landmarks;
  VoxelCloud voxels;
  int64_t push_run = 0;
  double in_place_start_yaw = 0, in_place_s = -1;  // the camera yaw when the base last began to stand; -1: moving
  for (int64_t i = 0; i < max_frames; ++i) {
    planner.AddOdometry(world.Odometry());
    if (world.Landmarks(&landmarks)) planner.SetLandmarks(landmarks);
    planner.SetTarget(world.FindTarget());
    if (world.DenseModel(&voxels)) planner.SetVoxels(voxels);
    CameraPoseEstimate pose = world.CameraPose();
    if (world.utime() < initializing_s * 1e6) pose.status = PoseStatus::kInitializing;
    if (pose_status) pose.status = pose_status(world);
    const PlannerCommand c = planner.Step(pose);
    const int phase = static_cast<int>(planner.phase());
    if (log.first_seq[phase] < 0) log.first_seq[phase] = world.seq();
    for (const std::string& e : planner.TakeEvents()) {
      if (Verbose()) std::printf("[%7.2f s] %s\n", world.utime() * 1e-6, e.c_str());
      log.events.push_back("[" + std::to_string(world.seq()) + "] " + e);
      // The orbit starts on its circle (PlanToOrbit's radius is up to 400 mm more), never at a frontier the approach
      // explored (room_04, 7 Dec: "on the orbit circle (3601 mm from the target)", then no orbit and no model).
      const size_t at = e.find("on the orbit circle (");
      if (at != std::string::npos) {
        const double d = std::atof(e.c_str() + at + std::strlen("on the orbit circle ("));
        EXPECT_LE(d, options.orbit_radius_mm + 400 + 2 * 150) << e;
      }
    }
    if (!c.stop && planner.phase() == Phase::kExplore &&
        (planner.activity() == "frontier" || planner.activity() == "look around")) {
      const double dt = 1.0 / 30.0;
      const double camera_turn = std::abs(c.omega_rad_s * dt + WrapAngle(c.pan_rad - last_pan));
      const double allowed = (2 * kDeg + 0.2 * kDeg * std::abs(c.v_mm_s)) * dt;
      log.explore_camera_turn_excess_deg_s =
          std::max(log.explore_camera_turn_excess_deg_s, (camera_turn - allowed) / dt / kDeg);
      if (planner.activity() == "look around") ++log.look_around_frames;
      log.backed_up = log.backed_up || c.v_mm_s < -1;
    }
    if (!c.stop && std::abs(c.omega_rad_s) > 5 * kDeg && std::abs(c.v_mm_s) < 20 &&
        std::abs(c.pan_rad) > options.limits.max_pan_rad - 0.5 * kDeg)
      ++log.pan_limit_turn_frames;
    if (!c.stop) {
      const double dt = 1.0 / 30.0;  // the commanded yaw after this step's base turn
      const double yaw = world.truth().theta_rad + c.omega_rad_s * dt + c.pan_rad;
      if (std::abs(c.v_mm_s) >= 1 || planner.activity() == "look around (head only)") {
        in_place_s = -1;
      } else if (in_place_s < 0) {
        in_place_s = 0;
        in_place_start_yaw = world.truth().theta_rad + last_pan;
      } else {
        in_place_s += dt;
      }
      if (in_place_s >= 0) {
        const double swing = std::abs(WrapAngle(yaw - in_place_start_yaw)) / kDeg - 2 * in_place_s;
        if (swing > log.max_in_place_swing_deg) {
          log.max_in_place_swing_deg = swing;
          log.max_in_place_swing_where = std::string(PhaseName(planner.phase())) + " / " + planner.activity() +
                                         " at frame " + std::to_string(world.seq());
        }
      }
    }
    if (!c.stop) last_pan = c.pan_rad;
    if (!c.stop) {
      const bool ok = c.v_mm_s >= -100 && c.v_mm_s <= 400 && std::abs(c.omega_rad_s) <= 30 * kDeg + 1e-9 &&
                      std::abs(c.pan_rad) <= 170 * kDeg + 1e-9 && c.tilt_rad >= -1e-9 &&
                      c.tilt_rad <= 60 * kDeg + 1e-9;
      if (!ok && log.commands_within_limits) {
        log.commands_within_limits = false;
        log.limit_violation = "frame " + std::to_string(world.seq()) + ": v " + std::to_string(c.v_mm_s) +
                              " omega " + std::to_string(c.omega_rad_s) + " pan " + std::to_string(c.pan_rad) +
                              " tilt " + std::to_string(c.tilt_rad);
      }
    }
    if (planner.phase() == Phase::kOrbit) {
      if (orbit_start < 0) orbit_start = world.seq();
      const double radius = (world.truth().position() - target.head<2>()).norm();
      log.orbit_max_radius_mm = std::max(log.orbit_max_radius_mm, radius);
      // A glance at an unknown arc ahead and the bypass that follows it turn the camera away on purpose.
      const bool looking_away = planner.activity().find("paused") != std::string::npos ||
                                planner.activity().find("looking ahead") != std::string::npos ||
                                planner.activity().find("bypass") != std::string::npos;
      if (looking_away) last_looking_away = world.seq();
      // The head follows its command one frame late, and comes back from looking away at the tracking turn rate
      // (30 deg/s: up to 1.5 s).
      if (!looking_away && world.seq() - orbit_start > 15 && world.seq() - last_looking_away > 45)
        log.orbit_max_off_axis_all_deg =
            std::max(log.orbit_max_off_axis_all_deg, AngleOffAxis(world.WorldFromCamera(), target) / kDeg);
      if (planner.activity() != "orbit") {
        if (planner.activity().find("paused") != std::string::npos) ++log.orbit_paused_frames;
      } else if (world.seq() - orbit_start > 60 && world.seq() - last_looking_away > 45) {
        ++log.orbit_frames_checked;
        log.orbit_max_radius_error_mm = std::max(log.orbit_max_radius_error_mm, std::abs(radius - 800));
        log.orbit_max_off_axis_deg =
            std::max(log.orbit_max_off_axis_deg, AngleOffAxis(world.WorldFromCamera(), target) / kDeg);
      }
    }
    if (planner.phase() == Phase::kOrbit) ++log.orbit_frames;
    if (hook) hook(planner, world);
    if (world.Clearance(world.truth().position()) < log.min_clearance_mm) {
      log.min_clearance_mm = world.Clearance(world.truth().position());
      log.min_clearance_where = std::string(PhaseName(planner.phase())) + " / " + planner.activity() + " at frame " +
                                std::to_string(world.seq());
    }
    ++log.frames;
    if (planner.done()) break;
    const Eigen::Vector2d before = world.truth().position();
    world.Advance(c);
    // Pushing: told to drive, the base did not move (held by a solid).
    const bool pushing = !c.stop && std::abs(c.v_mm_s) > 20 && (world.truth().position() - before).norm() < 0.5;
    push_run = pushing ? push_run + 1 : 0;
    log.longest_push_frames = std::max(log.longest_push_frames, push_run);
  }
  EXPECT_LE(log.max_in_place_swing_deg, 32.0) << log.max_in_place_swing_where;
  log.end_phase = planner.phase();
  log.collisions = world.collisions();
  log.summary = planner.Summary();
  const OdometryReading odometry = world.Odometry();
  log.true_disagreement_mm = std::hypot(odometry.x_mm - world.truth().x_mm, odometry.y_mm - world.truth().y_mm);
  if (Verbose())
    std::printf("frames %lld, path %.0f mm, coverage %.3f (%d samples), orbit %.0f %%, next views %zu, "
                "min clearance %.0f mm (%s), safety stops %lld, orbit frames %lld (on the circle %lld, paused %lld), "
                "max radius error %.1f mm, max off-axis %.2f deg (%.2f deg off the circle too), glances %d, disagreement max %.0f mm %.2f deg, "
                "pan-limit turn frames %lld, reversals %lld, in-place camera swing %.1f deg (%s)\n",
                static_cast<long long>(log.frames), log.summary.path_length_mm, log.summary.coverage,
                log.summary.coverage_samples, log.summary.orbit_percent, log.summary.next_views.size(),
                log.min_clearance_mm, log.min_clearance_where.c_str(), static_cast<long long>(log.summary.safety_stops),
                static_cast<long long>(log.orbit_frames), static_cast<long long>(log.orbit_frames_checked),
                static_cast<long long>(log.orbit_paused_frames), log.orbit_max_radius_error_mm,
                log.orbit_max_off_axis_deg, log.orbit_max_off_axis_all_deg, log.summary.orbit_glances, log.summary.max_disagreement.distance_mm,
                log.summary.max_disagreement.angle_rad / kDeg, static_cast<long long>(log.pan_limit_turn_frames),
                static_cast<long long>(log.summary.pan_limit_reversals), log.max_in_place_swing_deg,
                log.max_in_place_swing_where.c_str());
  return log;
}

TEST(PlannerClosedLoopTest, ExploresFindsOrbitsAddsViewsAndFinishes) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  // The start does not face the target: it is outside the image and beyond the finder's 3 m.
  EXPECT_GT(AngleOffAxis(world.WorldFromCamera(), world.TargetCentre()), 90 * kDeg);
  EXPECT_GT((world.TargetCentre().head<2>() - world.truth().position()).norm(), 4000.0);
  const RunLog log = RunMission(world, options, 30 * 900);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_EQ(log.collisions, 0);
  EXPECT_GT(log.min_clearance_mm, 0.0);
  EXPECT_TRUE(log.commands_within_limits) << log.limit_violation;
  // Phases in order, each reached.
  for (int p = 0; p <= 4; ++p) EXPECT_GE(log.first_seq[p], 0) << PhaseName(static_cast<Phase>(p));
  for (int p = 1; p <= 4; ++p) EXPECT_GT(log.first_seq[p], log.first_seq[p - 1]) << PhaseName(static_cast<Phase>(p));
  // The orbit: on the circle within 50 mm, the target within 5 deg of the optical axis.
  EXPECT_GT(log.orbit_frames_checked, 300);
  EXPECT_LE(log.orbit_max_radius_error_mm, 50.0);
  EXPECT_LE(log.orbit_max_off_axis_deg, 5.0);
  EXPECT_LE(log.orbit_max_off_axis_all_deg, 5.0);
  EXPECT_GE(log.summary.orbit_percent, 95.0);
  // Next views raise the coverage.
  ASSERT_FALSE(log.summary.next_views.empty());
  EXPECT_GT(log.summary.coverage, log.summary.next_views.front().coverage_before + 0.05);
  EXPECT_TRUE(log.summary.target_confirmed);
  EXPECT_LT((log.summary.target.centre_mm - world.TargetCentre()).norm(), 15.0);
  // Disagreement reported: odometry drift (2 % scale, 0.5 deg/m) against the camera-based estimate; the last one
  // equals the true odometry error within the pose estimate's error (head encoder bias 0.5 deg, 40 mm lever).
  EXPECT_GT(log.summary.max_disagreement.distance_mm, 100.0);
  EXPECT_GE(log.summary.max_disagreement.distance_mm, log.true_disagreement_mm - 2.0);
}

// An object the sparse map never sees (no landmarks at all, as a plain untextured one) stands in the robot's way:
// the base is stopped against it (the simulator's contact), the planner feels it (odometry still while driving),
// marks it as an obstacle and goes around it instead of pushing again and again (room_05: 6 contacts with a plain
// cylinder, room_02: a plain sphere).
TEST(PlannerClosedLoopTest, AnObstacleTheMapCannotSeeIsFeltOnceAndAvoided) {
  const PlannerOptions options = TestOptions();
  toy::Room room = toy::MakeLivingRoom(true);
  const toy::ToyWorld probe(room, options.robot);
  const BasePose start = probe.truth();
  for (double ahead : {650.0, 1600.0}) {  // two invisible boxes on the start heading
    toy::Solid s;
    s.name = "plain_box_" + std::to_string(static_cast<int>(ahead));
    s.kind = toy::Solid::kBox;
    s.centre_mm = start.position() + ahead * Eigen::Vector2d(std::cos(start.theta_rad), std::sin(start.theta_rad));
    s.size_mm = Eigen::Vector3d(300, 300, 300);
    s.textured = false;
    s.invisible = true;
    room.solids.push_back(s);
  }
  toy::ToyWorld world(room, options.robot);
  const RunLog log = RunMission(world, options, 30 * 900);
  int contact_events = 0;
  for (const auto& e : log.events) contact_events += e.find("contact (") != std::string::npos;
  std::printf("contacts %d, blocked frames %d, end phase %s\n", log.summary.contacts, log.collisions,
              PhaseName(log.end_phase));
  EXPECT_GE(log.summary.contacts, 1);  // it was hit: nothing shows it before
  EXPECT_EQ(contact_events, log.summary.contacts);
  EXPECT_LE(log.summary.contacts, 6);           // each felt side is avoided afterwards
  EXPECT_LE(log.collisions, 30 * 2 * log.summary.contacts);  // about a second per contact, not pushing on
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
}

// A candidate the finder forgets because the sparse map restarted (its cluster was the old map's landmarks; room_10:
// the target was a candidate twice and "gone" both times right after a restart) is looked at again from where it
// was, so the new map gets points on it, instead of being given up after 5 s: the candidate comes back and is
// confirmed without exploring the room again.
TEST(PlannerClosedLoopTest, ACandidateForgottenAtAMapRestartIsLookedAtAgain) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  int64_t restart_seq = -1;
  const RunLog log = RunMission(world, options, 30 * 900, [&](const Planner& planner, toy::ToyWorld& w) {
    if (restart_seq < 0 && planner.activity() == "investigate candidate") {
      restart_seq = w.seq() + 15;
      w.ForceMapRestart(restart_seq);
    }
  });
  // No turn in place sweeps the camera round with the head at its pan limit (before the reversal: 25 frames).
  EXPECT_LE(log.pan_limit_turn_frames, 5);
  ASSERT_GE(restart_seq, 0) << "no candidate was investigated";
  // The first frame after EXPLORE (APPROACH may last no frame when the robot is already on the circle).
  int64_t confirmed = -1;
  for (int p = static_cast<int>(Phase::kApproach); p <= static_cast<int>(Phase::kFinish); ++p)
    if (log.first_seq[p] >= 0 && (confirmed < 0 || log.first_seq[p] < confirmed)) confirmed = log.first_seq[p];
  std::printf("restart at frame %lld, explore ended at frame %lld: %.1f s later\n",
              static_cast<long long>(restart_seq), static_cast<long long>(confirmed), (confirmed - restart_seq) / 30.0);
  for (const std::string& e : log.events)
    EXPECT_EQ(e.find("candidate gone"), std::string::npos) << e;
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  ASSERT_GT(confirmed, restart_seq);
  EXPECT_LT(confirmed - restart_seq, 30 * 30);  // 8 s in view to find it again, then views from 4 places (24 s here)
  EXPECT_EQ(log.collisions, 0);
}

// The living room with the start in a corner: a wall 0.7 m ahead and 0.7 m to the right.
toy::Room CornerStartRoom() {
  toy::Room room = toy::MakeLivingRoom(true);
  room.solids.erase(std::remove_if(room.solids.begin(), room.solids.end(),
                                   [](const toy::Solid& s) { return s.name.rfind("wall", 0) == 0 || s.name == "crate"; }),
                    room.solids.end());
  toy::AddWalls(&room, {-5200, -700}, {700, 3200});
  return room;
}

// Put down in a corner facing a wall (0.7 m ahead, 0.7 m to the right), the robot cannot reach anything it has seen:
// it looks around by shuttling back and forth on the floor it came from while the head sweeps, never turning the
// camera faster than it travels (a turn in place onto unmapped floor loses the pose solver's track), then explores
// and finds the target as from an open start.
TEST(PlannerClosedLoopTest, CornerStartLooksAroundWhileShuttlingAndFindsTheTarget) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(CornerStartRoom(), options.robot);
  const RunLog log = RunMission(world, options, 30 * 900);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_EQ(log.collisions, 0);
  EXPECT_TRUE(log.commands_within_limits) << log.limit_violation;
  EXPECT_GT(log.look_around_frames, 0);
  EXPECT_TRUE(log.backed_up);
  EXPECT_LE(log.explore_camera_turn_excess_deg_s, 0.01);
  EXPECT_TRUE(log.summary.target_confirmed);
  // The shuttle reverses and drives on within a second: no contact is felt where nothing was touched (room_06: a
  // false contact behind the start boxed the robot in for the rest of its run).
  EXPECT_EQ(log.summary.contacts, 0);
}

// The pose solver's rule for a new map after a loss (pose_estimator.cpp TryInitialize): a span since the base last
// stood still (< 20 mm/s) with >= 50 mm of camera travel and >= 8 deg of camera rotation. Poses are LOST from the
// first frame `lose` says so until such a span has passed, and for at least min_lost_frames (a span begins after
// them).
class FakeReinitialization {
 public:
  FakeReinitialization(std::function<bool()> lose, int64_t min_lost_frames)
      : lose_(std::move(lose)), min_lost_frames_(min_lost_frames) {}
  PoseStatus operator()(const toy::ToyWorld& world) {
    const Eigen::Isometry3d camera = world.WorldFromCamera();
    const Eigen::Vector2d base = world.truth().position();
    if (!lost_ && !lost_once_ && lose_()) {
      lost_ = lost_once_ = true;
      lost_at_ = world.seq();
      span_start_ = camera;
      travel_ = turn_ = 0;
    } else if (lost_) {
      if ((base - last_base_).norm() * 30 < 20 || world.seq() - lost_at_ < min_lost_frames_) {  // span starts again
        span_start_ = camera;
        travel_ = turn_ = 0;
      }
      travel_ = std::max(travel_, (camera.translation() - span_start_.translation()).norm());
      turn_ = std::max(turn_, Eigen::AngleAxisd(span_start_.linear().transpose() * camera.linear()).angle());
      if (travel_ >= 50 && turn_ >= 8 * kDeg) {
        lost_ = false;
        lost_frames_ = world.seq() - lost_at_;
      }
    }
    last_base_ = base;
    return lost_ ? PoseStatus::kLost : PoseStatus::kTracking;
  }
  bool lost_once() const { return lost_once_; }
  bool lost() const { return lost_; }
  int64_t lost_frames() const { return lost_frames_; }

 private:
  std::function<bool()> lose_;
  bool lost_ = false, lost_once_ = false;
  int64_t min_lost_frames_ = 0;
  int64_t lost_at_ = 0, lost_frames_ = -1;
  Eigen::Isometry3d span_start_ = Eigen::Isometry3d::Identity();
  Eigen::Vector2d last_base_ = Eigen::Vector2d::Zero();
  double travel_ = 0, turn_ = 0;
};

// Tracking lost in the middle of the corner start's look-around (room_07: lost in a head-only sweep, and no new map
// in the 1 420 frames after, because nothing moved the base). The look-around's legs on the trail give a new map its
// span; when the pose stays lost for 1 s more, the planner retraces its trail with the head fixating a floor point.
// Either way the pose is back within seconds and the mission goes on.
TEST(PlannerClosedLoopTest, PoseLostWhileLookingAroundRetracesTheTrailUntilANewMap) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(CornerStartRoom(), options.robot);
  int look_around_frames = 0;
  auto gate = std::make_shared<FakeReinitialization>([&] { return look_around_frames > 45; }, 30);
  const RunLog log = RunMission(
      world, options, 30 * 900,
      [&](const Planner& planner, toy::ToyWorld&) {
        if (planner.activity().rfind("look around", 0) == 0) ++look_around_frames;
      },
      0, [gate](const toy::ToyWorld& w) { return (*gate)(w); });
  ASSERT_TRUE(gate->lost_once());
  EXPECT_FALSE(gate->lost());
  EXPECT_GT(gate->lost_frames(), 0);
  EXPECT_LT(gate->lost_frames(), 30 * 10);  // the new map's span within 10 s
  EXPECT_GE(log.summary.relocalizations, 1);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_EQ(log.collisions, 0);
  EXPECT_TRUE(log.commands_within_limits) << log.limit_violation;
}

// The finder drops the confirmed target during the next views (after the whole orbit): the mission ends with the
// model so far (FINISH) instead of exploring again.
TEST(PlannerClosedLoopTest, TargetDroppedAfterTheOrbitEndsTheMissionWithItsModel) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  bool dropped = false;
  const RunLog log = RunMission(world, options, 30 * 900, [&](const Planner& planner, toy::ToyWorld& w) {
    if (!dropped && planner.phase() == Phase::kNextViews) {
      w.ForceDropped(w.seq() + 1);
      dropped = true;
    }
  });
  ASSERT_TRUE(dropped);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_TRUE(log.summary.target_confirmed);
  EXPECT_GE(log.summary.orbit_percent, 95.0);
  EXPECT_EQ(log.collisions, 0);
}

TEST(PlannerClosedLoopTest, NoUsablePoseForTheFirst30SecondsOnlyDelaysTheSearch) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  const RunLog log = RunMission(world, options, 30 * 900, {}, 30.0);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_EQ(log.collisions, 0);
  EXPECT_GT(log.first_seq[static_cast<int>(Phase::kApproach)], 30 * 30);
  EXPECT_GE(log.summary.orbit_percent, 95.0);
}

TEST(PlannerClosedLoopTest, RoomWithoutTargetEndsInNoTargetWithinTheBudget) {
  PlannerOptions options = TestOptions();
  options.explore_budget_s = 180;
  toy::ToyWorld world(toy::MakeLivingRoom(false), options.robot);
  const RunLog log = RunMission(world, options, 30 * 400);
  EXPECT_EQ(log.end_phase, Phase::kNoTarget) << PhaseName(log.end_phase);
  EXPECT_LE(log.frames, 30 * 180 + 2);  // ended by the budget at the latest
  EXPECT_EQ(log.collisions, 0);
  EXPECT_TRUE(log.commands_within_limits) << log.limit_violation;
  EXPECT_FALSE(log.summary.target_confirmed);
  EXPECT_GT(log.summary.path_length_mm, 5000.0);  // it did search
}

// The finder reports the target as a candidate but never confirms it (here: it would need 100000 places). Once the
// room is explored, the candidate is the only lead: it gets 2 more rounds of 4 places before the mission ends in
// NO_TARGET with a message that names it (room_01, 7 Dec: the sphere a candidate for 22 s, then "no target" with
// 134 s of the exploration budget left).
TEST(PlannerClosedLoopTest, ACandidateStillUnconfirmedWhenTheRoomIsExploredGetsMoreRounds) {
  PlannerOptions options = TestOptions();
  options.explore_budget_s = 400;
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  world.SetPlacesToConfirm(100000);
  const RunLog log = RunMission(world, options, 30 * 450);
  // No turn in place sweeps the camera round with the head at its pan limit (before the reversal: 178 frames).
  EXPECT_LE(log.pan_limit_turn_frames, 5);
  EXPECT_EQ(log.end_phase, Phase::kNoTarget) << PhaseName(log.end_phase);
  int rounds = 0, gave_up = 0;
  for (const std::string& e : log.events) {
    if (e.find("not confirmed yet: looking at it again from new places") != std::string::npos) ++rounds;
    if (e.find("candidate not confirmed from 4 places") != std::string::npos) ++gave_up;
  }
  EXPECT_EQ(rounds, 2);
  EXPECT_GE(gave_up, 3);  // the first round and the two given again
  const std::string& last = log.events.empty() ? std::string() : log.events.back();
  EXPECT_NE(last.find("never confirmed: no target found"), std::string::npos) << last;
  EXPECT_EQ(log.collisions, 0);
  EXPECT_LE(log.frames, 30 * 400 + 2);
}

// The target stands in the middle of a plain carpet (untextured: landmarks on its edges only, the floor under it hidden),
// so the map never shows the floor of the orbit circle as free: the approach can only explore frontiers. Reaching
// one must not start the orbit there (room_04, 7 Dec: "on the orbit circle (3601 mm from the target)" at a frontier
// goal, then no orbit and an empty model); RunMission checks every orbit start against the circle's radius. The
// approach ends after its budget; the mission ends without an orbit, as "partial", and says why.
TEST(PlannerClosedLoopTest, ACircleTheMapCannotReachEndsTheApproachAfterItsBudgetWithoutAnOrbit) {
  PlannerOptions options = TestOptions();
  options.explore_budget_s = 200;
  options.map.free_support_mm = 250;  // the circle (<= 1.2 m) lies >= 350 mm inside the carpet: never free
  toy::Room room = toy::MakeLivingRoom(true);
  const Eigen::Vector2d target_xy = TargetXy(room);
  toy::Solid carpet;
  carpet.name = "plain_carpet";
  carpet.centre_mm = target_xy + Eigen::Vector2d(-100, 0);
  carpet.size_mm = Eigen::Vector3d(3300, 3600, 5);  // edges >= 1.55 m from the target, clear of the table
  carpet.drivable = true;
  carpet.textured = false;
  room.solids.push_back(carpet);
  toy::ToyWorld world(room, options.robot);
  const RunLog log = RunMission(world, options, 30 * 300);
  // No turn in place sweeps the camera round with the head at its pan limit (before the reversal: 298 frames).
  EXPECT_LE(log.pan_limit_turn_frames, 5);
  int approach_explores = 0;
  for (const std::string& e : log.events)
    approach_explores += e.find("approach: the orbit circle is not reachable yet: exploring") != std::string::npos;
  std::printf("end %s after %.1f s, orbit frames %lld, path %.0f mm\n", PhaseName(log.end_phase), log.frames / 30.0,
              static_cast<long long>(log.orbit_frames), log.summary.path_length_mm);
  const int64_t approach = log.first_seq[static_cast<int>(Phase::kApproach)];
  ASSERT_GE(approach, 0) << "the target was never confirmed";
  EXPECT_GE(approach_explores, 1);
  EXPECT_EQ(log.orbit_frames, 0) << "an orbit started away from the circle";
  // The approach gives up after its budget (not at the frame limit) and the run ends as a failure that says why.
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  const int64_t finish = log.first_seq[static_cast<int>(Phase::kFinish)];  // NEXT_VIEWS had no view to add
  EXPECT_NEAR((finish - approach) / 30.0, options.approach_budget_s, 2.0);  // it explored from the start
  EXPECT_EQ(PlanOutcome(log.summary), "partial");
  bool says_why = false;
  for (const std::string& e : log.events) says_why = says_why || e.find("orbit circle was not reachable for") != std::string::npos;
  EXPECT_TRUE(says_why);
  EXPECT_EQ(log.collisions, 0);
}

// A bench across the circle north of the target, from the target to the wall: the bypass past it can only go all the
// way round, clockwise (backwards). A bypass counts as the arc it skips, not as the way its path goes round (room_09
// rerun: a bypass of 69 deg counter-clockwise drove 290 deg clockwise, past the target, taking back the progress the
// orbit had made; the orbit took 157 s).
TEST(PlannerClosedLoopTest, ABypassBackwardsRoundTheTargetCountsTheArcItSkips) {
  const PlannerOptions options = TestOptions();
  toy::Room room = toy::MakeLivingRoom(true);
  const Eigen::Vector2d target_xy = TargetXy(room);
  toy::Solid bench;
  bench.name = "bench";
  // From 250 mm north of the target's centre to the wall: no way past it on that side, inside or outside the circle.
  bench.centre_mm = Eigen::Vector2d(target_xy.x(), 0.5 * (target_xy.y() + 250 + room.max_mm.y()));
  bench.size_mm = Eigen::Vector3d(300, room.max_mm.y() - (target_xy.y() + 250), 400);
  room.solids.push_back(bench);
  toy::ToyWorld world(room, options.robot);
  const RunLog log = RunMission(world, options, 30 * 600);
  // No turn in place sweeps the camera round with the head at its pan limit (before the reversal: 65 frames).
  EXPECT_LE(log.pan_limit_turn_frames, 5);
  int bypasses = 0;
  bool complete = false;
  for (const std::string& e : log.events) {
    bypasses += e.find("bypass to") != std::string::npos;
    complete = complete || e.find("orbit complete") != std::string::npos;
  }
  std::printf("end %s after %.1f s, orbit %.0f %%, bypasses %d\n", PhaseName(log.end_phase), log.frames / 30.0,
              log.summary.orbit_percent, bypasses);
  EXPECT_GE(bypasses, 1) << "the circle was not blocked: the test does not test anything";
  EXPECT_TRUE(complete) << "the orbit did not come round";
  EXPECT_LE(bypasses, 2);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
}

// An unjoined map restart in the middle of the search (the pose solver's map starts again from nothing): the search
// goes on over the new map, with the old map's obstacles remembered, until the room is explored again; it neither
// ends early nor drives into what the new map has not seen yet.
TEST(PlannerClosedLoopTest, AMapRestartDuringTheSearchExploresTheRoomAgain) {
  PlannerOptions options = TestOptions();
  options.explore_budget_s = 300;
  toy::ToyWorld undisturbed(toy::MakeLivingRoom(false), options.robot);
  const RunLog reference = RunMission(undisturbed, options, 30 * 400);
  ASSERT_EQ(reference.end_phase, Phase::kNoTarget) << PhaseName(reference.end_phase);
  for (const double restart_s : {30.0, 90.0}) {
    toy::ToyWorld world(toy::MakeLivingRoom(false), options.robot);
    world.ForceMapRestart(static_cast<int64_t>(restart_s * 30));
    const RunLog log = RunMission(world, options, 30 * 400);
    std::printf("restart at %.0f s: %s after %.1f s, path %.0f mm (%.0f mm without the restart)\n", restart_s,
                PhaseName(log.end_phase), log.frames / 30.0, log.summary.path_length_mm,
                reference.summary.path_length_mm);
    EXPECT_EQ(log.end_phase, Phase::kNoTarget) << "restart at " << restart_s << " s";
    EXPECT_GT(log.summary.path_length_mm, reference.summary.path_length_mm) << "restart at " << restart_s << " s";
    EXPECT_EQ(log.collisions, 0) << "restart at " << restart_s << " s";
    EXPECT_TRUE(log.commands_within_limits) << log.limit_violation;
  }
}

TEST(PlannerClosedLoopTest, ObstacleOnTheCircleIsPassedOutsideWithoutCollision) {
  const PlannerOptions options = TestOptions();
  toy::Room room = toy::MakeLivingRoom(true);
  toy::Solid post;
  post.name = "post";
  post.kind = toy::Solid::kCylinder;
  post.centre_mm = Eigen::Vector2d(-3800, 800);  // on the orbit circle, south of the target
  post.size_mm = Eigen::Vector3d(240, 240, 500);
  room.solids.push_back(post);
  toy::ToyWorld world(room, options.robot);
  const RunLog log = RunMission(world, options, 30 * 900);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_EQ(log.collisions, 0);
  EXPECT_GT(log.min_clearance_mm, 0.0);
  EXPECT_GE(log.summary.orbit_percent, 90.0);
  EXPECT_GT(log.orbit_max_radius_mm, 800 + 120 + 200.0);  // went round the post
  EXPECT_LE(log.orbit_max_radius_error_mm, 50.0);          // and back on the circle
  EXPECT_LE(log.orbit_max_off_axis_all_deg, 5.0);          // the head on the target all along
}

// A 20 mm sill across the way: its landmarks lie in the map's floor band, so the map shows free floor, but the base
// cannot cross it (the simulator holds it). The planner notices that the base does not move and plans again instead
// of pushing until a goal's deadline (room_08's base stood against a table for 6 367 frames).
TEST(PlannerClosedLoopTest, ABaseHeldByWhatTheMapDoesNotShowIsNotPushedForLong) {
  const PlannerOptions options = TestOptions();
  toy::Room room = toy::MakeLivingRoom(true);
  toy::Solid sill;
  sill.name = "sill";
  sill.centre_mm = Eigen::Vector2d(-1000, 700);  // wall to wall: the west half is behind it
  sill.size_mm = Eigen::Vector3d(100, 5000, 20);
  room.solids.push_back(sill);
  toy::ToyWorld world(room, options.robot);
  const RunLog log = RunMission(world, options, 30 * 300);
  std::printf("longest push %lld frames, collisions %d, end %s\n", static_cast<long long>(log.longest_push_frames),
              log.collisions, PhaseName(log.end_phase));
  EXPECT_GT(log.collisions, 0) << "the sill was not in the way: the test does not test anything";
  EXPECT_LE(log.longest_push_frames, 4 * 30);  // 3 s, and the frame that replans
}

TEST(PlannerClosedLoopTest, TargetLostDuringTheOrbitPausesAndResumes) {
  const PlannerOptions options = TestOptions();
  toy::ToyWorld world(toy::MakeLivingRoom(true), options.robot);
  int64_t lost_from = -1;
  Eigen::Vector2d at_loss;
  double moved_while_lost = 0, off_axis_while_lost_deg = 0;
  const Eigen::Vector3d target = world.TargetCentre();
  const RunLog log = RunMission(world, options, 30 * 900, [&](const Planner& planner, toy::ToyWorld& w) {
    if (planner.phase() == Phase::kOrbit && lost_from < 0 && planner.activity() == "orbit") {
      lost_from = w.seq() + 150;  // 5 s into the orbit, for 4 s
      w.ForceLost(lost_from, lost_from + 120);
    }
    if (w.seq() == lost_from + 5) at_loss = w.truth().position();  // the pause takes effect one frame late
    if (lost_from >= 0 && w.seq() > lost_from + 5 && w.seq() < lost_from + 120) {
      moved_while_lost = std::max(moved_while_lost, (w.truth().position() - at_loss).norm());
      off_axis_while_lost_deg =
          std::max(off_axis_while_lost_deg, AngleOffAxis(w.WorldFromCamera(), target) / kDeg);
    }
  });
  ASSERT_GE(lost_from, 0);
  EXPECT_GE(log.orbit_paused_frames, 100);
  // The search shuttles on the trail (400 mm legs) with the head on the target, then the orbit goes on.
  EXPECT_GT(moved_while_lost, 50.0);
  EXPECT_LT(moved_while_lost, 450.0);
  EXPECT_LT(off_axis_while_lost_deg, 5.0);
  EXPECT_EQ(log.end_phase, Phase::kFinish) << PhaseName(log.end_phase);
  EXPECT_GE(log.summary.orbit_percent, 95.0);
  EXPECT_EQ(log.collisions, 0);
}

}  // namespace
}  // namespace objscan

namespace objscan {
namespace {

// The finder confirmed something that later views rejected (it drops it: SEARCHING): the planner must not go on
// circling it but explore again, and take the next confirmed target.
TEST(PlannerTargetTest, DroppedConfirmedTargetSendsTheRobotExploringAgain) {
  toy::ToyWorld world(toy::MakeLivingRoom(true), TestOptions().robot);
  Planner planner(TestOptions());
  planner.SetCamera(CameraIntrinsics{});
  TargetObservation phantom;
  phantom.state = TargetState::kConfirmed;
  phantom.centre_mm = Eigen::Vector3d(world.truth().x_mm + 1500, world.truth().y_mm, 100);
  phantom.size_mm = Eigen::Vector3d(150, 150, 150);
  auto step = [&]() {
    planner.AddOdometry(world.Odometry());
    planner.Step(world.CameraPose());
  };
  step();
  planner.SetTarget(phantom);
  step();
  EXPECT_EQ(planner.phase(), Phase::kApproach);
  TargetObservation dropped;
  dropped.state = TargetState::kSearching;
  planner.SetTarget(dropped);
  step();
  EXPECT_EQ(planner.phase(), Phase::kExplore);
  EXPECT_FALSE(planner.Summary().target_confirmed);
  bool said = false;
  for (const std::string& e : planner.TakeEvents()) said = said || e.find("dropped the confirmed target") != std::string::npos;
  EXPECT_TRUE(said);
  planner.SetTarget(phantom);  // a target confirmed again is taken
  step();
  EXPECT_EQ(planner.phase(), Phase::kApproach);
}

// A candidate with no free place to look from (no map yet around it, as just after a map restart): the robot looks
// at it from its trail for 5 s per place instead of using up its 4 places at once (room_10: 0.2 s), and gives up
// after the 4th with a word.
TEST(PlannerTargetTest, ACandidateWithNowhereToLookFromIsWatchedForFiveSecondsPerPlace) {
  toy::ToyWorld world(toy::MakeLivingRoom(true), TestOptions().robot);
  Planner planner(TestOptions());
  planner.SetCamera(CameraIntrinsics{});
  TargetObservation candidate;
  candidate.state = TargetState::kCandidate;
  candidate.centre_mm = Eigen::Vector3d(world.truth().x_mm + 1200, world.truth().y_mm, 100);
  candidate.size_mm = Eigen::Vector3d(150, 150, 150);
  int holds = 0;
  double gave_up_s = -1;
  for (int i = 0; i < 30 * 30 && gave_up_s < 0; ++i) {
    planner.AddOdometry(world.Odometry());
    planner.SetTarget(candidate);  // no landmarks: the map stays unknown
    const PlannerCommand c = planner.Step(world.CameraPose());
    for (const std::string& e : planner.TakeEvents()) {
      if (e.find("no free place to see the candidate from") != std::string::npos) ++holds;
      if (e.find("candidate not confirmed from 4 places") != std::string::npos) gave_up_s = i / 30.0;
    }
    if (gave_up_s < 0) {
      EXPECT_EQ(planner.activity(), "investigate candidate") << "frame " << i;
    }
    world.Advance(c);
  }
  EXPECT_EQ(holds, 4);
  EXPECT_GE(gave_up_s, 19.5);
  EXPECT_LE(gave_up_s, 21.0);
  EXPECT_EQ(world.collisions(), 0);
}

// A plan that finished with less coverage than min_coverage is "partial" (a failure the session reports: room_04,
// 7 Dec, ended "modeled" with 52 % coverage, the model 48.5 % of the target and its centre 26 mm off); the rest keep
// their outcomes, and plan.json carries the limit.
TEST(PlanReport, AFinishBelowTheMinimumCoverageIsPartial) {
  PlanSummary s;
  s.phase = Phase::kFinish;
  s.min_coverage = 0.7;
  s.coverage = 0.523;
  EXPECT_EQ(PlanOutcome(s), "partial");
  s.coverage = 0.7;
  EXPECT_EQ(PlanOutcome(s), "modeled");
  s.phase = Phase::kNoTarget;
  s.coverage = 0;
  EXPECT_EQ(PlanOutcome(s), "no_target");
  s.phase = Phase::kOrbit;
  EXPECT_EQ(PlanOutcome(s), "stopped");
  EXPECT_NE(PlanJson(s, 0).find("\"min_coverage\": 0.7000"), std::string::npos) << PlanJson(s, 0);
  PlannerOptions bad;
  bad.min_coverage = 1.5;
  std::string why;
  EXPECT_FALSE(ValidatePlannerOptions(bad, &why));
  EXPECT_NE(why.find("min coverage"), std::string::npos) << why;
  bad.min_coverage = 0.8;
  bad.coverage_target = 0.7;
  EXPECT_FALSE(ValidatePlannerOptions(bad, &why));
  EXPECT_NE(why.find("<= the coverage target"), std::string::npos) << why;
}

}  // namespace

}  // namespace objscan
