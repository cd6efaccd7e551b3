#include "drivers/camera/camera_node.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/options.h"
#include "common/recorded_run.h"
#include "common/test_data.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"

namespace objscan {
namespace {
namespace fs = std::filesystem;

std::string TempleDir() { return SharedDataPath("middlebury_templeSparseRing"); }

class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    path_ = fs::temp_directory_path() / ("objscan_camera_node_" + tag + "_" + std::to_string(getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// count frames img_00.png.. (64x48, pixel value 10 k + 5), with the listed ones corrupt or odd-sized, calib.yaml
// and poses_gt.txt (metres, x = 0.1 k).
void WriteFolder(const fs::path& root, int count, const std::vector<int>& corrupt = {},
                 const std::vector<int>& odd = {}) {
  for (int k = 0; k < count; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "img_%02d.png", k);
    const bool is_corrupt = std::find(corrupt.begin(), corrupt.end(), k) != corrupt.end();
    const bool is_odd = std::find(odd.begin(), odd.end(), k) != odd.end();
    if (is_corrupt) {
      std::ofstream(root / name) << "garbage";
    } else {
      cv::imwrite((root / name).string(),
                  cv::Mat(is_odd ? 24 : 48, is_odd ? 32 : 64, CV_8UC3, cv::Scalar(10 * k + 5, 50, 60)));
    }
  }
  PinholeCamera c;
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 70;
  c.cx = 31.5;
  c.cy = 23.5;
  std::string error;
  ASSERT_TRUE(WriteCalibrationFile((root / "calib.yaml").string(), c, &error)) << error;
  std::ofstream gt(root / "poses_gt.txt");
  for (int k = 0; k < count; ++k) gt << k / 30.0 << " " << 0.1 * k << " 0 1 0 0 0 1\n";
}

// Collects everything the node publishes.
struct Recorder {
  std::vector<image_t> images;
  std::vector<camera_info_t> infos;
  std::vector<pose_t> truths;
  std::vector<control_t> controls;
  std::vector<process_status_t> statuses;
  std::vector<std::string> order;  // channel of each message, in arrival order

  explicit Recorder(Bus& bus) {
    bus.SubscribeMessage<image_t>(
        "CAMERA_IMAGE",
        [this](const image_t& m, const RawMessage&) {
          images.push_back(m);
          order.push_back("I");
        },
        {}, 1000);
    bus.SubscribeMessage<camera_info_t>(
        "CAMERA_INFO",
        [this](const camera_info_t& m, const RawMessage&) {
          infos.push_back(m);
          order.push_back("C");
        },
        {}, 1000);
    bus.SubscribeMessage<pose_t>(
        "GROUND_TRUTH_POSE",
        [this](const pose_t& m, const RawMessage&) {
          truths.push_back(m);
          order.push_back("G");
        },
        {}, 1000);
    bus.SubscribeMessage<control_t>(
        "OBJSCAN_CONTROL",
        [this](const control_t& m, const RawMessage&) {
          controls.push_back(m);
          order.push_back("E");
        },
        {}, 1000);
    bus.SubscribeMessage<process_status_t>(
        "PROCESS_STATUS", [this](const process_status_t& m, const RawMessage&) { statuses.push_back(m); }, {}, 1000);
  }
};

void Drain(Bus& bus) {
  while (bus.Handle(0) > 0) {
  }
}

// Ticks the node with a fake wall clock (1 ms steps) until it finishes (or max_ticks).
void RunToEnd(Bus& bus, CameraNode& node, int64_t* wall, int max_ticks = 100000) {
  for (int i = 0; i < max_ticks && !node.Finished(); ++i) {
    node.Tick(*wall);
    *wall += 1000;
    Drain(bus);
  }
  Drain(bus);
}

// A recorded robot run: image times from timestamps.txt, odometry.txt published around each frame (every reading up
// to the frame's time and the next one, so the receiver can interpolate), head angles turned into objscan's
// convention by robot.cfg; the rest after the last frame, before the end of stream.
TEST(CameraNodeTest, RecordedRunPublishesItsOdometryAroundEachFrameAtTheRecordedTimes) {
  TempDir dir("recorded");
  WriteFolder(dir.path(), 3);
  const int64_t t0 = 1'700'000'000'000'000;
  std::vector<FrameTime> times;
  for (int k = 0; k < 3; ++k) times.push_back({"img_0" + std::to_string(k) + ".png", t0 + k * 50'000});
  std::vector<OdometryReading> readings;  // every 20 ms from 30 ms before the first frame to 170 ms after it
  for (int i = 0; i < 11; ++i) {
    OdometryReading r;
    r.utime = t0 - 30'000 + i * 20'000;
    r.seq = i;
    r.x_mm = 10.0 * i;
    r.pan_rad = 0.1 * i;  // this robot's pan encoder counts to the right, zero at 0.05 rad
    readings.push_back(r);
  }
  RobotDescription robot;
  robot.geometry.mast_height_mm = 450;
  robot.pan_sign = -1;
  robot.pan_zero_rad = 0.05;
  std::string error;
  ASSERT_TRUE(WriteFrameTimes((dir.path() / "timestamps.txt").string(), times, &error)) << error;
  ASSERT_TRUE(WriteOdometryFile((dir.path() / "odometry.txt").string(), readings, &error)) << error;

  auto bus = MakeLcmBus("memq://");
  CameraNodeOptions options;
  options.source = dir.path().string();
  options.rate_hz = 0;
  // Without robot.cfg the run is refused, and the message says what is missing and what else to do.
  try {
    CameraNode node(*bus, options);
    ADD_FAILURE() << "a recorded run without robot.cfg was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("robot.cfg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--odometry=false"), std::string::npos) << e.what();
  }
  ASSERT_TRUE(WriteRobotFile((dir.path() / "robot.cfg").string(), robot, &error)) << error;
  options.order = "3,2,1";
  EXPECT_THROW(CameraNode(*bus, options), std::runtime_error);
  options.order.clear();

  Recorder rec(*bus);
  std::vector<odometry_t> odometry;
  std::vector<size_t> odometry_before_frame;  // readings received before each CAMERA_INFO
  bus->SubscribeMessage<odometry_t>(
      "ROBOT_ODOMETRY", [&](const odometry_t& m, const RawMessage&) { odometry.push_back(m); }, {}, 1000);
  bus->SubscribeMessage<camera_info_t>(
      "CAMERA_INFO", [&](const camera_info_t&, const RawMessage&) { odometry_before_frame.push_back(odometry.size()); },
      {}, 1000);
  CameraNode node(*bus, options);
  int64_t wall = 1'000'000'000;
  RunToEnd(*bus, node, &wall);
  ASSERT_TRUE(node.Finished());
  ASSERT_EQ(rec.images.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(rec.images[k].utime, t0 + k * 50'000);
    EXPECT_EQ(rec.images[k].seq, k);
  }
  // Frame times 0, 50, 100 ms; readings at -30, -10, 10, 30, 50, 70, 90, 110, ... ms.
  ASSERT_EQ(odometry_before_frame.size(), 3u);
  EXPECT_EQ(odometry_before_frame[0], 3u);  // -30, -10 and the bracket 10
  EXPECT_EQ(odometry_before_frame[1], 6u);  // 30, 50 and the bracket 70
  EXPECT_EQ(odometry_before_frame[2], 8u);  // 90 and the bracket 110
  ASSERT_EQ(odometry.size(), readings.size());
  for (size_t i = 0; i < odometry.size(); ++i) {
    EXPECT_EQ(odometry[i].utime, readings[i].utime);
    EXPECT_EQ(odometry[i].x_mm, readings[i].x_mm);
    EXPECT_NEAR(odometry[i].pan_rad, -(readings[i].pan_rad - 0.05), 1e-12);
  }
  EXPECT_EQ(rec.order.back(), "E");

  // --odometry=false plays the images alone, at the rate's times.
  CameraNodeOptions images_only = options;
  images_only.odometry = false;
  odometry.clear();
  Recorder rec2(*bus);
  CameraNode node2(*bus, images_only);
  RunToEnd(*bus, node2, &wall);
  EXPECT_TRUE(odometry.empty());
  ASSERT_EQ(rec2.images.size(), 3u);
  EXPECT_EQ(rec2.images[1].utime, std::llround(1e6 / 30.0));
}

TEST(CameraNodeTest, FolderPublishesContiguousFramesSkipsBadFilesAndEndsStream) {
  TempDir dir("folder");
  WriteFolder(dir.path(), 7, {2}, {5});
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  CameraNodeOptions options;
  options.source = dir.path().string();
  options.rate_hz = 0;  // as fast as possible; timestamps at 30 Hz
  CameraNode node(*bus, options);
  int64_t wall = 1'000'000'000;
  RunToEnd(*bus, node, &wall);
  ASSERT_TRUE(node.Finished());

  ASSERT_EQ(rec.images.size(), 5u);
  ASSERT_EQ(rec.infos.size(), 5u);
  ASSERT_EQ(rec.truths.size(), 5u);
  const std::vector<int> source_of_seq = {0, 1, 3, 4, 6};
  for (size_t i = 0; i < rec.images.size(); ++i) {
    const image_t& m = rec.images[i];
    EXPECT_EQ(m.seq, static_cast<int64_t>(i));
    EXPECT_EQ(m.utime, std::llround(static_cast<double>(i) * 1e6 / 30.0));
    EXPECT_EQ(m.encoding, +image_t::ENCODING_RGB8);
    EXPECT_EQ(m.camera_name, "camera");
    ImageFrame frame;
    std::string error;
    ASSERT_TRUE(ImageFromMessage(m, &frame, &error, 64, 48)) << error;
    EXPECT_EQ(frame.image.at<cv::Vec3b>(3, 3)[0], 10 * source_of_seq[i] + 5) << "seq " << i;
    EXPECT_EQ(rec.infos[i].utime, m.utime);
    EXPECT_EQ(rec.infos[i].fx, 70);
    EXPECT_EQ(rec.infos[i].width, 64);
    const pose_t& t = rec.truths[i];
    EXPECT_EQ(t.seq, m.seq);
    EXPECT_EQ(t.utime, m.utime);
    EXPECT_EQ(t.status, +pose_t::STATUS_GROUND_TRUTH);
    EXPECT_EQ(t.scale_source, +pose_t::SCALE_TRUE);
    EXPECT_EQ(t.parent_frame, "world");
    EXPECT_NEAR(t.position_mm[0], 100.0 * source_of_seq[i], 1e-9);
    EXPECT_NEAR(t.position_mm[2], 1000.0, 1e-9);
    EXPECT_NEAR(t.orientation[0], 1.0, 1e-12);
  }
  // Per frame: calibration, image, truth; then the end of stream.
  ASSERT_GE(rec.order.size(), 4u);
  EXPECT_EQ(rec.order[0] + rec.order[1] + rec.order[2], "CIG");
  EXPECT_EQ(rec.order.back(), "E");
  ASSERT_EQ(rec.controls.size(), 1u);
  const control_t& eos = rec.controls[0];
  EXPECT_EQ(eos.command, +control_t::COMMAND_END_OF_STREAM);
  EXPECT_EQ(eos.sender, "camera");
  EXPECT_EQ(eos.last_seq, 4);
  EXPECT_EQ(eos.utime, rec.images.back().utime);

  EXPECT_EQ(node.frames_published(), 5);
  EXPECT_EQ(node.frames_skipped(), 2);
  EXPECT_EQ(node.status().rejected("frame: unreadable file"), 1);
  EXPECT_EQ(node.status().rejected("frame: wrong size"), 1);
  // The status published at the end says so.
  ASSERT_FALSE(rec.statuses.empty());
  const process_status_t& s = rec.statuses.back();
  EXPECT_EQ(s.name, "camera");
  EXPECT_EQ(s.state, +process_status_t::STATE_FINISHED);
  EXPECT_EQ(s.messages_rejected, 2);
  EXPECT_EQ(s.messages_out, 5 * 3 + 1);
  bool found = false;
  for (int i = 0; i < s.num_values; ++i) {
    if (s.value_name[static_cast<size_t>(i)] == "frames_published") {
      EXPECT_EQ(s.value[static_cast<size_t>(i)], 5);
      found = true;
    }
  }
  EXPECT_TRUE(found);

  // After the end nothing more is published.
  node.Tick(wall + 10'000'000);
  node.OnShutdown();
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 5u);
  EXPECT_EQ(rec.controls.size(), 1u);
}

TEST(CameraNodeTest, MiddleburyPublishesPerViewCalibrationAndTruth) {
  if (!fs::is_directory(TempleDir())) GTEST_SKIP() << TempleDir() << " not present";
  std::vector<MiddleburyView> views;
  std::string error;
  ASSERT_TRUE(ReadMiddleburyPar(TempleDir() + "/templeSR_par.txt", &views, &error)) << error;
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  CameraNodeOptions options;
  options.source = TempleDir();
  options.rate_hz = 0;
  options.order = "16,1,2";
  options.rotate_180 = "16";
  options.encoding = "jpeg";
  options.jpeg_quality = 80;
  CameraNode node(*bus, options);
  int64_t wall = 0;
  RunToEnd(*bus, node, &wall);
  ASSERT_EQ(rec.images.size(), 3u);
  ASSERT_EQ(rec.truths.size(), 3u);
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].last_seq, 2);
  const std::vector<int> view_of_seq = {15, 0, 1};
  for (size_t i = 0; i < 3; ++i) {
    const MiddleburyView& v = views[static_cast<size_t>(view_of_seq[i])];
    EXPECT_EQ(rec.images[i].encoding, +image_t::ENCODING_JPEG);
    EXPECT_EQ(rec.images[i].width, 640);
    ImageFrame frame;
    ASSERT_TRUE(ImageFromMessage(rec.images[i], &frame, &error, 640, 480)) << error;
    const bool rotated = i == 0;
    EXPECT_EQ(rec.infos[i].fx, v.K(0, 0));
    EXPECT_EQ(rec.infos[i].cx, rotated ? 639 - v.K(0, 2) : v.K(0, 2));
    EXPECT_EQ(rec.infos[i].cy, rotated ? 479 - v.K(1, 2) : v.K(1, 2));
    // True camera centre C = -R^T t (m) -> mm; orientation R^T (rotated by 180 deg about z for view 16).
    const Eigen::Vector3d centre_mm = -v.R.transpose() * v.t * 1000;
    const pose_t& t = rec.truths[i];
    EXPECT_EQ(t.seq, static_cast<int64_t>(i));
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(t.position_mm[a], centre_mm[a], 1e-6) << i;
    Eigen::Quaterniond q(t.orientation[0], t.orientation[1], t.orientation[2], t.orientation[3]);
    Eigen::Matrix3d expected = v.R.transpose();
    if (rotated) expected = expected * Eigen::Vector3d(-1, -1, 1).asDiagonal();
    EXPECT_LT((q.toRotationMatrix() - expected).norm(), 1e-6) << i;
    // Consistency of the published calibration and pose: a world point projects where K [R | t] says (or
    // mirrored for the rotated view).
    PinholeCamera camera;
    ASSERT_TRUE(CameraFromMessage(rec.infos[i], &camera, &error)) << error;
    const Eigen::Vector3d point_m(-0.02, 0.1, 0.025);
    const Eigen::Vector3d x = v.K * (v.R * point_m + v.t);
    Eigen::Vector2d uv_file = x.head<2>() / x.z();
    if (rotated) uv_file = Eigen::Vector2d(639, 479) - uv_file;
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
    world_from_camera.linear() = q.toRotationMatrix();
    world_from_camera.translation() = Eigen::Vector3d(t.position_mm[0], t.position_mm[1], t.position_mm[2]);
    Eigen::Vector2d uv;
    ASSERT_TRUE(camera.Project(world_from_camera.inverse() * (point_m * 1000), &uv));
    EXPECT_LT((uv - uv_file).norm(), 1e-6) << i;
  }
}

TEST(CameraNodeTest, RatePacingAndRealtimeSchedule) {
  TempDir dir("pace");
  WriteFolder(dir.path(), 6);
  for (bool realtime : {false, true}) {
    auto bus = MakeLcmBus("memq://");
    Recorder rec(*bus);
    CameraNodeOptions options;
    options.source = dir.path().string();
    options.rate_hz = 10;
    options.realtime = realtime;
    CameraNode node(*bus, options);
    const int64_t t0 = 5'000'000;
    node.Tick(t0);
    Drain(*bus);
    EXPECT_EQ(rec.images.size(), 1u);
    node.Tick(t0 + 50'000);  // 50 ms: not due
    Drain(*bus);
    EXPECT_EQ(rec.images.size(), 1u);
    node.Tick(t0 + 100'000);  // due
    Drain(*bus);
    EXPECT_EQ(rec.images.size(), 2u);
    // A stall of 250 ms: realtime catches up with frames 2 and 3 (due at 200 and 300 ms), paced mode sends one.
    node.Tick(t0 + 350'000);
    Drain(*bus);
    EXPECT_EQ(rec.images.size(), realtime ? 4u : 3u) << "realtime " << realtime;
    // utime depends only on seq, never on the wall clock.
    for (size_t i = 0; i < rec.images.size(); ++i) EXPECT_EQ(rec.images[i].utime, static_cast<int64_t>(i) * 100000);
  }
}

TEST(CameraNodeTest, LockstepWaitsForTheConsumerAndTimesOut) {
  TempDir dir("lockstep");
  WriteFolder(dir.path(), 3);
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  CameraNodeOptions options;
  options.source = dir.path().string();
  options.rate_hz = 0;
  options.lockstep_channel = "FEATURE_TRACKS";
  options.lockstep_timeout_ms = 500;
  CameraNode node(*bus, options);
  auto ack = [&](int64_t seq) {
    feature_tracks_t tracks;
    tracks.utime = 123;
    tracks.seq = seq;
    tracks.num_tracks = 0;
    bus->PublishMessage("FEATURE_TRACKS", tracks);
    Drain(*bus);
  };
  int64_t wall = 0;
  node.Tick(wall);
  Drain(*bus);
  ASSERT_EQ(rec.images.size(), 1u);  // frame 0 needs no ack
  node.Tick(wall += 100'000);
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 1u);  // waits for seq >= 0
  ack(0);
  node.Tick(wall += 1000);
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 2u);
  ack(0);  // old seq: not enough for frame 2
  node.Tick(wall += 1000);
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 2u);
  // A too-short message on the channel is rejected, not taken as an ack.
  const uint8_t junk[10] = {0};
  bus->Publish("FEATURE_TRACKS", junk, sizeof(junk));
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("lockstep: message too short"), 1);
  // No ack for seq 1: after the timeout the node goes on.
  node.Tick(wall += 497'000);  // 498 ms after frame 1 was published
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 2u);
  node.Tick(wall += 2'000);
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 3u);
  EXPECT_EQ(node.lockstep_timeouts(), 1);
  // End of stream also waits for the ack of the last frame.
  node.Tick(wall += 1000);
  Drain(*bus);
  EXPECT_TRUE(rec.controls.empty());
  ack(2);
  node.Tick(wall += 1000);
  Drain(*bus);
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].last_seq, 2);
  EXPECT_TRUE(node.Finished());
}

TEST(CameraNodeTest, LoopAndMaxFrames) {
  TempDir dir("loop");
  WriteFolder(dir.path(), 3);
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  CameraNodeOptions options;
  options.source = dir.path().string();
  options.rate_hz = 0;
  options.loop = true;
  options.max_frames = 7;
  options.publish_ground_truth = false;
  options.encoding = "gray8";
  CameraNode node(*bus, options);
  int64_t wall = 0;
  RunToEnd(*bus, node, &wall);
  ASSERT_EQ(rec.images.size(), 7u);
  EXPECT_TRUE(rec.truths.empty());
  for (size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(rec.images[i].seq, static_cast<int64_t>(i));
    EXPECT_EQ(rec.images[i].encoding, +image_t::ENCODING_GRAY8);
    EXPECT_EQ(rec.images[i].size, 64 * 48);
  }
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].last_seq, 6);
}

