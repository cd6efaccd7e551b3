#include "drivers/camera/frame_source.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "common/test_data.h"

namespace objscan {
namespace {
namespace fs = std::filesystem;

std::string DataDir() { return SharedDataDir(); }
std::string TempleDir() { return DataDir() + "/middlebury_templeSparseRing"; }

// A temporary folder removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    path_ = fs::temp_directory_path() / ("objscan_camera_" + tag + "_" + std::to_string(getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

PinholeCamera TestCamera() {
  PinholeCamera c;
  c.name = "camera";
  c.width = 64;
  c.height = 48;
  c.fx = 80;
  c.fy = 82;
  c.cx = 31.2;
  c.cy = 22.7;
  c.k1 = -0.1;
  c.k2 = 0.01;
  c.p1 = 0.001;
  c.p2 = -0.002;
  return c;
}

// Image k: BGR with a brightness ramp that encodes k (pixel (0,0) = 10 * k + 5) and a marker at the top-left.
cv::Mat TestImage(int k, int width = 64, int height = 48) {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(10 * k + 5, 100, 200));
  image.at<cv::Vec3b>(0, 1) = cv::Vec3b(255, 0, 0);
  return image;
}

// A folder: frame_000..005.png, frame_002 corrupt, frame_004 odd-sized, calib.yaml, poses_gt.txt (metres).
void WriteTestFolder(const fs::path& root, const fs::path& image_dir, bool with_gt = true) {
  fs::create_directories(image_dir);
  for (int k = 0; k < 6; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%03d.png", k);
    const fs::path path = image_dir / name;
    if (k == 2) {
      std::ofstream(path) << "this is not a png";
    } else if (k == 4) {
      cv::imwrite(path.string(), TestImage(k, 32, 24));
    } else {
      cv::imwrite(path.string(), TestImage(k));
    }
  }
  std::ofstream(image_dir / "notes.txt") << "not an image";
  std::string error;
  ASSERT_TRUE(WriteCalibrationFile((root / "calib.yaml").string(), TestCamera(), &error)) << error;
  if (with_gt) {
    std::ofstream gt(root / "poses_gt.txt");
    gt << "# timestamp tx ty tz qx qy qz qw\n";
    for (int k = 0; k < 6; ++k)
      gt << k / 30.0 << " " << 0.1 * k << " " << -0.2 << " " << 1.5 << " 0 0 0.7071067811865476 0.7071067811865476\n";
  }
}

TEST(FrameSourceTest, ImageFolderReadsSortedFramesAndSkipsBadFiles) {
  TempDir dir("folder");
  WriteTestFolder(dir.path(), dir.path() / "images");
  FrameSourceOptions options;
  options.path = dir.path().string();
  std::string error;
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->kind(), SourceKind::kImageFolder);
  EXPECT_EQ(source->NumFrames(), 6);

  std::vector<int> published;
  std::vector<std::string> skipped;
  SourceFrame frame;
  std::string reason, detail;
  for (;;) {
    const ReadResult r = source->Next(&frame, &reason, &detail);
    if (r == ReadResult::kEnd) break;
    if (r == ReadResult::kSkipped) {
      skipped.push_back(reason + "|" + detail);
      continue;
    }
    published.push_back(frame.source_index);
    ASSERT_EQ(frame.image.cols, 64);
    ASSERT_EQ(frame.image.rows, 48);
    EXPECT_EQ(frame.image.at<cv::Vec3b>(5, 5)[0], 10 * frame.source_index + 5);  // the right file's content
    EXPECT_EQ(frame.camera.fx, 80);
    EXPECT_EQ(frame.camera.cy, 22.7);
    EXPECT_EQ(frame.camera.p2, -0.002);
    ASSERT_TRUE(frame.has_true_pose);
    // poses_gt.txt is in metres: 0.1 k m -> 100 k mm; rotation 90 deg about z.
    EXPECT_NEAR(frame.world_from_camera.translation().x(), 100.0 * frame.source_index, 1e-9);
    EXPECT_NEAR(frame.world_from_camera.translation().y(), -200.0, 1e-9);
    EXPECT_NEAR(frame.world_from_camera.translation().z(), 1500.0, 1e-9);
    EXPECT_NEAR(frame.world_from_camera.linear()(1, 0), 1.0, 1e-9);
  }
  EXPECT_EQ(published, (std::vector<int>{0, 1, 3, 5}));
  ASSERT_EQ(skipped.size(), 2u);
  EXPECT_NE(skipped[0].find("frame: unreadable file"), std::string::npos);
  EXPECT_NE(skipped[0].find("frame_002.png"), std::string::npos);
  EXPECT_NE(skipped[1].find("frame: wrong size"), std::string::npos);
  EXPECT_NE(skipped[1].find("frame_004.png is 32x24"), std::string::npos);

