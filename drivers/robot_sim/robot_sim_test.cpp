#include "drivers/robot_sim/robot_sim.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/camera_model.h"
#include "common/robot_model.h"

namespace objscan {
namespace {

Scene SphereScene() { return ParseScene("sphere center=0,0,100 radius=100 target=true\n", "."); }

RobotSimOptions NoErrors(RobotSimOptions o) {
  o.errors.scale_error = o.errors.yaw_scale_error = o.errors.heading_drift_rad_per_mm = 0;
  o.errors.distance_noise = o.errors.heading_noise_rad_per_sqrt_m = 0;
  o.errors.pan_bias_rad = o.errors.tilt_bias_rad = o.errors.head_noise_rad = 0;
  o.errors.sync_offset_us = 0;
  return o;
}

double Wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

TEST(RobotSimTest, OrbitCirclesTheTargetAndAimsAtIt) {
  const Scene scene = SphereScene();
  RobotSimOptions options;
  RobotSimulator sim(scene, options);
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 319.5;
  camera.cy = 239.5;
  int64_t count = 0;
  const double step = 2 * M_PI / 200;
  while (!sim.Done()) {
    const SimFrame f = sim.Step();
    EXPECT_EQ(f.seq, count);
    EXPECT_EQ(f.utime, std::llround(count * 1e6 / 30.0));
    EXPECT_NEAR(std::hypot(f.truth.x_mm, f.truth.y_mm), 800, 1e-9);
    // heading tangent (counter-clockwise): theta = angle + 90 deg
    EXPECT_NEAR(Wrap(f.truth.theta_rad - std::atan2(f.truth.y_mm, f.truth.x_mm) - M_PI / 2), 0, 1e-9);
    EXPECT_NEAR(f.truth.v_mm_s, 800 * step * 30, 1e-9);
    EXPECT_NEAR(f.truth.omega_rad_s, step * 30, 1e-12);
    EXPECT_NEAR(f.truth.pan_rate_rad_s, 0, 1e-9);  // steady circle: the head holds still
    // the target centre is on the optical axis
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.Project(f.world_from_camera.inverse() * Eigen::Vector3d(0, 0, 100), &pixel));
    EXPECT_LT((pixel - Eigen::Vector2d(319.5, 239.5)).norm(), 1e-6);
    EXPECT_TRUE(f.world_from_camera.isApprox(WorldFromCamera(options.geometry, f.truth.x_mm, f.truth.y_mm,
                                                             f.truth.theta_rad, f.truth.pan_rad, f.truth.tilt_rad)));
    EXPECT_NEAR(f.world_from_camera.translation().z(), 400, 20);  // camera on the 400 mm mast
    ++count;
  }
  EXPECT_EQ(count, 200);
  // pan ~ +90 deg (the target is on the left of a counter-clockwise orbit), tilt looking down
  const SimFrame last = sim.Step();
  EXPECT_NEAR(last.truth.pan_rad, M_PI / 2, 0.05);
  EXPECT_GT(last.truth.tilt_rad, 0.2);
}

TEST(RobotSimTest, ErrorFreeOdometryEqualsTheTruthInTheStartFrame) {
  const Scene scene = SphereScene();
  RobotSimOptions options = NoErrors(RobotSimOptions());
  RobotSimulator sim(scene, options);
  SimFrame first = sim.Step();
  const Eigen::Isometry3d start_from_world =
      WorldFromBase(first.truth.x_mm, first.truth.y_mm, first.truth.theta_rad).inverse();
  while (!sim.Done()) {
    const SimFrame f = sim.Step();
    const Eigen::Isometry3d start_from_base =
        start_from_world * WorldFromBase(f.truth.x_mm, f.truth.y_mm, f.truth.theta_rad);
    EXPECT_NEAR(f.odometry.x_mm, start_from_base.translation().x(), 1e-6);
    EXPECT_NEAR(f.odometry.y_mm, start_from_base.translation().y(), 1e-6);
    EXPECT_NEAR(Wrap(f.odometry.theta_rad - (f.truth.theta_rad - first.truth.theta_rad)), 0, 1e-9);
    EXPECT_NEAR(f.odometry.pan_rad, f.truth.pan_rad, 1e-12);
    EXPECT_EQ(f.odometry.utime, f.utime);
  }
}

TEST(RobotSimTest, OdometryErrorsHaveTheConfiguredSize) {
  const Scene scene = SphereScene();
  RobotSimOptions options;  // defaults: 2 % scale, 0.5 deg/m drift, 1 % yaw scale, 0.5 deg biases, 15 ms
  options.errors.distance_noise = 0;
  options.errors.heading_noise_rad_per_sqrt_m = 0;
  options.errors.yaw_scale_error = 0;
  options.orbit_degrees = 90;
  options.frames = 100;
  RobotSimulator sim(scene, options);
  double pan_error = 0, tilt_error = 0;
  SimFrame f;
  const SimFrame first = sim.Step();
  while (!sim.Done()) {
    f = sim.Step();
    pan_error += Wrap(f.odometry.pan_rad - f.truth.pan_rad);
    tilt_error += f.odometry.tilt_rad - f.truth.tilt_rad;
    EXPECT_EQ(f.odometry.utime - f.utime, 15000);
    EXPECT_NEAR(f.odometry.v_mm_s, f.truth.v_mm_s * 1.02, 1e-9);
  }
  EXPECT_NEAR(pan_error / 99 * 180 / M_PI, 0.5, 0.03);
  EXPECT_NEAR(tilt_error / 99 * 180 / M_PI, 0.5, 0.03);
  // travelled arc 800 * pi/2 * 99/100; the odometry heading gains 0.5 deg/m on top of the true change
  const double arc = 800 * M_PI / 2 * 99 / 100;
  const double true_turn = Wrap(f.truth.theta_rad - first.truth.theta_rad);
  EXPECT_NEAR(Wrap(f.odometry.theta_rad - true_turn) * 180 / M_PI, 0.5 * arc / 1000, 1e-6);
  // with the drift the path bends a little more; the chord of the measured path is ~2 % longer than the truth
  const double true_chord = std::hypot(f.truth.x_mm - first.truth.x_mm, f.truth.y_mm - first.truth.y_mm);
  const double odo_chord = std::hypot(f.odometry.x_mm, f.odometry.y_mm);
  EXPECT_NEAR(odo_chord / true_chord, 1.02, 0.004);
}

TEST(RobotSimTest, SameSeedSameReadingsOtherSeedOtherNoise) {
  const Scene scene = SphereScene();
  RobotSimOptions options;
  options.frames = 30;
  RobotSimulator a(scene, options), b(scene, options);
  options.seed = 2;
  RobotSimulator c(scene, options);
  bool any_difference = false;
  while (!a.Done()) {
    const SimFrame fa = a.Step(), fb = b.Step(), fc = c.Step();
    EXPECT_EQ(fa.odometry.x_mm, fb.odometry.x_mm);
    EXPECT_EQ(fa.odometry.pan_rad, fb.odometry.pan_rad);
    if (fa.odometry.pan_rad != fc.odometry.pan_rad) any_difference = true;
  }
  EXPECT_TRUE(any_difference);
}

TEST(RobotSimTest, CommandModeFollowsVelocityGoalAndHeadCommands) {
  const Scene scene = SphereScene();
  RobotSimOptions options = NoErrors(RobotSimOptions());
  options.mode = "command";
  options.frames = 0;  // unlimited
  RobotSimulator sim(scene, options);
  EXPECT_FALSE(sim.Done());
  SimFrame f0 = sim.Step();
  EXPECT_EQ(f0.truth.v_mm_s, 0);
  SimCommand velocity;
  velocity.mode = SimCommand::kVelocity;
  velocity.v_mm_s = 300;
  velocity.omega_rad_s = 0;
  sim.SetCommand(velocity, f0.utime);
  SimFrame f;
  for (int i = 0; i < 30; ++i) f = sim.Step();  // 1 s at 300 mm/s (the first step used the old command)
  const double moved = std::hypot(f.truth.x_mm - f0.truth.x_mm, f.truth.y_mm - f0.truth.y_mm);
  EXPECT_NEAR(moved, 300.0 * 29 / 30, 1e-6);
  EXPECT_NEAR(Wrap(f.truth.theta_rad - f0.truth.theta_rad), 0, 1e-12);
  // speed limit
  velocity.v_mm_s = 5000;
  sim.SetCommand(velocity, f.utime);
  SimFrame g = sim.Step();
  g = sim.Step();
  EXPECT_NEAR(g.truth.v_mm_s, options.max_speed_mm_s, 1e-9);
  // goal in the odometry frame (= start pose): drive there and turn to the goal heading
  SimCommand goal;
  goal.mode = SimCommand::kGoal;
  goal.goal_x_mm = 0;
  goal.goal_y_mm = 500;
  goal.goal_theta_rad = M_PI;
  goal.has_pan_tilt = true;
  goal.pan_rad = 0.3;
  goal.tilt_rad = 0.4;
  for (int i = 0; i < 600; ++i) {
    sim.SetCommand(goal, g.utime);
    g = sim.Step();
  }
  EXPECT_LT(std::hypot(g.odometry.x_mm - 0, g.odometry.y_mm - 500), options.goal_tolerance_mm + 1);
  EXPECT_NEAR(Wrap(g.odometry.theta_rad - M_PI), 0, 0.01);
  EXPECT_NEAR(g.truth.pan_rad, 0.3, 1e-9);
  EXPECT_NEAR(g.truth.tilt_rad, 0.4, 1e-9);
  // command timeout: a velocity command that is not renewed stops after 1 s of sim time
  velocity.v_mm_s = 100;
  sim.SetCommand(velocity, g.utime);
  for (int i = 0; i < 45; ++i) g = sim.Step();
  EXPECT_EQ(g.truth.v_mm_s, 0);
}

TEST(RobotSimTest, CommandModeStartsAtTheScenesRobotLine) {
  const std::string objects = "sphere center=0,0,100 radius=100 target=true\n";
  const Scene scene = ParseScene(objects + "robot start=1500,-700,120 pan=-20 tilt=35\n", ".");
  RobotSimOptions options;
  options.mode = "command";
  options.frames = 0;
  RobotSimulator sim(scene, options);
  const SimFrame f = sim.Step();
  EXPECT_EQ(f.truth.x_mm, 1500);
  EXPECT_EQ(f.truth.y_mm, -700);
  EXPECT_NEAR(f.truth.theta_rad, 120 * M_PI / 180, 1e-12);
  EXPECT_NEAR(f.truth.pan_rad, -20 * M_PI / 180, 1e-12);
  EXPECT_NEAR(f.truth.tilt_rad, 35 * M_PI / 180, 1e-12);
  EXPECT_EQ(f.truth.v_mm_s, 0);
  EXPECT_TRUE(f.world_from_camera.isApprox(
      WorldFromCamera(options.geometry, 1500, -700, 120 * M_PI / 180, -20 * M_PI / 180, 35 * M_PI / 180)));
  EXPECT_EQ(f.odometry.x_mm, 0);  // odometry frame = the start pose
  EXPECT_EQ(f.odometry.theta_rad, 0);
  // the head holds the scene's angles until commanded
  SimFrame g = f;
  for (int i = 0; i < 10; ++i) g = sim.Step();
  EXPECT_EQ(g.truth.pan_rad, f.truth.pan_rad);
  EXPECT_EQ(g.truth.x_mm, 1500);
  // odometry origin "world": the readings start at the true start pose
  options.odometry_origin = "world";
  RobotSimulator world(scene, options);
  const SimFrame w = world.Step();
  EXPECT_EQ(w.odometry.x_mm, 1500);
  EXPECT_NEAR(w.odometry.theta_rad, 120 * M_PI / 180, 1e-12);
  // the orbit ignores the line; without the line, command mode starts at the orbit's first pose as before
  RobotSimOptions orbit;
  RobotSimulator orbiting(scene, orbit);
  const SimFrame o = orbiting.Step();
  EXPECT_NEAR(o.truth.x_mm, 0, 1e-9);
  EXPECT_NEAR(o.truth.y_mm, -800, 1e-9);
  RobotSimulator plain(ParseScene(objects, "."), options);
  const SimFrame p = plain.Step();
  EXPECT_NEAR(p.truth.x_mm, o.truth.x_mm, 1e-9);
  EXPECT_NEAR(p.truth.y_mm, o.truth.y_mm, 1e-9);
  EXPECT_NEAR(p.truth.theta_rad, o.truth.theta_rad, 1e-12);
  EXPECT_NEAR(p.truth.tilt_rad, o.truth.tilt_rad, 1e-12);
}

TEST(RobotSimTest, RejectsInvalidOptions) {
  const Scene scene = SphereScene();
  RobotSimOptions options;
  options.mode = "dance";
  EXPECT_THROW(RobotSimulator(scene, options), std::invalid_argument);
  options = RobotSimOptions();
  options.rate_hz = 0;
  EXPECT_THROW(RobotSimulator(scene, options), std::invalid_argument);
  options = RobotSimOptions();
  options.frames = 0;
  EXPECT_THROW(RobotSimulator(scene, options), std::invalid_argument);  // orbit needs frames
  options = RobotSimOptions();
  options.orbit_radius_mm = NAN;
  std::string why;
  EXPECT_FALSE(ValidateRobotSimOptions(options, &why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace objscan
