#include "tools/export/colmap_convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "tools/evaluate/evaluation.h"

namespace objscan {
namespace {
namespace fs = std::filesystem;

// Removes this process's temporary folder after all tests (also when some failed).
class RemoveTempFolder : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("objscan_colmap_convert_test_" + std::to_string(::getpid())), ec);
  }
};
const ::testing::Environment* const kRemoveTempFolder = ::testing::AddGlobalTestEnvironment(new RemoveTempFolder);

std::string TempPath(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("objscan_colmap_convert_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return (dir / name).string();
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

Eigen::Isometry3d MakePose(double yaw, double pitch, const Eigen::Vector3d& position) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  pose.translation() = position;
  return pose;
}

// One images.txt pose line for world_from_camera, as COLMAP writes it (cam_from_world).
std::string PoseLine(int id, const Eigen::Isometry3d& world_from_camera, const std::string& name) {
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Quaterniond q(camera_from_world.linear());
  const Eigen::Vector3d t = camera_from_world.translation();
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g 1 %s\n", id, q.w(), q.x(), q.y(), q.z(),
                t.x(), t.y(), t.z(), name.c_str());
  return buf;
}

TEST(FrameIndexFromName, TakesTheLastDigitRunOfTheStem) {
  int64_t index = -1;
  EXPECT_TRUE(FrameIndexFromName("000042.png", &index));
  EXPECT_EQ(index, 42);
  EXPECT_TRUE(FrameIndexFromName("images/000007.png", &index));
  EXPECT_EQ(index, 7);
  EXPECT_TRUE(FrameIndexFromName("templeSR0013.png", &index));
  EXPECT_EQ(index, 13);
  EXPECT_TRUE(FrameIndexFromName("cam2/frame_0150_left.jpg", &index));
  EXPECT_EQ(index, 150);
  EXPECT_FALSE(FrameIndexFromName("dir5/image.png", &index));
  EXPECT_FALSE(FrameIndexFromName("noframe", &index));
}

TEST(ColmapImagesToTum, InvertsCamFromWorldAndTimesByFrameNumber) {
  const std::vector<std::pair<int, Eigen::Isometry3d>> truth = {
      {10, MakePose(0.3, -0.2, {1.5, -2.0, 0.7})},
      {0, MakePose(-1.1, 0.4, {0.1, 0.2, 0.3})},
      {3, MakePose(2.5, 0.05, {-3.0, 1.0, 2.0})},
  };
  std::string text =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      "# Number of images: 3, mean observations per image: 1.3\n";
  text += PoseLine(1, truth[0].second, "000010.png");
  text += "12.5 30.25 7 100.0 40.0 -1\n";  // two observations, one triangulated
  text += PoseLine(2, truth[1].second, "images/000000.png");
  text += "\n";                                        // no observations
  text += PoseLine(3, truth[2].second, "000003.png");  // last image without an observation line
  const std::string path = TempPath("images.txt");
  WriteText(path, text);

  std::vector<ColmapImage> images;
  std::string error;
  ASSERT_TRUE(ReadColmapImagesTxt(path, &images, &error)) << error;
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(images[0].image_id, 1);
  EXPECT_EQ(images[0].name, "000010.png");
  EXPECT_EQ(images[0].num_observations, 2);
  EXPECT_EQ(images[0].num_triangulated, 1);
  EXPECT_EQ(images[1].num_observations, 0);
  EXPECT_EQ(images[2].name, "000003.png");

  std::vector<StampedPose> poses;
  ASSERT_TRUE(ColmapImagesToTum(images, 30, &poses, &error)) << error;
  ASSERT_EQ(poses.size(), 3u);
  const int expected_order[3] = {1, 2, 0};  // sorted by frame number 0, 3, 10
  for (int i = 0; i < 3; ++i) {
    const auto& [index, pose] = truth[expected_order[i]];
    EXPECT_DOUBLE_EQ(poses[i].t, index / 30.0);
    EXPECT_LT((poses[i].world_from_camera.translation() - pose.translation()).norm(), 1e-12) << i;
    EXPECT_LT(Eigen::Quaterniond(poses[i].world_from_camera.linear()).angularDistance(Eigen::Quaterniond(pose.linear())),
              1e-12) << i;
  }

  // Round trip through the TUM writer and the evaluator: a scaled copy of the truth aligns with scale ~ 1/1000.
  const std::string tum = TempPath("colmap_tum.txt");
  ASSERT_TRUE(WriteTumTrajectory(tum, poses, {"test"}, &error)) << error;
  std::vector<StampedPose> estimated, true_poses;
  ASSERT_TRUE(ReadTumTrajectory(tum, &estimated, &error)) << error;
  ASSERT_EQ(estimated.size(), 3u);
  for (const auto& [index, pose] : truth) {
    StampedPose p;
    p.t = index / 30.0;
    p.world_from_camera = pose;
    p.world_from_camera.translation() *= 1000.0;  // truth in mm, the estimate in "model units"
    true_poses.push_back(p);
  }
  TrajectoryEvaluation evaluation;
  ASSERT_TRUE(EvaluateTumTrajectories(estimated, true_poses, true, 0.005, &evaluation, &error)) << error;
  EXPECT_EQ(evaluation.num_matched, 3);
  EXPECT_LT(evaluation.error.ate_rmse, 1e-6);
  EXPECT_NEAR(evaluation.error.scale, 1000.0, 1e-6);
  EXPECT_LT(evaluation.error.rotation_max_rad, 1e-6);
}