  // Rewind starts again.
  ASSERT_TRUE(source->Rewind());
  ASSERT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kFrame);
  EXPECT_EQ(frame.source_index, 0);
}

TEST(FrameSourceTest, ImagesDirectlyInFolderAndExplicitOrder) {
  TempDir dir("flat");
  WriteTestFolder(dir.path(), dir.path(), false);
  FrameSourceOptions options;
  options.path = dir.path().string();
  options.order = "6, 1,frame_004 frame_001.png,3-1";
  std::string error;
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->NumFrames(), 7);
  std::vector<std::string> names;
  SourceFrame frame;
  std::string reason, detail;
  for (ReadResult r; (r = source->Next(&frame, &reason, &detail)) != ReadResult::kEnd;) {
    names.push_back(r == ReadResult::kFrame ? frame.name : "skip:" + detail.substr(0, 13));
    if (r == ReadResult::kFrame) {
      EXPECT_FALSE(frame.has_true_pose);
    }
  }
  // 6, 1, frame_004 (odd-sized), frame_001.png, 3-1 = frames 3 (corrupt), 2, 1.
  EXPECT_EQ(names, (std::vector<std::string>{"frame_005.png", "frame_000.png", "skip:frame_004.png", "frame_001.png",
                                             "skip:frame_002.png", "frame_001.png", "frame_000.png"}));
}

TEST(FrameSourceTest, FrameListParsing) {
  const std::vector<std::string> names = {"a.png", "b.png", "c.jpg"};
  std::vector<int> indices;
  std::string error;
  ASSERT_TRUE(ParseFrameList("3,1 b", names, &indices, &error)) << error;
  EXPECT_EQ(indices, (std::vector<int>{2, 0, 1}));
  ASSERT_TRUE(ParseFrameList("c.jpg,1-3", names, &indices, &error)) << error;
  EXPECT_EQ(indices, (std::vector<int>{2, 0, 1, 2}));
  EXPECT_FALSE(ParseFrameList("0", names, &indices, &error));
  EXPECT_NE(error.find("out of range"), std::string::npos);
  EXPECT_FALSE(ParseFrameList("4", names, &indices, &error));
  EXPECT_FALSE(ParseFrameList("2-9", names, &indices, &error));
  EXPECT_FALSE(ParseFrameList("d.png", names, &indices, &error));
  EXPECT_NE(error.find("d.png"), std::string::npos);
  EXPECT_FALSE(ParseFrameList(" , ", names, &indices, &error));
}

