#include "common/camera_model.h"

#include <gtest/gtest.h>

namespace objscan {
namespace {

TEST(CameraModelTest, ProjectUnprojectRoundTripWithDistortion) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = 800;
  c.fy = 790;
  c.cx = 320;
  c.cy = 240;
  c.k1 = -0.2;
  c.k2 = 0.05;
  c.p1 = 0.001;
  c.p2 = -0.0005;
  for (double x = -0.3; x <= 0.3; x += 0.1) {
    for (double y = -0.2; y <= 0.2; y += 0.1) {
      const Eigen::Vector3d p(x * 1000, y * 1000, 1000);
      Eigen::Vector2d pixel;
      ASSERT_TRUE(c.Project(p, &pixel));
      const Eigen::Vector2d n = c.Unproject(pixel);
      EXPECT_NEAR(n.x(), x, 1e-9);
      EXPECT_NEAR(n.y(), y, 1e-9);
    }
  }
  Eigen::Vector2d pixel;
  EXPECT_FALSE(c.Project(Eigen::Vector3d(0, 0, -1), &pixel));
}

TEST(CameraModelTest, PrincipalPointAndValidity) {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500;
  c.cx = 319.5;
  c.cy = 239.5;
  Eigen::Vector2d pixel;
  ASSERT_TRUE(c.Project(Eigen::Vector3d(0, 0, 5), &pixel));
  EXPECT_DOUBLE_EQ(pixel.x(), 319.5);
  EXPECT_TRUE(c.IsValid());
  c.fx = -1;
  std::string why;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace objscan
