#include "tools/export/log_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/recorded_run.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "tools/evaluate/evaluation.h"
#ifdef OBJSCAN_HAVE_CAMERA_DRIVER
#include "drivers/camera/frame_source.h"
#endif

namespace objscan {
namespace {
namespace fs = std::filesystem;

// Removes this process's temporary folder after all tests (also when some failed).
class RemoveTempFolder : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("objscan_log_export_test_" + std::to_string(::getpid())), ec);
  }
};
const ::testing::Environment* const kRemoveTempFolder = ::testing::AddGlobalTestEnvironment(new RemoveTempFolder);

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("objscan_log_export_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

PinholeCamera TestCamera() {
  PinholeCamera camera;
  camera.name = "camera";
  camera.width = 64;
  camera.height = 48;
  camera.fx = 55.123456789012345;
  camera.fy = 54.987654321;
  camera.cx = 31.75;
  camera.cy = 23.3;
  camera.k1 = -0.1234;
  camera.k2 = 0.0456;
  camera.p1 = 0.001;
  camera.p2 = -0.0007;
  camera.k3 = 0.0123;
  return camera;
}

// A synthetic session: frames seq 0..3 with four encodings (gray, RGB, BGR, JPEG) plus a truncated frame (seq 4),
// the calibration before every frame, a true pose after every frame and odometry in between.
struct Session {
  std::vector<ImageFrame> frames;  // what a reader of frames 0..3 must get back (JPEG: the decoded image)
  std::vector<CameraPoseEstimate> poses;
  std::vector<OdometryReading> odometry;
};

Session WriteSession(const std::string& log_path) {
  Session session;
  auto bus = MakeLcmBus("datalog://" + log_path);
  const PinholeCamera camera = TestCamera();
  cv::RNG rng(12345);
  const int8_t encodings[4] = {+image_t::ENCODING_GRAY8, +image_t::ENCODING_RGB8, +image_t::ENCODING_BGR8,
                               +image_t::ENCODING_JPEG};
  for (int i = 0; i < 5; ++i) {
    const int64_t utime = std::llround(i * 1e6 / 30);
    EXPECT_TRUE(bus->PublishMessage("CAMERA_INFO", CameraToMessage(camera, utime)));
    ImageFrame frame;
    frame.utime = utime;
    frame.seq = i;
    frame.camera_name = "camera";
    frame.image = cv::Mat(camera.height, camera.width, i == 0 ? CV_8UC1 : CV_8UC3);
    rng.fill(frame.image, cv::RNG::UNIFORM, 0, 256);
    image_t msg = ImageToMessage(frame, encodings[i % 4], 90);
    if (i == 4) {
      msg.data.resize(msg.data.size() / 2);  // truncated: undecodable
      msg.size = static_cast<int32_t>(msg.data.size());
    } else {
      ImageFrame decoded;
      std::string error;
      EXPECT_TRUE(ImageFromMessage(msg, &decoded, &error)) << error;
      if (encodings[i] != +image_t::ENCODING_JPEG) {
        EXPECT_TRUE(SameImage(decoded.image, frame.image));
      }
      session.frames.push_back(decoded);
    }
    EXPECT_TRUE(bus->PublishMessage("CAMERA_IMAGE", msg));

    CameraPoseEstimate pose;
    pose.utime = utime;
    pose.seq = i;
    pose.status = PoseStatus::kGroundTruth;
    pose.scale_source = ScaleSource::kTrue;
    pose.world_from_camera.linear() =
        Eigen::AngleAxisd(0.3 + 0.7 * i, Eigen::Vector3d(0.2, -0.5, 1).normalized()).toRotationMatrix();
    pose.world_from_camera.translation() = Eigen::Vector3d(1000.125 * i, -250.5 + i, 300.0 / 7);
    EXPECT_TRUE(bus->PublishMessage("GROUND_TRUTH_POSE", PoseToMessage(pose, "world", "camera")));
    session.poses.push_back(pose);

    OdometryReading odo;
    odo.utime = utime + 1234;
    odo.seq = i;
    odo.x_mm = 10.0 / 3 * i;
    odo.y_mm = -1.0 / 7;
    odo.theta_rad = 0.01 * i;
    odo.pan_rad = 0.1;
    odo.tilt_rad = 0.35;
    odo.v_mm_s = 100;
    odo.omega_rad_s = 0.02;
    odo.pan_rate_rad_s = -0.001;
    odo.tilt_rate_rad_s = 1e-9;
    EXPECT_TRUE(bus->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(odo)));
    session.odometry.push_back(odo);
  }
  // A message of the wrong type on the image channel.
  EXPECT_TRUE(bus->PublishMessage("CAMERA_IMAGE", OdometryToMessage(session.odometry[0])));
  return session;
}