TEST(FrameSourceTest, CalibrationErrorsAreClear) {
  TempDir dir("calib");
  WriteTestFolder(dir.path(), dir.path() / "images", false);
  FrameSourceOptions options;
  options.path = dir.path().string();
  std::string error;

  fs::remove(dir.path() / "calib.yaml");
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("no calibration"), std::string::npos) << error;
  EXPECT_NE(error.find("--calib"), std::string::npos) << error;

  auto write = [&](const std::string& text) { std::ofstream(dir.path() / "calib.yaml") << text; };
  auto expect_error = [&](const std::string& fragment) {
    error.clear();
    EXPECT_FALSE(OpenFrameSource(options, &error));
    EXPECT_NE(error.find(fragment), std::string::npos) << "got: " << error;
  };
  write("%YAML:1.0\nimage_width: 64\nimage_height: 48\n");
  expect_error("missing camera_matrix");
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 2\n  cols: 2\n"
      "  dt: d\n  data: [1, 0, 0, 1]\n");
  expect_error("3x3");
  write(
      "%YAML:1.0\nimage_width: 64\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
      "  data: [80, 0, 32, 0, 80, 24, 0, 0, 1]\n");
  expect_error("image_height");
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [-80, 0, 32, 0, 80, 24, 0, 0, 1]\n");
  expect_error("focal");
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [80, 0, 320, 0, 80, 24, 0, 0, 1]\n");
  expect_error("principal point");
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [80, 0, 32, 0, 80, 24, 0, 0, 1]\ndistortion_coefficients: [0.1, 0.2]\n");
  expect_error("0, 4 or 5 values");
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [80, 0, 32, 0, 80, 24, 0, 0, 1]\ndistortion_coefficients: [0.1, 0.2, 0, 0, 0, 0.5, 0, 0]\n");
  expect_error("only plumb_bob");
  write("this: [is not: yaml");
  expect_error("cannot be parsed");
  // Right format, wrong image size for these images.
  write(
      "%YAML:1.0\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [80, 0, 320, 0, 80, 240, 0, 0, 1]\n");
  expect_error("is for 640x480 images but the images");

  // A valid hand-written file (plain lists, 5 coefficients) and the --calib override.
  write(
      "%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n"
      "  dt: d\n  data: [80, 0, 32, 0, 81, 24, 0, 0, 1]\ndistortion_coefficients: [0.1, 0.02, 0, 0, 0.003]\n");
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  SourceFrame frame;
  std::string reason, detail;
  ASSERT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kFrame);
  EXPECT_EQ(frame.camera.fy, 81);
  EXPECT_EQ(frame.camera.k3, 0.003);
  options.calib_path = (dir.path() / "does_not_exist.yaml").string();
  expect_error("not found");
}

TEST(FrameSourceTest, TumUnitsAndErrors) {
  TempDir dir("tum");
  const std::string path = (dir.path() / "poses.txt").string();
  std::vector<StampedPose> poses;
  std::string error;
  std::ofstream(path) << "# units: mm\n0.0 10 20 30 0 0 0 1\n\n0.5 1 2 3 0 0 0 1\n";
  ASSERT_TRUE(ReadTumTrajectory(path, 1000, &poses, &error)) << error;
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].world_from_camera.translation(), Eigen::Vector3d(10, 20, 30));
  EXPECT_EQ(poses[1].t, 0.5);
  std::ofstream(path) << "0.0 0.01 0.02 0.03 0 0 0 1\n";
  ASSERT_TRUE(ReadTumTrajectory(path, 1000, &poses, &error)) << error;
  EXPECT_NEAR(poses[0].world_from_camera.translation().z(), 30.0, 1e-12);
  std::ofstream(path) << "0.0 0.01 0.02 0.03 0 0 0 2\n";
  EXPECT_FALSE(ReadTumTrajectory(path, 1000, &poses, &error));
  EXPECT_NE(error.find("quaternion"), std::string::npos);
  std::ofstream(path) << "0.0 0.01 0.02 0.03 0 0 1\n";
  EXPECT_FALSE(ReadTumTrajectory(path, 1000, &poses, &error));
  EXPECT_NE(error.find(":1:"), std::string::npos) << error;
}

