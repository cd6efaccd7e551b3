#include "drivers/robot_sim/footprint.h"

#include <gtest/gtest.h>

#include <cmath>

#include "drivers/robot_sim/robot_sim.h"

namespace objscan {
namespace {

constexpr double kStepMm = 10;  // 300 mm/s at 30 Hz

Scene SceneOf(const std::string& text) { return ParseScene(text, OBJSCAN_ROBOT_SIM_SCENES_DIR); }

RobotSimOptions CommandOptions() {
  RobotSimOptions o;
  o.mode = "command";
  o.frames = 0;
  o.command_timeout_us = 0;  // commands hold until replaced
  return o;
}

SimCommand Velocity(double v_mm_s, double omega_rad_s) {
  SimCommand c;
  c.mode = SimCommand::kVelocity;
  c.v_mm_s = v_mm_s;
  c.omega_rad_s = omega_rad_s;
  return c;
}

// Runs `frames` frames under one command; returns the last frame.
SimFrame Drive(RobotSimulator* sim, const SimCommand& command, int frames) {
  sim->SetCommand(command, sim->UtimeOf(sim->frames_produced()));
  SimFrame f;
  for (int i = 0; i < frames; ++i) f = sim->Step();
  return f;
}

TEST(FootprintTest, FloorFootprintsOfEveryShape) {
  const Scene scene = SceneOf(
      "floor size=10000\n"
      "box name=crate center=1000,0,250 size=400,200,500 yaw=30\n"
      "cylinder name=pillar center=-1000,0,500 radius=250 height=1000\n"
      "sphere name=ball center=0,1000,150 radius=150 target=true\n"
      "mesh name=blob file=blob.ply center=0,-1000,0 scale=1.2 yaw=20\n"
      "box name=rug center=0,0,2.5 size=1000,700,5\n");
  const std::vector<FloorObstacle> obstacles = FloorObstacles(scene);
  ASSERT_EQ(obstacles.size(), 4u);  // the floor and the 5 mm rug are driven over
  EXPECT_EQ(obstacles[0].name, "crate");
  EXPECT_EQ(obstacles[3].name, "blob");
  // box: a yawed rectangle; points given in its own frame
  const Eigen::Rotation2Dd yaw(30 * M_PI / 180);
  auto crate_point = [&](double x, double y) -> Eigen::Vector2d {
    return Eigen::Vector2d(1000, 0) + yaw * Eigen::Vector2d(x, y);
  };
  EXPECT_NEAR(obstacles[0].SignedDistance(crate_point(300, 0)), 100, 1e-9);                   // in front of the +x face
  EXPECT_NEAR(obstacles[0].SignedDistance(crate_point(0, -250)), 150, 1e-9);                  // beside the -y face
  EXPECT_NEAR(obstacles[0].SignedDistance(crate_point(230, 130)), std::hypot(30, 30), 1e-9);  // off a corner
  EXPECT_NEAR(obstacles[0].SignedDistance(crate_point(150, 0)), -50, 1e-9);                   // inside, 50 mm deep
  // cylinder and sphere: circles of their radius
  EXPECT_TRUE(obstacles[1].is_circle);
  EXPECT_NEAR(obstacles[1].SignedDistance(Eigen::Vector2d(-1000, 400)), 150, 1e-9);
  EXPECT_NEAR(obstacles[2].SignedDistance(Eigen::Vector2d(0, 1000)), -150, 1e-9);
  // mesh: the convex hull of the placed vertices contains every vertex and touches the extreme ones
  const SceneObject& blob = scene.objects[4];
  ASSERT_GE(obstacles[3].polygon_mm.size(), 8u);
  double max_inside = -1e9;
  for (const Eigen::Vector3f& p : blob.mesh.positions)
    max_inside = std::max(max_inside, obstacles[3].SignedDistance(p.head<2>().cast<double>()));
  EXPECT_LT(max_inside, 1e-6);
  EXPECT_GT(max_inside, -1e-6);  // hull vertices are mesh vertices
  const Eigen::Vector2d east(blob.bounds.max().x() + 10, blob.bounds.center().y());
  EXPECT_GT(obstacles[3].SignedDistance(east), 9.99);
  // segments
  EXPECT_TRUE(obstacles[1].IntersectsSegment(Eigen::Vector2d(-2000, 0), Eigen::Vector2d(0, 0)));
  EXPECT_FALSE(obstacles[1].IntersectsSegment(Eigen::Vector2d(-2000, 300), Eigen::Vector2d(0, 300)));
  EXPECT_TRUE(obstacles[0].IntersectsSegment(Eigen::Vector2d(0, 0), Eigen::Vector2d(2000, 0)));
  EXPECT_FALSE(obstacles[0].IntersectsSegment(Eigen::Vector2d(0, 600), Eigen::Vector2d(2000, 600)));
}

TEST(FootprintTest, ConvexHullOfASquareWithInteriorAndCollinearPoints) {
  const std::vector<Eigen::Vector2d> hull =
      ConvexHull({{0, 0}, {1, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5, 1.5}, {2, 1}, {0, 0}});
  ASSERT_EQ(hull.size(), 4u);
  double area = 0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d& a = hull[i];
    const Eigen::Vector2d& b = hull[(i + 1) % hull.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  EXPECT_NEAR(area / 2, 4.0, 1e-12);  // positive: counter-clockwise
}

TEST(FootprintTest, ContactCounterCountsEpisodesNotFrames) {
  using F = ContactCounter::Frame;
  ContactCounter c;
  for (F f : {F::kFree, F::kBlocked, F::kBlocked, F::kIdle, F::kBlocked, F::kFree, F::kIdle, F::kBlocked}) c.Record(f);
  EXPECT_EQ(c.collisions(), 2);
  EXPECT_EQ(c.blocked_frames(), 4);
  EXPECT_TRUE(c.in_contact());
  EXPECT_FALSE(c.Record(F::kBlocked));  // still the same contact
  EXPECT_FALSE(c.Record(F::kFree));
  EXPECT_TRUE(c.Record(F::kBlocked));  // a new one
}

TEST(FootprintTest, DrivingFaceOnStopsWithinAStepAndReportsNoTranslation) {
  // The box's -x face is at x = 800: the 200 mm footprint touches it when the base centre reaches x = 600.
  const Scene scene = SceneOf(
      "sphere name=t center=0,3000,100 radius=100 target=true\n"
      "box name=crate center=1000,0,250 size=400,400,500\nrobot start=0,0,0\n");
  RobotSimulator sim(scene, CommandOptions());  // default odometry errors
  SimFrame f = sim.Step();
  EXPECT_EQ(f.truth.x_mm, 0);
  int blocked = 0;
  double odo_x_at_contact = 0;
  sim.SetCommand(Velocity(300, 0), f.utime);
  for (int i = 0; i < 120; ++i) {  // 4 s: 1200 mm of commanded travel
    f = sim.Step();
    if (f.blocked) {
      if (blocked == 0) {
        odo_x_at_contact = f.odometry.x_mm;
        EXPECT_TRUE(f.new_collision);
        EXPECT_EQ(f.collision_object, 1);
      } else {
        EXPECT_FALSE(f.new_collision);
        EXPECT_EQ(f.odometry.x_mm, odo_x_at_contact);  // the odometry measures no translation
        EXPECT_EQ(f.truth.v_mm_s, 0);
      }
      ++blocked;
    }
  }
  EXPECT_LE(f.truth.x_mm, 600.0 + 1e-9);
  EXPECT_GE(f.truth.x_mm, 600.0 - kStepMm - 1e-9);
  EXPECT_EQ(f.truth.y_mm, 0);
  EXPECT_GE(sim.footprint().Clearance(Eigen::Vector2d(f.truth.x_mm, f.truth.y_mm)), 0);
  EXPECT_EQ(sim.collisions(), 1);
  EXPECT_EQ(sim.blocked_frames(), blocked);
  EXPECT_GE(blocked, 55);  // 600 mm took ~60 frames; the rest pushed against the box
  EXPECT_NEAR(sim.path_length_mm(), f.truth.x_mm, 1e-9);
}

TEST(FootprintTest, DrivingAtAnAngleStopsWithinAStepOfTheFace) {
  // A long box whose -x face is at x = 800; the base heads 30 deg off the face normal.
  const Scene scene = SceneOf(
      "sphere name=t center=-2000,0,100 radius=100 target=true\n"
      "box name=wall center=1000,0,500 size=400,3000,1000\nrobot start=0,0,30\n");
  RobotSimulator sim(scene, CommandOptions());
  SimFrame f = Drive(&sim, Velocity(300, 0), 1);
  f = Drive(&sim, Velocity(300, 0), 150);
  EXPECT_LE(f.truth.x_mm, 600.0 + 1e-9);
  EXPECT_GE(f.truth.x_mm, 600.0 - kStepMm * std::cos(M_PI / 6) - 1e-9);
  EXPECT_NEAR(f.truth.y_mm, f.truth.x_mm * std::tan(M_PI / 6), 1e-6);  // stopped on its line
  EXPECT_NEAR(f.truth.theta_rad, M_PI / 6, 1e-12);
  EXPECT_EQ(sim.collisions(), 1);
}

TEST(FootprintTest, TurningInContactAndBackingAwayAreAllowed) {
  const Scene scene = SceneOf(
      "sphere name=t center=0,3000,100 radius=100 target=true\n"
      "box name=crate center=1000,0,250 size=400,400,500\nrobot start=0,0,0\n");
  RobotSimulator sim(scene, CommandOptions());
  SimFrame f = Drive(&sim, Velocity(300, 0), 91);
  ASSERT_TRUE(f.blocked);
  const double x_contact = f.truth.x_mm;
  // turn in place in contact: the heading changes, the position does not, no new collision, no blocked frame
  const int64_t blocked_before = sim.blocked_frames();
  f = Drive(&sim, Velocity(0, 0.5), 31);
  EXPECT_EQ(f.truth.x_mm, x_contact);
  EXPECT_NEAR(f.truth.theta_rad, 0.5 * 30 / 30.0, 1e-9);  // the first of the 31 frames still had the old command
  EXPECT_EQ(sim.blocked_frames(), blocked_before + 1);
  EXPECT_EQ(sim.collisions(), 1);
  // turning while pushing forward: the heading still turns, the position stays
  f = Drive(&sim, Velocity(300, 0.5), 10);
  EXPECT_EQ(f.truth.x_mm, x_contact);
  EXPECT_NEAR(f.truth.theta_rad, 0.5 * 40 / 30.0, 1e-9);
  EXPECT_EQ(sim.collisions(), 1);
  // backing away (reverse) moves the base away from the box
  f = Drive(&sim, Velocity(-300, 0), 31);
  EXPECT_FALSE(f.blocked);
  EXPECT_NEAR(std::hypot(f.truth.x_mm - x_contact, f.truth.y_mm), 300.0, 1e-6);
  EXPECT_LT(f.truth.x_mm, x_contact - 150);
  EXPECT_EQ(sim.collisions(), 1);
  // drive in again: a second collision
  f = Drive(&sim, Velocity(300, 0), 60);
  EXPECT_TRUE(f.blocked);
  EXPECT_EQ(sim.collisions(), 2);
}

TEST(FootprintTest, PausingAgainstAnObstacleIsOneCollision) {
  const Scene scene = SceneOf(
      "sphere name=t center=0,3000,100 radius=100 target=true\n"
      "box name=crate center=1000,0,250 size=400,400,500\nrobot start=0,0,0\n");
  RobotSimulator sim(scene, CommandOptions());
  Drive(&sim, Velocity(300, 0), 100);
  Drive(&sim, Velocity(0, 0), 30);
  Drive(&sim, Velocity(300, 0), 30);
  EXPECT_EQ(sim.collisions(), 1);
  EXPECT_GE(sim.blocked_frames(), 60);
}

TEST(FootprintTest, ARugIsDrivenOver) {
  const Scene scene = SceneOf(
      "sphere name=t center=0,3000,100 radius=100 target=true\n"
      "box name=rug center=1000,0,2.5 size=1000,700,5\nrobot start=0,0,0\n");
  RobotSimulator sim(scene, CommandOptions());
  const SimFrame f = Drive(&sim, Velocity(300, 0), 241);  // 2400 mm, across the rug
  EXPECT_NEAR(f.truth.x_mm, 2400, 1e-6);
  EXPECT_EQ(sim.blocked_frames(), 0);
  EXPECT_EQ(sim.collisions(), 0);
}

TEST(FootprintTest, AStepCannotTunnelThroughAThinObstacle) {
  const Scene scene = SceneOf(
      "sphere name=t center=0,3000,100 radius=100 target=true\n"
      "box name=wall center=1000,0,500 size=20,3000,1000\n");
  const FootprintChecker checker(scene, 200);
  int object = -1;
  // a 1.5 m step whose start and end are both free but whose path crosses the wall
  EXPECT_TRUE(checker.StepBlocked(0, 0, 0, 1500, 0, &object));
  EXPECT_EQ(object, 1);
  EXPECT_FALSE(checker.StepBlocked(0, 0, M_PI, 1500, 0, &object));
  EXPECT_EQ(object, -1);
  // a base that starts overlapping may back out, not push deeper
  EXPECT_FALSE(checker.StepBlocked(850, 0, M_PI, 10, 0));
  EXPECT_TRUE(checker.StepBlocked(850, 0, 0, 10, 0));
}

TEST(FootprintTest, OrbitModeCountsOverlapsWithoutChangingTheMotion) {
  // A 200 mm crate sits on the 800 mm orbit around the target at the origin.
  const std::string base = "sphere name=t center=0,0,100 radius=100 target=true\n";
  const Scene clear = SceneOf(base);
  const Scene blocked = SceneOf(base + "box name=crate center=800,0,100 size=200,200,200\n");
  RobotSimOptions options;
  RobotSimulator a(clear, options), b(blocked, options);
  int expected = 0, new_collisions = 0;
  while (!a.Done()) {
    const SimFrame fa = a.Step(), fb = b.Step();
    EXPECT_EQ(fa.truth.x_mm, fb.truth.x_mm);
    EXPECT_EQ(fa.truth.y_mm, fb.truth.y_mm);
    EXPECT_EQ(fa.odometry.x_mm, fb.odometry.x_mm);
    const double dx = std::max(std::abs(fb.truth.x_mm - 800) - 100, 0.0);
    const double dy = std::max(std::abs(fb.truth.y_mm) - 100, 0.0);
    const bool overlaps = std::hypot(dx, dy) < 200;
    expected += overlaps;
    EXPECT_EQ(fb.blocked, overlaps) << fb.seq;
    new_collisions += fb.new_collision;
    EXPECT_FALSE(fa.blocked);
  }
  EXPECT_GT(expected, 10);
  EXPECT_EQ(b.blocked_frames(), expected);
  EXPECT_EQ(b.collisions(), 1);
  EXPECT_EQ(new_collisions, 1);
  EXPECT_EQ(a.collisions(), 0);
  EXPECT_NEAR(a.path_length_mm(), 2 * M_PI * 800 * 199 / 200, 1.0);  // chords of 199 steps
}

TEST(FootprintTest, InvalidFootprintRadiusIsRejected) {
  const Scene scene = SceneOf("sphere center=0,0,100 radius=100\n");
  RobotSimOptions options;
  options.footprint_radius_mm = 0;
  EXPECT_THROW(RobotSimulator(scene, options), std::invalid_argument);
  options.footprint_radius_mm = NAN;
  EXPECT_THROW(RobotSimulator(scene, options), std::invalid_argument);
  EXPECT_THROW(FootprintChecker(scene, -1), std::invalid_argument);
}

}  // namespace
}  // namespace objscan
