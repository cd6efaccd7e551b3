#include "common/robot_model.h"

#include <gtest/gtest.h>

namespace objscan {
namespace {

TEST(RobotModelTest, LevelHeadLooksForwardFromMastTop) {
  RobotGeometry robot;
  robot.camera_offset_mm = Eigen::Vector3d(40, 0, 0);
  const Eigen::Isometry3d t = WorldFromCamera(robot, 1000, 500, 0, 0, 0);
  // Optical centre: 40 mm forward of the mast top.
  EXPECT_TRUE(t.translation().isApprox(Eigen::Vector3d(1040, 500, 400), 1e-12));
  // Optical axis (camera z) points along world +x, image down (camera y) along world -z.
  EXPECT_TRUE((t.linear() * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE((t.linear() * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_TRUE((t.linear() * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(RobotModelTest, PanLeftAndTiltDownMoveTheOpticalAxis) {
  RobotGeometry robot;
  robot.camera_offset_mm.setZero();
  const double tilt = 0.4;
  const Eigen::Isometry3d t = WorldFromCamera(robot, 0, 0, 0.3, M_PI / 2 - 0.3, tilt);
  const Eigen::Vector3d axis = t.linear() * Eigen::Vector3d::UnitZ();
  // Heading 0.3 + pan (pi/2 - 0.3) = looking along +y, tilted down by 0.4 rad.
  EXPECT_TRUE(axis.isApprox(Eigen::Vector3d(0, std::cos(tilt), -std::sin(tilt)), 1e-12));
  // A point straight ahead on the floor projects onto the optical axis.
  const Eigen::Vector3d floor_point(0, 400 / std::tan(tilt), 0);
  const Eigen::Vector3d in_camera = t.inverse() * floor_point;
  EXPECT_NEAR(in_camera.x(), 0, 1e-9);
  EXPECT_NEAR(in_camera.y(), 0, 1e-9);
  EXPECT_GT(in_camera.z(), 0);
}

TEST(RobotModelTest, ValidatesGeometry) {
  RobotGeometry robot;
  EXPECT_TRUE(robot.IsValid());
  robot.mast_height_mm = -1;
  std::string why;
  EXPECT_FALSE(robot.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace objscan