TEST(FrameSourceTest, GroundTruthMatchedByTimestampNames) {
  TempDir dir("tumtime");
  for (const char* name : {"100.000000.png", "100.033333.png", "100.066667.png"})
    cv::imwrite((dir.path() / name).string(), TestImage(1));
  std::string error;
  ASSERT_TRUE(WriteCalibrationFile((dir.path() / "calib.yaml").string(), TestCamera(), &error));
  // 5 poses at 100 Hz (count differs from the images): matched by nearest time within 20 ms.
  std::ofstream gt(dir.path() / "poses_gt.txt");
  for (int k = 0; k < 4; ++k) gt << 100.0 + 0.02 * k << " " << k << " 0 0 0 0 0 1\n";
  gt.close();
  FrameSourceOptions options;
  options.path = dir.path().string();
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  SourceFrame frame;
  std::string reason, detail;
  std::vector<double> x;
  while (source->Next(&frame, &reason, &detail) == ReadResult::kFrame) {
    ASSERT_TRUE(frame.has_true_pose);
    x.push_back(frame.world_from_camera.translation().x());
  }
  EXPECT_EQ(x, (std::vector<double>{0, 2000, 3000}));  // t = 100.00, 100.04 (7 ms off), 100.06 (7 ms off)
}

TEST(FrameSourceTest, DetectsSourceKinds) {
  TempDir dir("kinds");
  std::ofstream(dir.path() / "movie.avi") << "x";
  SourceKind kind;
  std::string error;
  ASSERT_TRUE(DetectSourceKind(dir.path().string(), &kind, &error));
  EXPECT_EQ(kind, SourceKind::kVideoFile);  // a folder with one video and no images: a video folder
  std::ofstream(dir.path() / "000000.png") << "x";
  ASSERT_TRUE(DetectSourceKind(dir.path().string(), &kind, &error));
  EXPECT_EQ(kind, SourceKind::kImageFolder);
  ASSERT_TRUE(DetectSourceKind((dir.path() / "movie.avi").string(), &kind, &error));
  EXPECT_EQ(kind, SourceKind::kVideoFile);
  ASSERT_TRUE(DetectSourceKind("/dev/video7", &kind, &error));
  EXPECT_EQ(kind, SourceKind::kV4l2Device);
  ASSERT_TRUE(DetectSourceKind("0", &kind, &error));
  EXPECT_EQ(kind, SourceKind::kV4l2Device);
  EXPECT_FALSE(DetectSourceKind((dir.path() / "nothing").string(), &kind, &error));
  EXPECT_NE(error.find("does not exist"), std::string::npos);
  if (fs::is_directory(TempleDir())) {
    ASSERT_TRUE(DetectSourceKind(TempleDir(), &kind, &error));
    EXPECT_EQ(kind, SourceKind::kMiddlebury);
    ASSERT_TRUE(DetectSourceKind(TempleDir() + "/templeSR_par.txt", &kind, &error));
    EXPECT_EQ(kind, SourceKind::kMiddlebury);
  }
  // Video and device need --calib.
  FrameSourceOptions options;
  options.path = (dir.path() / "movie.avi").string();
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("needs --calib"), std::string::npos) << error;
  options.path = "/dev/video99";
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("needs --calib"), std::string::npos) << error;
  ASSERT_TRUE(WriteCalibrationFile((dir.path() / "calib.yaml").string(), TestCamera(), &error));
  options.calib_path = (dir.path() / "calib.yaml").string();
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("cannot open V4L2 device /dev/video99"), std::string::npos) << error;
  options.order = "1,2";
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("--order is not supported"), std::string::npos) << error;
}

