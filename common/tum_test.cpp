#include "common/tum.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>

namespace objscan {
namespace {

std::string Temp(const std::string& name) { return ::testing::TempDir() + "objscan_tum_" + std::to_string(getpid()) + name; }

TEST(TumTest, RoundTripUnitsHeaderAndErrors) {
  std::vector<StampedPose> poses(2);
  poses[0].t = 1.5;
  poses[0].world_from_camera.translation() = Eigen::Vector3d(1234.56789, -2, 3);
  poses[1].t = 1.533333;
  poses[1].world_from_camera.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const std::string path = Temp("a.txt");
  std::string error;
  ASSERT_TRUE(WriteTumTrajectory(path, poses, {"units: mm", "a comment"}, &error, 4)) << error;
  std::vector<StampedPose> read;
  bool units_mm = false;
  ASSERT_TRUE(ReadTumTrajectory(path, &read, &error, &units_mm)) << error;
  EXPECT_TRUE(units_mm);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_DOUBLE_EQ(read[0].t, 1.5);
  EXPECT_NEAR(read[0].world_from_camera.translation().x(), 1234.5679, 1e-9);  // 4 decimals
  EXPECT_TRUE(read[1].world_from_camera.linear().isApprox(poses[1].world_from_camera.linear(), 1e-8));
  {
    std::ifstream in(path);
    std::string first;
    std::getline(in, first);
    EXPECT_EQ(first, "# units: mm");
  }
  ASSERT_TRUE(WriteTumTrajectory(path, poses, {}, &error, -1)) << error;  // lossless
  ASSERT_TRUE(ReadTumTrajectory(path, &read, &error, &units_mm)) << error;
  EXPECT_FALSE(units_mm);
  EXPECT_EQ(read[0].world_from_camera.translation(), poses[0].world_from_camera.translation());
  EXPECT_LT((read[1].world_from_camera.linear() - poses[1].world_from_camera.linear()).norm(), 1e-14);

  // Malformed lines name the file and line.
  for (const char* bad : {"0 1 2 3 0 0 0 1\n0 1 2 3 0 0 1\n", "0 1 2 3 0 0 0 2\n", "0 1 2 nan 0 0 0 1\n",
                          "0 1 2 3x 0 0 0 1\n", "0 1 2 3 0 0 0 1 9\n"}) {
    std::ofstream(path) << bad;
    EXPECT_FALSE(ReadTumTrajectory(path, &read, &error)) << bad;
    EXPECT_NE(error.find(path + ":"), std::string::npos) << error;
  }
  EXPECT_FALSE(ReadTumTrajectory(Temp("missing.txt"), &read, &error));
  EXPECT_FALSE(WriteTumTrajectory("/nonexistent/dir/t.txt", poses, {}, &error));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace objscan
