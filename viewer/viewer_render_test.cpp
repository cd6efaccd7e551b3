// Renders a synthetic log with the real viewer binary under xvfb-run and checks the screenshot: not blank, the
// estimated and true trajectories and the voxel blob appear where the viewer's own view maths puts them.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/geometry.h"
#include "objscan/landmarks_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"
#include "viewer/scene_renderer.h"
#include "viewer/view_camera.h"

namespace objscan {
namespace {

constexpr int kPoses = 90;
constexpr double kEstimatedRadius = 800, kTrueRadius = 1100, kCameraHeight = 400;
constexpr int kWidth = 1024, kHeight = 768, kPanel = 400;
const Eigen::Vector3d kBlobCenter(0, 0, 100);  // 10x10x10 voxels of 20 mm, z from 0 to 200
constexpr double kVoxelSize = 20;
const cv::Vec3b kBlobRgb(40, 60, 230);

Eigen::Vector3d CirclePoint(double radius, int i) {
  const double a = 2 * M_PI * i / kPoses;
  return {radius * std::cos(a), radius * std::sin(a), kCameraHeight};
}

pose_t CirclePose(double radius, int i, int8_t status) {
  // Camera at the circle point looking at the centre (z forward), x tangential, y down-ish.
  const Eigen::Vector3d c = CirclePoint(radius, i);
  const Eigen::Vector3d z = (Eigen::Vector3d(0, 0, 100) - c).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << x, y, z;
  pose.translation() = c;
  pose_t msg{};
  msg.utime = std::llround(i * 1e6 / 30);
  msg.seq = i;
  msg.parent_frame = "world";
  msg.child_frame = "camera";
  PoseToArrays(pose, msg.position_mm, msg.orientation);
  msg.status = status;
  return msg;
}

// Writes the test log; data time = frame time (datalog:// uses each message's utime as event time).
void WriteLog(const std::string& path) {
  auto bus = MakeLcmBus("datalog://" + path + "?exclude=NONE");
  for (int i = 0; i < kPoses; ++i) {
    ASSERT_TRUE(bus->PublishMessage("GROUND_TRUTH_POSE", CirclePose(kTrueRadius, i, pose_t::STATUS_GROUND_TRUTH)));
    ASSERT_TRUE(bus->PublishMessage("CAMERA_POSE", CirclePose(kEstimatedRadius, i, pose_t::STATUS_TRACKING)));
    if (i % 30 == 0) {
      landmarks_t lm{};
      lm.utime = std::llround(i * 1e6 / 30);
      lm.seq = i;
      lm.frame = "world";
      for (int k = 0; k < 20; ++k) {
        lm.id.push_back(k + i);
        lm.position_mm.push_back({static_cast<float>(300 * std::cos(k)), static_cast<float>(300 * std::sin(k)), 50.0f});
        lm.num_observations.push_back(3);
        lm.reprojection_error_px.push_back(0.2f * k);
        lm.rgb.push_back({100, 100, 100});
      }
      lm.num_landmarks = static_cast<int32_t>(lm.id.size());
      ASSERT_TRUE(bus->PublishMessage("LANDMARKS", lm));
    }
    if (i == 10) {
      ImageFrame frame;
      frame.seq = i;
      frame.utime = std::llround(i * 1e6 / 30);
      frame.camera_name = "sim";
      frame.image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(80, 120, 160));
      ASSERT_TRUE(bus->PublishMessage("CAMERA_IMAGE", ImageToMessage(frame, image_t::ENCODING_BGR8)));
      TrackFrame tracks;
      tracks.seq = i;
      tracks.utime = frame.utime;
      tracks.width = 64;
      tracks.height = 48;
      tracks.features = {{1, 10, 10, 0}, {2, 30, 20, 12}, {3, 50, 40, 40}};
      ASSERT_TRUE(bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(tracks)));
      // Garbage with a plausible utime field (the datalog writer takes the event time from bytes 8..15).
      std::vector<uint8_t> junk(40, 0x5a);
      for (int b = 0; b < 8; ++b)
        junk[8 + b] = static_cast<uint8_t>(static_cast<uint64_t>(frame.utime) >> (56 - 8 * b));
      ASSERT_TRUE(bus->Publish("LANDMARKS", junk.data(), 40));  // malformed: must be counted, not crash
      ASSERT_TRUE(bus->Publish("SOME_UNKNOWN_CHANNEL", junk.data(), 40));
      process_status_t status{};
      status.utime = frame.utime;
      status.name = "tracker";
      status.state = process_status_t::STATE_RUNNING;
      ASSERT_TRUE(bus->PublishMessage("PROCESS_STATUS", status));
      odometry_t odo{};
      odo.utime = frame.utime;
      odo.seq = 0;
      odo.x_mm = -1500;
      odo.y_mm = 0;
      ASSERT_TRUE(bus->PublishMessage("ROBOT_ODOMETRY", odo));
    }
  }
  voxel_map_t map{};
  map.utime = std::llround((kPoses - 1) * 1e6 / 30);
  map.seq = kPoses - 1;
  map.frame = "world";
  map.voxel_size_mm = kVoxelSize;
  map.origin_mm[0] = kBlobCenter.x() - 5 * kVoxelSize;
  map.origin_mm[1] = kBlobCenter.y() - 5 * kVoxelSize;
  map.origin_mm[2] = 0;
  map.vote_threshold = 2;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      for (int k = 0; k < 10; ++k) {
        map.ijk.push_back({i, j, k});
        map.votes.push_back(5);
        map.rgb.push_back({kBlobRgb[0], kBlobRgb[1], kBlobRgb[2]});
      }
  map.num_voxels = static_cast<int32_t>(map.ijk.size());
  ASSERT_TRUE(bus->PublishMessage("VOXEL_MAP", map));
  target_t target{};
  target.utime = map.utime;
  target.seq = map.seq;
  target.state = target_t::STATE_CONFIRMED;
  target.frame = "world";
  target.center_mm[2] = 100;
  target.size_mm[0] = target.size_mm[1] = target.size_mm[2] = 260;
  target.confidence = 0.9;
  ASSERT_TRUE(bus->PublishMessage("TARGET", target));
}