TEST(FrameSourceTest, VideoFileWithCalibration) {
  TempDir dir("video");
  const std::string path = (dir.path() / "clip.avi").string();
  {
    cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25,
                           cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 5; ++k) writer.write(TestImage(k * 2));
  }
  std::string error;
  ASSERT_TRUE(WriteCalibrationFile((dir.path() / "calib.yaml").string(), TestCamera(), &error));
  FrameSourceOptions options;
  options.path = path;
  options.calib_path = (dir.path() / "calib.yaml").string();
  options.rotate_180 = "all";
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->kind(), SourceKind::kVideoFile);
  EXPECT_NEAR(source->SourceRate(), 25, 1e-6);
  SourceFrame frame;
  std::string reason, detail;
  int count = 0;
  while (source->Next(&frame, &reason, &detail) == ReadResult::kFrame) {
    EXPECT_EQ(frame.source_index, count);
    EXPECT_TRUE(frame.rotated_180);
    EXPECT_NEAR(frame.camera.cx, 63 - 31.2, 1e-12);
    EXPECT_NEAR(frame.image.at<cv::Vec3b>(20, 20)[0], 20 * count + 5, 6);  // JPEG-compressed
    ++count;
  }
  EXPECT_EQ(count, 5);
  ASSERT_TRUE(source->Rewind());
  ASSERT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kFrame);
  EXPECT_EQ(frame.source_index, 0);
}

// A folder holding one video (a recorded run kept as video): calib.yaml beside it, frame times from its
// frame-numbered timestamps.txt, else the container's (25 fps: 40 ms apart); a timestamps.txt that misses a frame or
// does not number frames is refused; a frame beyond its lines is skipped with a reason.
TEST(FrameSourceTest, VideoFolderTakesCalibrationAndFrameTimesBesideTheVideo) {
  TempDir dir("video_folder");
  {
    cv::VideoWriter writer((dir.path() / "run.avi").string(), cv::CAP_OPENCV_MJPEG,
                           cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 4; ++k) writer.write(TestImage(k * 2));
  }
  std::string error;
  ASSERT_TRUE(WriteCalibrationFile((dir.path() / "calib.yaml").string(), TestCamera(), &error));
  SourceKind kind;
  ASSERT_TRUE(DetectSourceKind(dir.path().string(), &kind, &error));
  EXPECT_EQ(kind, SourceKind::kVideoFile);
  FrameSourceOptions options;
  options.path = dir.path().string();
  auto read_times = [&](std::vector<int64_t>* times, std::string* last_reason) {
    auto source = OpenFrameSource(options, &error);
    if (!source) return false;
    times->clear();
    SourceFrame frame;
    std::string reason, detail;
    for (ReadResult r; (r = source->Next(&frame, &reason, &detail)) != ReadResult::kEnd;) {
      if (r == ReadResult::kFrame) times->push_back(frame.recorded_utime);
      if (r == ReadResult::kSkipped) *last_reason = reason;
    }
    return true;
  };
  std::vector<int64_t> times;
  std::string reason;
  ASSERT_TRUE(read_times(&times, &reason)) << error;
  ASSERT_EQ(times.size(), 4u);
  for (size_t i = 0; i < times.size(); ++i) EXPECT_NEAR(times[i], 40000.0 * i, 1000.0) << i;

  std::ofstream(dir.path() / "timestamps.txt") << "# frame utime\n0 1000000\n1 1033000\n2 1066000\n";
  ASSERT_TRUE(read_times(&times, &reason)) << error;
  EXPECT_EQ(times, (std::vector<int64_t>{1000000, 1033000, 1066000}));
  EXPECT_EQ(reason, "frame: no time in timestamps.txt");

  std::ofstream(dir.path() / "timestamps.txt") << "0 1000000\n2 1066000\n";
  EXPECT_FALSE(read_times(&times, &reason));
  EXPECT_NE(error.find("no time for frame 1"), std::string::npos) << error;
  std::ofstream(dir.path() / "timestamps.txt") << "000000.png 1000000\n";
  EXPECT_FALSE(read_times(&times, &reason));
  EXPECT_NE(error.find("is not a frame number"), std::string::npos) << error;

  // A second video makes it an image folder with no images: refused, not a guess.
  std::ofstream(dir.path() / "other.mp4") << "x";
  ASSERT_TRUE(DetectSourceKind(dir.path().string(), &kind, &error));
  EXPECT_EQ(kind, SourceKind::kImageFolder);
  EXPECT_FALSE(OpenFrameSource(options, &error));
}