TEST(ReadColmapImagesTxt, RejectsMalformedFiles) {
  std::vector<ColmapImage> images;
  std::string error;
  EXPECT_FALSE(ReadColmapImagesTxt(TempPath("does_not_exist.txt"), &images, &error));

  const std::string short_line = TempPath("short.txt");
  WriteText(short_line, "1 1 0 0 0 0 0 0 1\n\n");  // no NAME
  EXPECT_FALSE(ReadColmapImagesTxt(short_line, &images, &error));
  EXPECT_NE(error.find(":1:"), std::string::npos) << error;

  const std::string bad_number = TempPath("bad_number.txt");
  WriteText(bad_number, "1 1 0 zero 0 0 0 0 1 a.png\n\n");
  EXPECT_FALSE(ReadColmapImagesTxt(bad_number, &images, &error));

  const std::string zero_q = TempPath("zero_q.txt");
  WriteText(zero_q, "1 0 0 0 0 0 0 0 1 000001.png\n\n");
  EXPECT_FALSE(ReadColmapImagesTxt(zero_q, &images, &error));

  const std::string bad_observations = TempPath("bad_observations.txt");
  WriteText(bad_observations, "1 1 0 0 0 0 0 0 1 000001.png\n1.0 2.0\n");
  EXPECT_FALSE(ReadColmapImagesTxt(bad_observations, &images, &error));
  EXPECT_NE(error.find(":2:"), std::string::npos) << error;
}

TEST(ColmapImagesToTum, RejectsNamesWithoutNumbersDuplicatesAndBadRates) {
  ColmapImage a, b;
  a.name = "000001.png";
  b.name = "images/000001.jpg";
  std::vector<StampedPose> poses;
  std::string error;
  EXPECT_FALSE(ColmapImagesToTum({a, b}, 30, &poses, &error));
  EXPECT_NE(error.find("two images"), std::string::npos) << error;
  b.name = "left.png";
  EXPECT_FALSE(ColmapImagesToTum({a, b}, 30, &poses, &error));
  EXPECT_FALSE(ColmapImagesToTum({a}, 0, &poses, &error));
  EXPECT_TRUE(ColmapImagesToTum({a}, 10, &poses, &error)) << error;
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_DOUBLE_EQ(poses[0].t, 0.1);
}

TEST(ColmapCameraFromCalibration, ShiftsThePrincipalPointToColmapsPixelConvention) {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 500;
  camera.fy = 501;
  camera.cx = 319.5;
  camera.cy = 239.25;
  std::string model, params, error;
  ASSERT_TRUE(ColmapCameraFromCalibration(camera, &model, &params, &error)) << error;
  EXPECT_EQ(model, "PINHOLE");
  EXPECT_EQ(params, "500,501,320,239.75");
  camera.k1 = -0.25;
  camera.p2 = 0.001;
  ASSERT_TRUE(ColmapCameraFromCalibration(camera, &model, &params, &error)) << error;
  EXPECT_EQ(model, "OPENCV");
  EXPECT_EQ(params, "500,501,320,239.75,-0.25,0,0,0.001");
  camera.k3 = 0.125;
  ASSERT_TRUE(ColmapCameraFromCalibration(camera, &model, &params, &error)) << error;
  EXPECT_EQ(model, "FULL_OPENCV");
  EXPECT_EQ(params, "500,501,320,239.75,-0.25,0,0,0.001,0.125,0,0,0");
  camera.skew = 0.5;
  EXPECT_FALSE(ColmapCameraFromCalibration(camera, &model, &params, &error));
}

}  // namespace
}  // namespace objscan