OrbitView TestView() {
  OrbitView view;
  view.yaw_rad = -90 * M_PI / 180;
  view.pitch_rad = 70 * M_PI / 180;
  view.distance_mm = 4000;
  view.fovy_rad = 50 * M_PI / 180;
  return view;
}

std::string ViewArgs() {
  return " --window-width " + std::to_string(kWidth) + " --window-height " + std::to_string(kHeight) +
         " --panel-width " + std::to_string(kPanel) +
         " --view -90,70,4000,0,0,0,50";  // TestView()
}

bool Near(const cv::Vec3b& bgr, Rgb rgb, int tolerance) {
  return std::abs(bgr[2] - rgb.r) <= tolerance && std::abs(bgr[1] - rgb.g) <= tolerance &&
         std::abs(bgr[0] - rgb.b) <= tolerance;
}

// True when a pixel of the colour lies within radius of the pixel position.
bool ColourNear(const cv::Mat& image, const Eigen::Vector2d& pixel, Rgb rgb, int radius = 2) {
  const int u0 = static_cast<int>(std::lround(pixel.x())), v0 = static_cast<int>(std::lround(pixel.y()));
  for (int v = v0 - radius; v <= v0 + radius; ++v)
    for (int u = u0 - radius; u <= u0 + radius; ++u)
      if (u >= 0 && v >= 0 && u < image.cols && v < image.rows && Near(image.at<cv::Vec3b>(v, u), rgb, 30)) return true;
  return false;
}

// Fraction of sample points (midpoints between poses i and i+1) whose trajectory colour is found in the image.
double TrajectoryFound(const cv::Mat& image, double radius, Rgb rgb, int first, int last) {
  const OrbitView view = TestView();
  const Viewport viewport{0, 0, kWidth - kPanel, kHeight};
  int found = 0, total = 0;
  for (int i = first; i < last; i += 3) {
    const Eigen::Vector3d mid = 0.5 * (CirclePoint(radius, i) + CirclePoint(radius, i + 1));
    Eigen::Vector2d pixel;
    if (!ProjectToWindow(view, viewport, mid, &pixel)) continue;
    ++total;
    if (ColourNear(image, pixel, rgb)) ++found;
  }
  return total > 0 ? static_cast<double>(found) / total : 0.0;
}

class ViewerRenderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::system("command -v xvfb-run > /dev/null 2>&1") != 0) GTEST_SKIP() << "xvfb-run not installed";
    const char* viewer = std::getenv("OBJSCAN_VIEWER");
    if (viewer == nullptr) GTEST_SKIP() << "OBJSCAN_VIEWER not set (run through ctest)";
    viewer_ = viewer;
    prefix_ = ::testing::TempDir() + "objscan_viewer_render_test_" + std::to_string(getpid());
    log_ = prefix_ + ".lcmlog";
    WriteLog(log_);
  }
  void TearDown() override {
    if (!log_.empty() && std::getenv("OBJSCAN_KEEP_SCREENSHOTS") == nullptr) std::remove(log_.c_str());
  }
  cv::Mat Render(const std::string& extra, const std::string& name) {
    const std::string png = prefix_ + "_" + name + ".png";
    const std::string command = "LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 1280x800x24' " + viewer_ +
                                " --log " + log_ + ViewArgs() + " --screenshot " + png + extra + " > " + prefix_ + "_" +
                                name + ".out 2>&1";
    const int rc = std::system(command.c_str());
    EXPECT_EQ(rc, 0) << command << "\n(see " << prefix_ << "_" << name << ".out)";
    cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
    if (std::getenv("OBJSCAN_KEEP_SCREENSHOTS") == nullptr) std::remove(png.c_str());
    return image;
  }
  // Runs the viewer under xvfb-run with args; returns its exit code and its stdout + stderr in *output.
  int Run(const std::string& args, const std::string& name, std::string* output) {
    const std::string out = prefix_ + "_" + name + ".out";
    const std::string command = "LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 1280x800x24' " + viewer_ + " " +
                                args + " > " + out + " 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream in(out);
    std::ostringstream text;
    text << in.rdbuf();
    *output = text.str();
    if (std::getenv("OBJSCAN_KEEP_SCREENSHOTS") == nullptr) std::remove(out.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string viewer_, prefix_, log_;
};

// Fraction of sample points on the blob's top face (z = 200) drawn in the voxels' colour (top faces are unshaded).
double BlobTopFound(const cv::Mat& image) {
  const OrbitView view = TestView();
  const Viewport viewport{0, 0, kWidth - kPanel, kHeight};
  int blue = 0, samples = 0;
  for (double x = -80; x <= 80; x += 40)
    for (double y = -80; y <= 80; y += 40) {
      if (std::abs(x) < 30 && std::abs(y) < 30) continue;  // the z axis pokes out of the middle
      Eigen::Vector2d pixel;
      if (!ProjectToWindow(view, viewport, Eigen::Vector3d(x, y, 200), &pixel)) continue;
      const cv::Vec3b bgr =
          image.at<cv::Vec3b>(static_cast<int>(std::lround(pixel.y())), static_cast<int>(std::lround(pixel.x())));
      ++samples;
      blue += std::abs(bgr[0] - kBlobRgb[2]) <= 3 && std::abs(bgr[1] - kBlobRgb[1]) <= 3 &&
              std::abs(bgr[2] - kBlobRgb[0]) <= 3;
    }
  return samples > 0 ? static_cast<double>(blue) / samples : 0.0;
}

TEST_F(ViewerRenderTest, InstancedCubesAndPointsDrawTheBlobToo) {
  // The default draws this small model as a static face mesh; force the other two voxel paths.
  const cv::Mat instanced = Render(" --max-mesh-faces 0", "instanced");
  ASSERT_FALSE(instanced.empty());
  EXPECT_GE(BlobTopFound(instanced), 0.9);
  const cv::Mat points = Render(" --voxel-style points", "points");
  ASSERT_FALSE(points.empty());
  EXPECT_GE(BlobTopFound(points), 0.9);
}

TEST_F(ViewerRenderTest, PointsDepthPassAndLevelOfDetailKeepThePicture) {
  // The CPU depth pass (forced on for this small model) sends only the points nearest at some pixel: the scene must
  // look like the one with every point drawn.
  const cv::Mat all = Render(" --voxel-style points --voxel-occlusion-min-points 0", "points_all");
  const cv::Mat visible = Render(" --voxel-style points --voxel-occlusion-min-points 1", "points_visible");
  ASSERT_FALSE(all.empty());
  ASSERT_FALSE(visible.empty());
  EXPECT_GE(BlobTopFound(visible), 0.9);
  const cv::Rect scene(0, 0, kWidth - kPanel, kHeight);
  cv::Mat difference;
  cv::absdiff(all(scene), visible(scene), difference);
  cv::Mat gray;
  cv::cvtColor(difference, gray, cv::COLOR_BGR2GRAY);
  EXPECT_LE(cv::countNonZero(gray > 30), 20) << "pixels that differ with the depth pass";
  // Level of detail forced to the coarsest merged cells: still the blob, in its colour.
  const cv::Mat coarse = Render(" --voxel-lod-px 10000", "points_coarse");
  ASSERT_FALSE(coarse.empty());
  EXPECT_GE(BlobTopFound(coarse), 0.7);
  cv::absdiff(all(scene), coarse(scene), difference);  // 80 mm cells overhang the blob: really another level
  cv::cvtColor(difference, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray > 30), 100) << "the coarse level looks exactly like the voxels";
}