TEST(FrameSourceTest, OxfordDinosaurNeedsCalibration) {
  const std::string dino = DataDir() + "/oxford_dinosaur";
  if (!fs::is_directory(dino)) GTEST_SKIP() << dino << " not present";
  FrameSourceOptions options;
  options.path = dino;
  std::string error;
  EXPECT_FALSE(OpenFrameSource(options, &error));
  EXPECT_NE(error.find("--calib"), std::string::npos) << error;
  EXPECT_NE(error.find("not a metric calibration"), std::string::npos) << error;
  TempDir dir("dino");
  PinholeCamera c;
  c.width = 720;
  c.height = 576;
  c.fx = c.fy = 1000;
  c.cx = 359.5;
  c.cy = 287.5;
  ASSERT_TRUE(WriteCalibrationFile((dir.path() / "dino.yaml").string(), c, &error));
  options.calib_path = (dir.path() / "dino.yaml").string();
  auto source = OpenFrameSource(options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->NumFrames(), 36);
}

// ---- Middlebury ----

TEST(FrameSourceTest, MiddleburyParParsing) {
  if (!fs::is_directory(TempleDir())) GTEST_SKIP() << TempleDir() << " not present";
  std::vector<MiddleburyView> views;
  std::string error;
  ASSERT_TRUE(ReadMiddleburyPar(TempleDir() + "/templeSR_par.txt", &views, &error)) << error;
  ASSERT_EQ(views.size(), 16u);
  const MiddleburyView& v1 = views[0];
  EXPECT_EQ(v1.image_name, "templeSR0001.png");
  EXPECT_EQ(v1.K(0, 0), 1520.4);
  EXPECT_EQ(v1.K(1, 1), 1525.9);
  EXPECT_EQ(v1.K(0, 2), 302.32);
  EXPECT_EQ(v1.K(1, 2), 246.87);
  EXPECT_EQ(v1.K(0, 1), 0.0);
  EXPECT_EQ(v1.R(0, 0), 0.02187598221295043);
  EXPECT_EQ(v1.R(1, 2), 0.05199500709979997700);
  EXPECT_EQ(v1.R(2, 2), -0.98216479887691122);
  EXPECT_EQ(v1.t, Eigen::Vector3d(-0.0726637729648, 0.0223360353405, 0.614604845959));

  // Camera centres (mm): 542..628 mm from the world origin (SOURCE.txt says "ring radius ~0.56-0.63 m"; the
  // measured range is a little wider), and all in one plane (the gantry ring) within 1 mm.
  std::vector<Eigen::Vector3d> centres;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : views) {
    const Eigen::Isometry3d pose = v.WorldFromCamera(1000);
    const Eigen::Vector3d centre = pose.translation();
    EXPECT_LT((centre - (-v.R.transpose() * v.t) * 1000).norm(), 1e-6);
    EXPECT_GT(centre.norm(), 530) << v.image_name;
    EXPECT_LT(centre.norm(), 640) << v.image_name;
    // The object (bounding-box centre, README) is in front of every camera.
    const Eigen::Vector3d object_mm = Eigen::Vector3d(-0.0224, 0.1018, 0.0251) * 1000;
    EXPECT_GT((pose.inverse() * object_mm).z(), 400) << v.image_name;
    centres.push_back(centre);
    mean += centre / 16.0;
  }
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& c : centres) scatter += (c - mean) * (c - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Eigen::Vector3d ring_normal = eigen.eigenvectors().col(0);
  for (const auto& c : centres) EXPECT_LT(std::abs((c - mean).dot(ring_normal)), 1.0);
  EXPECT_GT(std::abs(ring_normal.y()), 0.99);  // the ring lies in a plane y = const of the world
  // Views 1 and 11 are the same viewpoint (SOURCE.txt).
  EXPECT_LT((centres[0] - centres[10]).norm(), 1e-6);

  // Malformed files.
  TempDir dir("par");
  const std::string path = (dir.path() / "x_par.txt").string();
  std::ofstream(path) << "2\na.png 1 0 0 0 1 0 0 0 1 1 0 0 0 1 0 0 0 1 0 0 1\n";
  EXPECT_FALSE(ReadMiddleburyPar(path, &views, &error));
  EXPECT_NE(error.find("header says 2 views, found 1"), std::string::npos) << error;
  std::ofstream(path) << "1\na.png 1 0 0 0 1 0 0 0 1 2 0 0 0 1 0 0 0 1 0 0 1\n";
  EXPECT_FALSE(ReadMiddleburyPar(path, &views, &error));
  EXPECT_NE(error.find("not a rotation"), std::string::npos) << error;
  std::ofstream(path) << "1\na.png 1 0 0 0 1 0 0 0 1 1 0 0 0 1 0 0 0 1 0 0\n";
  EXPECT_FALSE(ReadMiddleburyPar(path, &views, &error));
  EXPECT_NE(error.find(":2:"), std::string::npos) << error;
}

