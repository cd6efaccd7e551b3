#include "processes/planner/pose_estimator.h"

#include <gtest/gtest.h>

#include <cmath>

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

OdometryReading Reading(int64_t utime, const BasePose& odometry, double pan, double tilt) {
  OdometryReading r;
  r.utime = utime;
  r.seq = utime / 33333;
  r.x_mm = odometry.x_mm;
  r.y_mm = odometry.y_mm;
  r.theta_rad = odometry.theta_rad;
  r.pan_rad = pan;
  r.tilt_rad = tilt;
  return r;
}

CameraPoseEstimate Pose(int64_t utime, const Eigen::Isometry3d& world_from_camera,
                        PoseStatus status = PoseStatus::kTracking) {
  CameraPoseEstimate p;
  p.utime = utime;
  p.world_from_camera = world_from_camera;
  p.status = status;
  return p;
}

TEST(RobotPoseEstimatorTest, CameraPoseAndHeadAnglesGiveTheBasePoseExactly) {
  const RobotGeometry robot;
  RobotPoseEstimator estimator(robot);
  const BasePose truth{1234.5, -678.9, 2.2};
  const double pan = 1.1, tilt = 0.4;
  // The odometry has drifted by (+100 mm, -30 mm, +2 deg); the reading is stamped 15 ms after the image.
  const BasePose odometry{truth.x_mm + 100, truth.y_mm - 30, truth.theta_rad + 2 * kDeg};
  ASSERT_TRUE(estimator.AddOdometry(Reading(1015000, odometry, pan, tilt)));
  ASSERT_TRUE(estimator.AddCameraPose(Pose(1000000, WorldFromCamera(robot, truth, pan, tilt))));
  const BasePose e = estimator.Estimate();
  EXPECT_NEAR(e.x_mm, truth.x_mm, 1e-9);
  EXPECT_NEAR(e.y_mm, truth.y_mm, 1e-9);
  EXPECT_NEAR(e.theta_rad, truth.theta_rad, 1e-12);
  EXPECT_EQ(estimator.source(), RobotPoseEstimator::Source::kCameraPose);
  // Disagreement: the odometry pose against the estimate.
  EXPECT_NEAR(estimator.last_disagreement().distance_mm, std::hypot(100.0, 30.0), 1e-6);
  EXPECT_NEAR(estimator.last_disagreement().angle_rad, 2 * kDeg, 1e-9);
  EXPECT_NEAR(estimator.max_disagreement().distance_mm, std::hypot(100.0, 30.0), 1e-6);
}

TEST(RobotPoseEstimatorTest, DeadReckonsBetweenPosesAndWhileLost) {
  const RobotGeometry robot;
  RobotPoseEstimator estimator(robot);
  const BasePose truth{500, 500, M_PI / 2};
  const BasePose odometry{400, 520, M_PI / 2 + 0.1};  // a different frame: only increments count
  ASSERT_TRUE(estimator.AddOdometry(Reading(0, odometry, 0, 0.3)));
  ASSERT_TRUE(estimator.AddCameraPose(Pose(0, WorldFromCamera(robot, truth, 0, 0.3))));
  // The robot drives 200 mm forward and turns 10 deg (in its own frame), the camera pose is LOST.
  const BasePose step{200, 0, 10 * kDeg};
  ASSERT_TRUE(estimator.AddOdometry(Reading(33333, Compose(odometry, step), 0, 0.3)));
  EXPECT_FALSE(estimator.AddCameraPose(Pose(33333, WorldFromCamera(robot, truth, 0, 0.3), PoseStatus::kLost)));
  const BasePose e = estimator.Estimate();
  const BasePose expected = Compose(truth, step);
  EXPECT_NEAR(e.x_mm, expected.x_mm, 1e-9);  // (500, 700)
  EXPECT_NEAR(e.y_mm, expected.y_mm, 1e-9);
  EXPECT_NEAR(e.theta_rad, expected.theta_rad, 1e-12);
  EXPECT_EQ(estimator.source(), RobotPoseEstimator::Source::kDeadReckoned);
  // INITIALIZING poses are not used either; the next TRACKING pose wins again.
  EXPECT_FALSE(estimator.AddCameraPose(Pose(33333, Eigen::Isometry3d::Identity(), PoseStatus::kInitializing)));
  const BasePose moved{480, 710, M_PI / 2 + 9 * kDeg};
  EXPECT_TRUE(estimator.AddCameraPose(Pose(33333, WorldFromCamera(robot, moved, 0, 0.3))));
  EXPECT_NEAR(estimator.Estimate().x_mm, 480, 1e-9);
  EXPECT_NEAR(estimator.Estimate().theta_rad, moved.theta_rad, 1e-12);
  EXPECT_EQ(estimator.camera_poses_used(), 2);
}

TEST(RobotPoseEstimatorTest, BeforeAnyCameraPoseTheOdometryIsTheEstimate) {
  RobotPoseEstimator estimator{RobotGeometry{}};
  EXPECT_EQ(estimator.source(), RobotPoseEstimator::Source::kNone);
  EXPECT_EQ(estimator.Estimate().x_mm, 0.0);
  ASSERT_TRUE(estimator.AddOdometry(Reading(10, {30, 40, 0.5}, 0, 0)));
  EXPECT_EQ(estimator.Estimate().x_mm, 30.0);
  EXPECT_EQ(estimator.Estimate().theta_rad, 0.5);
  EXPECT_EQ(estimator.source(), RobotPoseEstimator::Source::kOdometry);
}

TEST(RobotPoseEstimatorTest, RefusesBadInput) {
  const RobotGeometry robot;
  RobotPoseEstimator estimator(robot);
  ASSERT_TRUE(estimator.AddOdometry(Reading(1000, {0, 0, 0}, 0, 0)));
  EXPECT_FALSE(estimator.AddOdometry(Reading(1000, {1, 0, 0}, 0, 0)));  // not after the last
  EXPECT_FALSE(estimator.AddOdometry(Reading(900, {1, 0, 0}, 0, 0)));
  EXPECT_FALSE(estimator.AddOdometry(Reading(2000, {NAN, 0, 0}, 0, 0)));
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = NAN;
  EXPECT_FALSE(estimator.AddCameraPose(Pose(1000, bad)));
  // No odometry reading within 200 ms of the pose: the head angles are unknown, the pose is not used.
  EXPECT_FALSE(estimator.AddCameraPose(Pose(500000, WorldFromCamera(robot, BasePose{}, 0, 0))));
  EXPECT_EQ(estimator.camera_poses_used(), 0);
}

TEST(RobotPoseEstimatorTest, PicksTheReadingNearestThePoseTime) {
  const RobotGeometry robot;
  RobotPoseEstimator estimator(robot);
  // Readings 33 ms apart with different pan angles; the pose at 100 ms must use the one stamped 115 ms.
  estimator.AddOdometry(Reading(82000, {0, 0, 0}, 0.5, 0.2));
  estimator.AddOdometry(Reading(115000, {0, 0, 0}, 0.7, 0.2));
  estimator.AddOdometry(Reading(148000, {0, 0, 0}, 0.9, 0.2));
  const BasePose truth{10, 20, 0.3};
  ASSERT_TRUE(estimator.AddCameraPose(Pose(100000, WorldFromCamera(robot, truth, 0.7, 0.2))));
  EXPECT_NEAR(estimator.Estimate().theta_rad, truth.theta_rad, 1e-12);  // the latest reading has no motion
}

}  // namespace
}  // namespace objscan