TEST_F(ViewerRenderTest, WholeLogShowsTrajectoriesAndVoxels) {
  // The test log's two circles differ on purpose (to tell the colours apart): draw the truth where it is, unaligned.
  const cv::Mat image = Render(" --align-truth=false", "end");
  ASSERT_FALSE(image.empty());
  ASSERT_EQ(image.cols, kWidth);
  ASSERT_EQ(image.rows, kHeight);
  const cv::Mat scene = image(cv::Rect(0, 0, kWidth - kPanel, kHeight));
  // Not blank: the scene has background, grid, trajectories and the model; the panel has text.
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 20.0);
  int background = 0;
  for (int v = 0; v < scene.rows; ++v)
    for (int u = 0; u < scene.cols; ++u) background += Near(scene.at<cv::Vec3b>(v, u), kBackgroundColor, 2);
  EXPECT_GT(background, scene.total() / 3);         // mostly background ...
  EXPECT_LT(background, scene.total() * 98 / 100);  // ... but not only

  EXPECT_GE(TrajectoryFound(image, kEstimatedRadius, kEstimatedTrajectoryColor, 0, kPoses - 1), 0.85);
  EXPECT_GE(TrajectoryFound(image, kTrueRadius, kGroundTruthTrajectoryColor, 0, kPoses - 1), 0.85);
  // Colours are not found where nothing was drawn (between the two circles).
  EXPECT_LE(TrajectoryFound(image, 0.5 * (kEstimatedRadius + kTrueRadius), kEstimatedTrajectoryColor, 0, kPoses - 1),
            0.1);

  // Voxel blob: the top face (z = 200) is drawn in the voxels' colour (top faces unshaded).
  const OrbitView view = TestView();
  const Viewport viewport{0, 0, kWidth - kPanel, kHeight};
  int blue = 0, samples = 0;
  for (double x = -80; x <= 80; x += 40)
    for (double y = -80; y <= 80; y += 40) {
      if (std::abs(x) < 30 && std::abs(y) < 30) continue;  // the z axis pokes out of the middle
      Eigen::Vector2d pixel;
      ASSERT_TRUE(ProjectToWindow(view, viewport, Eigen::Vector3d(x, y, 200), &pixel));
      const cv::Vec3b bgr =
          image.at<cv::Vec3b>(static_cast<int>(std::lround(pixel.y())), static_cast<int>(std::lround(pixel.x())));
      ++samples;
      blue += std::abs(bgr[0] - kBlobRgb[2]) <= 3 && std::abs(bgr[1] - kBlobRgb[1]) <= 3 &&
              std::abs(bgr[2] - kBlobRgb[0]) <= 3;
    }
  EXPECT_GE(blue, samples - 1) << "voxel top face colour missing";
}