// Projects a world point (m) with the file's K [R | t].
Eigen::Vector2d ProjectPar(const MiddleburyView& v, const Eigen::Vector3d& point_m) {
  const Eigen::Vector3d x = v.K * (v.R * point_m + v.t);
  return x.head<2>() / x.z();
}

// Projects a world point (mm) with a frame's calibration and true pose.
Eigen::Vector2d ProjectFrame(const SourceFrame& f, const Eigen::Vector3d& point_mm) {
  Eigen::Vector2d pixel(-1e9, -1e9);
  EXPECT_TRUE(f.camera.Project(f.world_from_camera.inverse() * point_mm, &pixel));
  return pixel;
}

TEST(FrameSourceTest, MiddleburySourceAndRotate180KeepProjectionsConsistent) {
  if (!fs::is_directory(TempleDir())) GTEST_SKIP() << TempleDir() << " not present";
  std::vector<MiddleburyView> views;
  std::string error;
  ASSERT_TRUE(ReadMiddleburyPar(TempleDir() + "/templeSR_par.txt", &views, &error)) << error;

  FrameSourceOptions plain_options;
  plain_options.path = TempleDir();
  auto plain = OpenFrameSource(plain_options, &error);
  ASSERT_TRUE(plain) << error;
  EXPECT_EQ(plain->kind(), SourceKind::kMiddlebury);
  EXPECT_EQ(plain->NumFrames(), 16);
  FrameSourceOptions rotated_options = plain_options;
  rotated_options.rotate_180 = "1,12-16";
  auto rotated = OpenFrameSource(rotated_options, &error);
  ASSERT_TRUE(rotated) << error;

  // Bounding-box corners of the temple (README), in m.
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 8; ++i)
    points.emplace_back(i & 1 ? 0.028855 : -0.073568, i & 2 ? 0.181892 : 0.021728, i & 4 ? 0.062736 : -0.012445);

  Eigen::Vector3d mean_axis_upright = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> axis_plain, axis_rotated;
  SourceFrame a, b;
  std::string reason, detail;
  for (int k = 0; k < 16; ++k) {
    ASSERT_EQ(plain->Next(&a, &reason, &detail), ReadResult::kFrame) << detail;
    ASSERT_EQ(rotated->Next(&b, &reason, &detail), ReadResult::kFrame) << detail;
    const bool expect_rotated = k == 0 || k >= 11;
    ASSERT_EQ(b.rotated_180, expect_rotated) << k;
    ASSERT_EQ(a.image.cols, 640);
    ASSERT_EQ(a.image.rows, 480);
    const int w = a.image.cols, h = a.image.rows;
    // Per-view intrinsics from the file; true pose in mm.
    EXPECT_EQ(a.camera.fx, views[static_cast<size_t>(k)].K(0, 0));
    EXPECT_EQ(a.camera.cx, views[static_cast<size_t>(k)].K(0, 2));
    ASSERT_TRUE(a.has_true_pose);
    for (const auto& p : points) {
      const Eigen::Vector2d uv = ProjectPar(views[static_cast<size_t>(k)], p);
      const Eigen::Vector2d uv_plain = ProjectFrame(a, p * 1000);
      const Eigen::Vector2d uv_rot = ProjectFrame(b, p * 1000);
      EXPECT_NEAR((uv_plain - uv).norm(), 0, 1e-6) << k;
      const Eigen::Vector2d expected = expect_rotated ? Eigen::Vector2d(w - 1 - uv.x(), h - 1 - uv.y()) : uv;
      EXPECT_NEAR((uv_rot - expected).norm(), 0, 1e-6) << k;
    }
    if (expect_rotated) {
      EXPECT_EQ(b.camera.cx, w - 1 - a.camera.cx);
      EXPECT_EQ(b.camera.cy, h - 1 - a.camera.cy);
      // Pixel (u, v) of the original is pixel (w-1-u, h-1-v) of the rotated image.
      EXPECT_EQ(a.image.at<cv::Vec3b>(100, 200), b.image.at<cv::Vec3b>(h - 1 - 100, w - 1 - 200));
      EXPECT_EQ(a.image.at<cv::Vec3b>(0, 0), b.image.at<cv::Vec3b>(h - 1, w - 1));
    } else {
      EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0);
    }
    // The camera's x axis in the world: the gantry mounts the camera with x along the ring axis.
    axis_plain.push_back(a.world_from_camera.linear().col(0));
    axis_rotated.push_back(b.world_from_camera.linear().col(0));
    if (k <= 10) mean_axis_upright += a.world_from_camera.linear().col(0) / 11.0;
  }
  EXPECT_EQ(plain->Next(&a, &reason, &detail), ReadResult::kEnd);
  // Data check: views 12..16 are stored rotated by 180 deg (SOURCE.txt): their x axis points against that of views
  // 1..11 (cos < -0.95); after --rotate-180 12-16 all 16 agree (cos > 0.95).
  ASSERT_GT(mean_axis_upright.norm(), 0.95);
  mean_axis_upright.normalize();
  for (int k = 0; k < 16; ++k) {
    const double plain_cos = axis_plain[static_cast<size_t>(k)].dot(mean_axis_upright);
    const double rotated_cos = axis_rotated[static_cast<size_t>(k)].dot(mean_axis_upright);
    if (k <= 10) {
      EXPECT_GT(plain_cos, 0.95) << k;
    } else {
      EXPECT_LT(plain_cos, -0.95) << k;
      EXPECT_GT(rotated_cos, 0.95) << k;
    }
  }
}

TEST(FrameSourceTest, RotateCameraWithDistortionReprojects) {
  const PinholeCamera c = TestCamera();
  const PinholeCamera r = RotateCamera180(c);
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  world_from_camera.translation() = Eigen::Vector3d(100, -50, 20);
  const Eigen::Isometry3d rotated_pose = RotatePose180(world_from_camera);
  for (double x : {-0.3, 0.0, 0.25}) {
    for (double y : {-0.2, 0.1}) {
      const Eigen::Vector3d point_world = world_from_camera * Eigen::Vector3d(x * 800, y * 800, 800);
      Eigen::Vector2d uv, uv_r;
      ASSERT_TRUE(c.Project(world_from_camera.inverse() * point_world, &uv));
      ASSERT_TRUE(r.Project(rotated_pose.inverse() * point_world, &uv_r));
      EXPECT_NEAR(uv_r.x(), c.width - 1 - uv.x(), 1e-9);
      EXPECT_NEAR(uv_r.y(), c.height - 1 - uv.y(), 1e-9);
    }
  }
}

}  // namespace
}  // namespace objscan
