#include "processes/planner/planner_geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

RobotGeometry OffsetRobot() {
  RobotGeometry robot;
  robot.mast_offset_x_mm = -35;
  robot.mast_offset_y_mm = 12;
  robot.camera_offset_mm = Eigen::Vector3d(40, 8, -15);  // off the optical axis: AimHead must iterate
  return robot;
}

TEST(PlannerGeometryTest, BasePoseFromCameraInvertsTheRobotModel) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-5000, 5000), angle(-M_PI, M_PI), pan(-170 * kDeg, 170 * kDeg),
      tilt(0, 60 * kDeg);
  for (const RobotGeometry& robot : {RobotGeometry{}, OffsetRobot()}) {
    for (int i = 0; i < 200; ++i) {
      const BasePose base{xy(rng), xy(rng), angle(rng)};
      const double p = pan(rng), t = tilt(rng);
      const BasePose back = BasePoseFromCamera(robot, WorldFromCamera(robot, base, p, t), p, t);
      EXPECT_NEAR(back.x_mm, base.x_mm, 1e-9);
      EXPECT_NEAR(back.y_mm, base.y_mm, 1e-9);
      EXPECT_NEAR(WrapAngle(back.theta_rad - base.theta_rad), 0.0, 1e-12);
    }
  }
}

TEST(PlannerGeometryTest, AimHeadPutsThePointOnTheOpticalAxis) {
  for (const RobotGeometry& robot : {RobotGeometry{}, OffsetRobot()}) {
    const BasePose base{100, -200, 0.7};
    for (const Eigen::Vector3d& point : {Eigen::Vector3d(900, 400, 80), Eigen::Vector3d(-600, -900, 0),
                                         Eigen::Vector3d(500, -100, 300), Eigen::Vector3d(100, 2300, 20)}) {
      double pan, tilt;
      AimHead(robot, base, point, &pan, &tilt);
      EXPECT_LT(AngleOffAxis(WorldFromCamera(robot, base, pan, tilt), point), 1e-9);
    }
  }
  // Straight ahead and 400 mm lower than the axes at 400 mm: tilt 45 deg down (default camera offset on the axis).
  double pan, tilt;
  AimHead(RobotGeometry{}, BasePose{}, Eigen::Vector3d(400, 0, 0), &pan, &tilt);
  EXPECT_NEAR(pan, 0.0, 1e-12);
  EXPECT_NEAR(tilt, 45 * kDeg, 1e-12);
}

TEST(PlannerGeometryTest, ComposeAndBetweenAreInverse) {
  const BasePose a{300, -50, 2.9}, b{-1200, 700, -2.8};
  const BasePose a_from_b = Between(a, b);
  const BasePose back = Compose(a, a_from_b);
  EXPECT_NEAR(back.x_mm, b.x_mm, 1e-9);
  EXPECT_NEAR(back.y_mm, b.y_mm, 1e-9);
  EXPECT_NEAR(WrapAngle(back.theta_rad - b.theta_rad), 0.0, 1e-12);
  EXPECT_NEAR(a_from_b.theta_rad, WrapAngle(-2.8 - 2.9), 1e-12);
}

TEST(PlannerGeometryTest, IntrinsicsFieldOfViewAndProjection) {
  const CameraIntrinsics camera;  // 640 x 480, fx = fy = 800
  EXPECT_NEAR(camera.HorizontalFovRad(), 2 * std::atan(320.0 / 800.0), 1e-12);  // 43.6 deg
  EXPECT_NEAR(camera.VerticalFovRad(), 2 * std::atan(240.0 / 800.0), 1e-12);
  double u, v;
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(100, -50, 1000), &u, &v));
  EXPECT_NEAR(u, 319.5 + 80, 1e-12);
  EXPECT_NEAR(v, 239.5 - 40, 1e-12);
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 0, -10), &u, &v));
  EXPECT_TRUE(camera.InImage(0, 0));
  EXPECT_FALSE(camera.InImage(0, 0, 5));
  EXPECT_FALSE(camera.InImage(640, 10));
  EXPECT_NEAR(WrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(-M_PI), M_PI, 1e-12);
}

}  // namespace
}  // namespace objscan