TEST_F(ViewerRenderTest, BenchmarkRendersASyntheticModelOrTheLog) {
  std::string output;
  EXPECT_EQ(Run("--window-width 640 --window-height 480 --benchmark scatter:3000@0.5", "bench_scatter", &output), 0)
      << output;
  EXPECT_NE(output.find("benchmark (scatter, "), std::string::npos) << output;
  EXPECT_NE(output.find(": 3000 voxels"), std::string::npos) << output;
  EXPECT_NE(output.find(" frames/s"), std::string::npos) << output;
  // The log's scene, 0.5 s: its 1000 voxels.
  EXPECT_EQ(Run("--log " + log_ + " --window-width 640 --window-height 480 --benchmark log@0.5", "bench_log", &output),
            0)
      << output;
  EXPECT_NE(output.find("benchmark (log " + log_), std::string::npos) << output;
  EXPECT_NE(output.find(": 1000 voxels"), std::string::npos) << output;
}

TEST_F(ViewerRenderTest, BadViewOrBenchmarkIsAUsageError) {
  struct Case {
    std::string args, message;
  };
  for (const Case& c : {Case{"--view 10,20,0", "error: --view '10,20,0': distance must be > 0 mm"},
                        Case{"--view -90,abc", "error: --view '-90,abc': pitch 'abc' is no finite number"},
                        Case{"--view 1,2,3,4", "error: --view '1,2,3,4': 4 values; want PRESET"},
                        Case{"--view 1,2,3,4,5,6,180", "fov must be in 1..170 deg"},
                        Case{"--view sideways", "unknown preset 'sideways'"},
                        Case{"--benchmark ball", "error: --benchmark 'ball': ball needs its voxel count"},
                        Case{"--benchmark scatter:-5", "voxel count '-5' must be a whole number"},
                        Case{"--benchmark ball:100@0", "seconds '0' must be a number > 0"},
                        Case{"--benchmark log", "error: --benchmark log needs --log"},
                        Case{"--benchmark ball:100 --log " + log_, "renders a synthetic model, not --log"},
                        Case{"--view-distance-mm 800", "unknown option '--view-distance-mm'"},
                        Case{"--benchmark-voxels 100", "unknown option '--benchmark-voxels'"}}) {
    std::string output;
    EXPECT_EQ(Run(c.args, "usage", &output), 2) << c.args << "\n" << output;
    EXPECT_NE(output.find(c.message), std::string::npos) << c.args << "\n" << output;
  }
}

TEST_F(ViewerRenderTest, ScreenshotAtUtimeShowsOnlyThePast) {
  // Half way: the second half of the trajectory is not there yet, and neither is the voxel map.
  const int64_t half = std::llround((kPoses / 2) * 1e6 / 30);
  const cv::Mat image = Render(" --screenshot-at-utime " + std::to_string(half), "half");
  ASSERT_FALSE(image.empty());
  EXPECT_GE(TrajectoryFound(image, kEstimatedRadius, kEstimatedTrajectoryColor, 0, kPoses / 2 - 3), 0.85);
  EXPECT_LE(TrajectoryFound(image, kEstimatedRadius, kEstimatedTrajectoryColor, kPoses / 2 + 3, kPoses - 1), 0.1);
  const OrbitView view = TestView();
  Eigen::Vector2d pixel;
  ASSERT_TRUE(ProjectToWindow(view, Viewport{0, 0, kWidth - kPanel, kHeight}, Eigen::Vector3d(60, 60, 200), &pixel));
  const cv::Vec3b bgr =
      image.at<cv::Vec3b>(static_cast<int>(std::lround(pixel.y())), static_cast<int>(std::lround(pixel.x())));
  EXPECT_FALSE(bgr[0] == kBlobRgb[2] && bgr[1] == kBlobRgb[1] && bgr[2] == kBlobRgb[0]);
}

}  // namespace
}  // namespace objscan