TEST(CameraNodeTest, ShutdownMidStreamSendsEndOfStream) {
  TempDir dir("stop");
  WriteFolder(dir.path(), 5);
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  CameraNodeOptions options;
  options.source = dir.path().string();
  options.rate_hz = 30;
  CameraNode node(*bus, options);
  node.Tick(0);
  node.OnShutdown();
  node.Tick(1'000'000);
  Drain(*bus);
  EXPECT_EQ(rec.images.size(), 1u);
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].last_seq, 0);
}

// Same input and options -> byte-identical output messages (status excluded), whatever the tick timing.
TEST(CameraNodeTest, OutputIsDeterministic) {
  TempDir dir("determinism");
  WriteFolder(dir.path(), 5, {1}, {});
  auto run = [&](int64_t tick_us) {
    auto bus = MakeLcmBus("memq://");
    std::vector<std::string> messages;
    bus->Subscribe(
        "CAMERA_.*|GROUND_TRUTH_POSE|OBJSCAN_CONTROL",
        [&](const RawMessage& raw) {
          messages.push_back(raw.channel + ":" +
                             std::string(static_cast<const char*>(raw.data), static_cast<size_t>(raw.size)));
        },
        1000);
    CameraNodeOptions options;
    options.source = dir.path().string();
    options.encoding = "jpeg";
    options.rotate_180 = "3";
    options.rate_hz = 20;
    options.session_id = "c0ffee";  // else drawn at random per start
    CameraNode node(*bus, options);
    int64_t wall = 777;
    for (int i = 0; i < 10000 && !node.Finished(); ++i) {
      node.Tick(wall += tick_us);
      Drain(*bus);
    }
    return messages;
  };
  const auto a = run(1000);
  const auto b = run(37'000);
  EXPECT_EQ(a.size(), 4u * 3 + 1);
  EXPECT_TRUE(a == b);
}

TEST(CameraNodeTest, InvalidOptionsAndSourcesThrowAtConstruction) {
  TempDir dir("bad");
  WriteFolder(dir.path(), 2);
  auto bus = MakeLcmBus("memq://");
  CameraNodeOptions options;
  options.source = dir.path().string();
  std::string why;
  EXPECT_TRUE(ValidateCameraNodeOptions(options, &why)) << why;
  auto expect_invalid = [&](CameraNodeOptions o, const std::string& fragment) {
    EXPECT_FALSE(ValidateCameraNodeOptions(o, &why));
    EXPECT_NE(why.find(fragment), std::string::npos) << why;
    EXPECT_THROW(CameraNode(*bus, o), std::invalid_argument);
  };
  CameraNodeOptions o = options;
  o.rate_hz = -1;
  expect_invalid(o, "--rate");
  o = options;
  o.encoding = "yuv";
  expect_invalid(o, "--encoding");
  o = options;
  o.jpeg_quality = 0;
  expect_invalid(o, "--jpeg-quality");
  o = options;
  o.rate_hz = 0;
  o.realtime = true;
  expect_invalid(o, "--realtime");
  o = options;
  o.source = "";
  expect_invalid(o, "--source");

  fs::remove(dir.path() / "calib.yaml");
  try {
    CameraNode node(*bus, options);
    ADD_FAILURE() << "no exception without calibration";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no calibration"), std::string::npos) << e.what();
  }
  o = options;
  o.order = "1,9";
  EXPECT_THROW(CameraNode(*bus, o), std::runtime_error);
}

TEST(CameraNodeTest, TheCommandLineOptionsAreRegistered) {
  CameraNodeOptions options;
  OptionParser parser("camera", "test");
  AddCameraNodeOptions(parser, &options);
  std::string error;
  ASSERT_TRUE(parser.ParseArgs({"--source",
                                "/x",
                                "--calib",
                                "c.yaml",
                                "--rate",
                                "15",
                                "--realtime",
                                "--loop",
                                "--order",
                                "3,2,1",
                                "--rotate-180",
                                "2",
                                "--encoding",
                                "jpeg",
                                "--jpeg-quality",
                                "70",
                                "--max-frames",
                                "9",
                                "--lockstep-channel",
                                "FEATURE_TRACKS",
                                "--lockstep-timeout-ms",
                                "0",
                                "--device-size",
                                "320x240",
                                "--channel",
                                "CAMERA_IMAGE=A",
                                "--channel",
                                "CAMERA_INFO=B",
                                "--channel=GROUND_TRUTH_POSE=C",
                                "--channel",
                                "OBJSCAN_CONTROL=D",
                                "--channel",
                                "PROCESS_STATUS=E",
                                "--exit-when-finished=false"},
                               &error))
      << error;
  EXPECT_EQ(options.rate_hz, 15);
  EXPECT_TRUE(options.realtime);
  EXPECT_TRUE(options.loop);
  EXPECT_EQ(options.rotate_180, "2");
  EXPECT_EQ(options.max_frames, 9);
  EXPECT_EQ(options.lockstep_timeout_ms, 0);
  EXPECT_EQ(options.device_size, "320x240");
  int width = 0, height = 0;
  EXPECT_TRUE(ParseDeviceSize(options.device_size, &width, &height));
  EXPECT_EQ(width, 320);
  EXPECT_EQ(height, 240);
  EXPECT_TRUE(ParseDeviceSize("", &width, &height));
  EXPECT_EQ(width, 0);
  for (const char* bad : {"320", "320x", "x240", "320x-240", "0x240", "320x240x3", "3.5x2", "320 x 240"}) {
    EXPECT_FALSE(ParseDeviceSize(bad, &width, &height)) << bad;
    CameraNodeOptions o = options;
    o.device_size = bad;
    std::string why;
    EXPECT_FALSE(ValidateCameraNodeOptions(o, &why)) << bad;
    EXPECT_NE(why.find("--device-size"), std::string::npos) << why;
  }
  EXPECT_EQ(options.status_channel, "E");
  EXPECT_FALSE(options.exit_when_finished);
  // Settings without a flag (issue 27) are refused on the command line.
  for (const char* flag : {"--gt-position-scale", "--publish-ground-truth", "--camera-name"}) {
    OptionParser other("camera", "test");
    AddCameraNodeOptions(other, &options);
    EXPECT_FALSE(other.ParseArgs({flag, "1"}, &error)) << flag;
  }
}

}  // namespace
}  // namespace objscan