TEST(LogExport, WritesAFolderThatReadsBackExactly) {
  const fs::path dir = TempDir("full");
  const std::string log_path = (dir / "session.lcmlog").string();
  const Session session = WriteSession(log_path);

  LogExportOptions options;
  options.log_path = log_path;
  options.out_dir = (dir / "dataset").string();
  LogExportResult result;
  std::string error;
  ASSERT_TRUE(ExportLogToDataset(options, &result, &error)) << error;
  EXPECT_EQ(result.events_read, 21);
  EXPECT_EQ(result.dataset.frames_written, 4);
  EXPECT_EQ(result.dataset.frames_undecodable, 2);
  EXPECT_EQ(result.rejected.count("image: truncated data"), 1u);
  EXPECT_EQ(result.rejected.count("image: not an image_t"), 1u);
  EXPECT_EQ(result.dataset.true_poses_written, 4);
  EXPECT_EQ(result.dataset.frames_without_true_pose, 0);
  EXPECT_EQ(result.dataset.odometry_written, 5);
  EXPECT_EQ(result.dataset.calibration_changes, 0);
  EXPECT_EQ(result.dataset.frames_size_mismatch, 0);

  // Images: lossless, named by seq, gray stays gray.
  const fs::path images = dir / "dataset" / "images";
  for (const auto& frame : session.frames) {
    const cv::Mat read = cv::imread((images / DatasetImageName(frame.seq)).string(), cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(SameImage(read, frame.image)) << frame.seq;
  }
  EXPECT_FALSE(fs::exists(images / "000004.png"));

  // Calibration: every number exactly.
  const PinholeCamera camera = TestCamera();
  cv::FileStorage storage((dir / "dataset" / "calib.yaml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(storage.isOpened());
  EXPECT_EQ(static_cast<int>(storage["image_width"]), camera.width);
  EXPECT_EQ(static_cast<int>(storage["image_height"]), camera.height);
  cv::Mat k, d;
  storage["camera_matrix"] >> k;
  storage["distortion_coefficients"] >> d;
  ASSERT_EQ(k.total(), 9u);
  ASSERT_EQ(d.total(), 5u);
  EXPECT_EQ(k.at<double>(0, 0), camera.fx);
  EXPECT_EQ(k.at<double>(1, 1), camera.fy);
  EXPECT_EQ(k.at<double>(0, 2), camera.cx);
  EXPECT_EQ(k.at<double>(1, 2), camera.cy);
  EXPECT_EQ(k.at<double>(0, 1), 0.0);
  EXPECT_EQ(k.at<double>(2, 2), 1.0);
  const double expected_d[5] = {camera.k1, camera.k2, camera.p1, camera.p2, camera.k3};
  for (int i = 0; i < 5; ++i) EXPECT_EQ(d.at<double>(0, i), expected_d[i]) << i;
  PinholeCamera read_back;
  ASSERT_TRUE(ReadCalibrationFile((dir / "dataset" / "calib.yaml").string(), "camera", &read_back, &error)) << error;
  EXPECT_EQ(read_back.fx, camera.fx);
  EXPECT_EQ(read_back.k3, camera.k3);

  // True poses: "# units: mm" first, t = utime / 1e6, positions exact, rotations to rounding.
  std::ifstream gt_file(dir / "dataset" / "poses_gt.txt");
  std::string first_line;
  std::getline(gt_file, first_line);
  EXPECT_EQ(first_line, "# units: mm");
  std::vector<StampedPose> gt;
  ASSERT_TRUE(ReadTumTrajectory((dir / "dataset" / "poses_gt.txt").string(), &gt, &error)) << error;
  ASSERT_EQ(gt.size(), 4u);
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_EQ(gt[i].t, static_cast<double>(session.poses[i].utime) / 1e6) << i;
    EXPECT_EQ(gt[i].world_from_camera.translation(), session.poses[i].world_from_camera.translation()) << i;
    EXPECT_LT((gt[i].world_from_camera.linear() - session.poses[i].world_from_camera.linear()).norm(), 1e-14) << i;
  }

  // Odometry: one line per reading, every field exact.
  std::ifstream odo_file(dir / "dataset" / "odometry.txt");
  std::string line;
  size_t n = 0;
  while (std::getline(odo_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    ASSERT_LT(n, session.odometry.size());
    const OdometryReading& r = session.odometry[n++];
    std::istringstream ss(line);
    double t, x, y, theta, pan, tilt, v, omega, pan_rate, tilt_rate;
    long long utime, seq;
    ASSERT_TRUE(ss >> t >> utime >> seq >> x >> y >> theta >> pan >> tilt >> v >> omega >> pan_rate >> tilt_rate);
    EXPECT_EQ(t, static_cast<double>(r.utime) / 1e6);
    EXPECT_EQ(utime, r.utime);
    EXPECT_EQ(seq, r.seq);
    EXPECT_EQ(x, r.x_mm);
    EXPECT_EQ(y, r.y_mm);
    EXPECT_EQ(theta, r.theta_rad);
    EXPECT_EQ(pan, r.pan_rad);
    EXPECT_EQ(tilt, r.tilt_rad);
    EXPECT_EQ(v, r.v_mm_s);
    EXPECT_EQ(omega, r.omega_rad_s);
    EXPECT_EQ(pan_rate, r.pan_rate_rad_s);
    EXPECT_EQ(tilt_rate, r.tilt_rate_rad_s);
  }
  EXPECT_EQ(n, session.odometry.size());

#ifdef OBJSCAN_HAVE_CAMERA_DRIVER
  // The camera driver opens the folder: same images, calibration and true poses, in seq order.
  FrameSourceOptions source_options;
  source_options.path = (dir / "dataset").string();
  auto source = OpenFrameSource(source_options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->kind(), SourceKind::kImageFolder);
  ASSERT_EQ(source->NumFrames(), 4);
  for (const auto& expected : session.frames) {
    SourceFrame frame;
    std::string reason, detail;
    ASSERT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kFrame) << reason << " " << detail;
    EXPECT_EQ(frame.name, DatasetImageName(expected.seq));
    EXPECT_TRUE(SameImage(frame.image, expected.image)) << expected.seq;
    EXPECT_EQ(frame.camera.fx, camera.fx);
    EXPECT_EQ(frame.camera.cy, camera.cy);
    EXPECT_EQ(frame.camera.k2, camera.k2);
    ASSERT_TRUE(frame.has_true_pose);
    const auto& truth = session.poses[static_cast<size_t>(expected.seq)].world_from_camera;
    EXPECT_LT((frame.world_from_camera.translation() - truth.translation()).norm(), 1e-9);
    EXPECT_LT((frame.world_from_camera.linear() - truth.linear()).norm(), 1e-12);
  }
  SourceFrame frame;
  std::string reason, detail;
  EXPECT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kEnd);
#else
  GTEST_LOG_(INFO) << "drivers/camera not built: camera driver read-back not checked";
#endif
}

// --video: a video folder (video.avi, frame-numbered timestamps.txt) that the camera driver plays with the frames'
// recorded times; gray and colour frames alike (the video is colour), JPEG-compressed.
TEST(LogExport, WritesAVideoFolderThatTheCameraDriverPlaysWithItsTimes) {
  const fs::path dir = TempDir("video");
  const std::string log_path = (dir / "session.lcmlog").string();
  const Session session = WriteSession(log_path);
  LogExportOptions options;
  options.log_path = log_path;
  options.out_dir = (dir / "dataset").string();
  options.video = true;
  LogExportResult result;
  std::string error;
  ASSERT_TRUE(ExportLogToDataset(options, &result, &error)) << error;
  EXPECT_EQ(result.dataset.frames_written, 4);
  EXPECT_EQ(result.dataset.frames_out_of_order, 0);
  EXPECT_TRUE(fs::is_regular_file(dir / "dataset" / "video.avi"));
  EXPECT_FALSE(fs::exists(dir / "dataset" / "images"));
  std::vector<FrameTime> times;
  ASSERT_TRUE(ReadFrameTimes((dir / "dataset" / kTimestampsFileName).string(), &times, &error)) << error;
  ASSERT_EQ(times.size(), 4u);
  for (size_t i = 0; i < times.size(); ++i) {
    EXPECT_EQ(times[i].file_name, std::to_string(i));
    EXPECT_EQ(times[i].utime, session.frames[i].utime);
  }
#ifdef OBJSCAN_HAVE_CAMERA_DRIVER
  FrameSourceOptions source_options;
  source_options.path = (dir / "dataset").string();
  auto source = OpenFrameSource(source_options, &error);
  ASSERT_TRUE(source) << error;
  EXPECT_EQ(source->kind(), SourceKind::kVideoFile);
  for (const auto& expected : session.frames) {
    SourceFrame frame;
    std::string reason, detail;
    ASSERT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kFrame) << reason << " " << detail;
    EXPECT_EQ(frame.recorded_utime, expected.utime);
    EXPECT_EQ(frame.camera.fx, TestCamera().fx);
    ASSERT_EQ(frame.image.size(), expected.image.size());
    cv::Mat gray_read, gray_expected;
    cv::cvtColor(frame.image, gray_read, cv::COLOR_BGR2GRAY);
    if (expected.image.channels() == 3)
      cv::cvtColor(expected.image, gray_expected, cv::COLOR_BGR2GRAY);
    else
      gray_expected = expected.image;
    cv::Mat blur_read, blur_expected;  // uniform noise: compare 8x8 means, which JPEG keeps
    cv::blur(gray_read, blur_read, cv::Size(8, 8));
    cv::blur(gray_expected, blur_expected, cv::Size(8, 8));
    EXPECT_LT(cv::norm(blur_read, blur_expected, cv::NORM_L1) / blur_read.total(), 3.0) << expected.seq;
  }
  SourceFrame frame;
  std::string reason, detail;
  EXPECT_EQ(source->Next(&frame, &reason, &detail), ReadResult::kEnd);
#endif
}

