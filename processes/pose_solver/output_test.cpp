#include "processes/pose_solver/output.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace objscan {
namespace {

std::string TempDir(const std::string& name) {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/objscan_output_test_" +
                          std::to_string(::getpid()) + "_" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TrackFrame MakeFrame(int64_t seq, int n) {
  TrackFrame f;
  f.seq = seq;
  for (int i = 0; i < n; ++i) {
    TrackedFeature t;
    t.id = seq * 1000 + i;
    t.u = 10.25f + static_cast<float>(i);
    t.v = 20.5f - static_cast<float>(i) * 0.125f;
    t.age = i;
    f.features.push_back(t);
  }
  return f;
}

TEST(ObservationSpool, ReadsBackWhatWasAppendedInOrderAndRemovesItsFile) {
  const std::string path = TempDir("spool") + "/obs.spool";
  {
    ObservationSpool spool(path);
    ASSERT_TRUE(spool.ok()) << spool.error();
    for (int64_t seq = 0; seq < 5; ++seq) ASSERT_TRUE(spool.Append(MakeFrame(seq, static_cast<int>(seq) * 3)));
    EXPECT_EQ(spool.frames(), 5);
    ASSERT_TRUE(spool.Rewind());
    int64_t seq = -1;
    std::vector<TrackedFeature> features;
    for (int64_t expected = 0; expected < 5; ++expected) {
      ASSERT_TRUE(spool.Next(&seq, &features)) << expected;
      EXPECT_EQ(seq, expected);
      const TrackFrame truth = MakeFrame(expected, static_cast<int>(expected) * 3);
      ASSERT_EQ(features.size(), truth.features.size());
      for (size_t i = 0; i < features.size(); ++i) {
        EXPECT_EQ(features[i].id, truth.features[i].id);
        EXPECT_EQ(features[i].u, truth.features[i].u);
        EXPECT_EQ(features[i].v, truth.features[i].v);
      }
    }
    EXPECT_FALSE(spool.Next(&seq, &features));  // end
    EXPECT_TRUE(spool.ok());
    EXPECT_TRUE(std::filesystem::exists(path));
  }
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(ObservationSpool, UnwritablePathIsReportedNotThrown) {
  ObservationSpool spool("/nonexistent_dir_for_objscan/obs.spool");
  EXPECT_FALSE(spool.ok());
  EXPECT_FALSE(spool.error().empty());
  EXPECT_FALSE(spool.Append(MakeFrame(0, 2)));
  EXPECT_FALSE(spool.Rewind());
}

TEST(WriteColmapText, StreamedImagesGiveTheSameFilesAsTheVector) {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 320;
  camera.cy = 240;
  std::vector<ColmapImage> images;
  for (int64_t seq = 0; seq < 3; ++seq) {
    ColmapImage im;
    im.pose.seq = seq;
    im.pose.status = seq == 1 ? PoseStatus::kLost : PoseStatus::kTracking;  // lost images are not written
    im.pose.world_from_camera.translation() = Eigen::Vector3d(10.0 * seq, 0, 0);
    im.name = "img" + std::to_string(seq) + ".png";
    im.features = MakeFrame(seq, 4).features;
    images.push_back(im);
  }
  std::vector<Landmark> landmarks(2);
  landmarks[0].id = 1;  // seen in image 0 (feature index 1)
  landmarks[1].id = 2002;
  std::string error;
  const std::string a = TempDir("colmap_a"), b = TempDir("colmap_b");
  ASSERT_TRUE(WriteColmapText(a, camera, images, landmarks, &error)) << error;
  size_t next = 0;
  ASSERT_TRUE(WriteColmapText(
      b, camera,
      [&](ColmapImage* im) {
        if (next >= images.size()) return false;
        *im = images[next++];
        return true;
      },
      landmarks, &error))
      << error;
  for (const char* file : {"/cameras.txt", "/images.txt", "/points3D.txt"}) {
    std::ifstream fa(a + file), fb(b + file);
    std::stringstream sa, sb;
    sa << fa.rdbuf();
    sb << fb.rdbuf();
    EXPECT_FALSE(sa.str().empty()) << file;
    EXPECT_EQ(sa.str(), sb.str()) << file;
  }
  std::ifstream images_txt(a + "/images.txt");
  std::stringstream text;
  text << images_txt.rdbuf();
  EXPECT_NE(text.str().find("img0.png"), std::string::npos);
  EXPECT_EQ(text.str().find("img1.png"), std::string::npos);
  EXPECT_NE(text.str().find("img2.png"), std::string::npos);
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

}  // namespace
}  // namespace objscan