TEST(LogExport, EveryAndMaxFramesSelectBySeqAndKeepPosesInStep) {
  const fs::path dir = TempDir("subset");
  const std::string log_path = (dir / "session.lcmlog").string();
  const Session session = WriteSession(log_path);

  LogExportOptions options;
  options.log_path = log_path;
  options.out_dir = (dir / "every2").string();
  options.every = 2;
  LogExportResult result;
  std::string error;
  ASSERT_TRUE(ExportLogToDataset(options, &result, &error)) << error;
  EXPECT_EQ(result.dataset.frames_written, 2);  // seq 0 and 2 (seq 4 is truncated)
  EXPECT_TRUE(fs::exists(dir / "every2" / "images" / "000000.png"));
  EXPECT_TRUE(fs::exists(dir / "every2" / "images" / "000002.png"));
  EXPECT_FALSE(fs::exists(dir / "every2" / "images" / "000001.png"));
  std::vector<StampedPose> gt;
  ASSERT_TRUE(ReadTumTrajectory((dir / "every2" / "poses_gt.txt").string(), &gt, &error)) << error;
  ASSERT_EQ(gt.size(), 2u);
  EXPECT_EQ(gt[1].t, static_cast<double>(session.poses[2].utime) / 1e6);

  options.out_dir = (dir / "max3").string();
  options.every = 1;
  options.max_frames = 3;
  ASSERT_TRUE(ExportLogToDataset(options, &result, &error)) << error;
  EXPECT_EQ(result.dataset.frames_written, 3);
  EXPECT_EQ(result.dataset.true_poses_written, 3);
  EXPECT_TRUE(fs::exists(dir / "max3" / "images" / "000002.png"));
  EXPECT_FALSE(fs::exists(dir / "max3" / "images" / "000003.png"));
}

TEST(LogExport, ReportsBadOptionsAndMissingLogs) {
  LogExportOptions options;
  std::string error;
  EXPECT_FALSE(ValidateLogExportOptions(options, &error));  // no --log
  options.log_path = "x.lcmlog";
  EXPECT_FALSE(ValidateLogExportOptions(options, &error));  // no --out
  options.out_dir = TempDir("bad").string();
  EXPECT_TRUE(ValidateLogExportOptions(options, &error)) << error;
  options.every = 0;
  EXPECT_FALSE(ValidateLogExportOptions(options, &error));
  options.every = 1;
  options.max_frames = -1;
  EXPECT_FALSE(ValidateLogExportOptions(options, &error));
  options.max_frames = 0;
  options.image_channel = "";
  EXPECT_FALSE(ValidateLogExportOptions(options, &error));
  options.image_channel = "CAMERA_IMAGE";
  options.log_path = (TempDir("bad") / "missing.lcmlog").string();
  LogExportResult result;
  EXPECT_FALSE(ExportLogToDataset(options, &result, &error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
}

}  // namespace
}  // namespace objscan
