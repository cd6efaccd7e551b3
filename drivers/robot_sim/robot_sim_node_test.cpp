#include "drivers/robot_sim/robot_sim_node.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/geometry.h"
#include "common/recorded_run.h"
#include "common/robot_model.h"
#include "common/time.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/robot_command_t.hpp"

namespace objscan {
namespace {

// Collects everything the node publishes.
struct Recorder {
  std::vector<image_t> images;
  std::vector<camera_info_t> infos;
  std::vector<odometry_t> odometry;
  std::vector<pose_t> poses;
  std::vector<control_t> controls;
  std::vector<process_status_t> statuses;
  std::vector<std::string> order;  // channel of every data message in publication order

  explicit Recorder(Bus& bus) {
    bus.SubscribeMessage<image_t>("CAMERA_IMAGE", [this](const image_t& m, const RawMessage&) {
      images.push_back(m);
      order.push_back("CAMERA_IMAGE");
    });
    bus.SubscribeMessage<camera_info_t>("CAMERA_INFO", [this](const camera_info_t& m, const RawMessage&) {
      infos.push_back(m);
      order.push_back("CAMERA_INFO");
    });
    bus.SubscribeMessage<odometry_t>("ROBOT_ODOMETRY", [this](const odometry_t& m, const RawMessage&) {
      odometry.push_back(m);
      order.push_back("ROBOT_ODOMETRY");
    });
    bus.SubscribeMessage<pose_t>("GROUND_TRUTH_POSE", [this](const pose_t& m, const RawMessage&) {
      poses.push_back(m);
      order.push_back("GROUND_TRUTH_POSE");
    });
    bus.SubscribeMessage<process_status_t>(
        "PROCESS_STATUS", [this](const process_status_t& m, const RawMessage&) { statuses.push_back(m); });
    bus.SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      if (m.command == control_t::COMMAND_END_OF_STREAM) controls.push_back(m);
    });
  }
};

RobotSimNodeOptions FastOptions(int frames) {
  RobotSimNodeOptions o;
  o.frames = frames;
  o.realtime = false;
  return o;
}

void Drain(Bus& bus) {
  while (bus.Handle(0) > 0) {
  }
}

// Runs the node until it finishes (at most max_ticks ticks).
void RunToEnd(Bus& bus, RobotSimNode& node, int max_ticks = 1000) {
  for (int i = 0; i < max_ticks && !node.Finished(); ++i) {
    node.Tick(WallTimeMicros());
    Drain(bus);
  }
  Drain(bus);
}

TEST(RobotSimNodeTest, PublishesTenFramesWithTruthAndErroneousOdometry) {
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  RobotSimNodeOptions options = FastOptions(10);
  options.orbit_degrees = 18;  // the first 10 frames of the default 200-frame orbit (25 mm per frame)
  const std::string gt_dir = ::testing::TempDir() + "/robot_sim_gt";
  std::filesystem::remove_all(gt_dir);
  options.ground_truth_dir = gt_dir;
  RobotSimNode node(*bus, options);
  RunToEnd(*bus, node);
  ASSERT_TRUE(node.Finished());
  ASSERT_EQ(rec.images.size(), 10u);
  ASSERT_EQ(rec.infos.size(), 10u);
  ASSERT_EQ(rec.odometry.size(), 10u);
  ASSERT_EQ(rec.poses.size(), 10u);
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].sender, "robot_sim");
  EXPECT_EQ(rec.controls[0].last_seq, 9);
  EXPECT_EQ(rec.controls[0].utime, std::llround(9 * 1e6 / 30));
  EXPECT_EQ(rec.order[0], "CAMERA_INFO");
  EXPECT_EQ(rec.order[3], "CAMERA_IMAGE");
  const auto& truth = node.truth_history();
  ASSERT_EQ(truth.size(), 10u);
  const Eigen::Isometry3d start_from_world = WorldFromBase(truth[0].x_mm, truth[0].y_mm, truth[0].theta_rad).inverse();
  for (int i = 0; i < 10; ++i) {
    const int64_t utime = std::llround(i * 1e6 / 30);
    EXPECT_EQ(rec.images[i].seq, i);
    EXPECT_EQ(rec.images[i].utime, utime);
    EXPECT_EQ(rec.images[i].width, 640);
    EXPECT_EQ(rec.images[i].height, 480);
    EXPECT_EQ(rec.images[i].encoding, +image_t::ENCODING_RGB8);
    EXPECT_EQ(rec.infos[i].utime, utime);
    EXPECT_EQ(rec.infos[i].fx, 800);
    EXPECT_EQ(rec.infos[i].cx, 319.5);
    EXPECT_EQ(rec.odometry[i].seq, i);
    EXPECT_EQ(rec.odometry[i].utime, utime + 15000);  // sync offset
    EXPECT_EQ(rec.poses[i].seq, i);
    EXPECT_EQ(rec.poses[i].utime, utime);
    EXPECT_EQ(rec.poses[i].status, +pose_t::STATUS_GROUND_TRUTH);
    EXPECT_EQ(rec.poses[i].scale_source, +pose_t::SCALE_TRUE);
    // GROUND_TRUTH_POSE = WorldFromCamera of the true state
    const Eigen::Isometry3d gt = PoseFromArrays(rec.poses[i].position_mm, rec.poses[i].orientation);
    const Eigen::Isometry3d expected = WorldFromCamera(node.geometry(), truth[i].x_mm, truth[i].y_mm,
                                                       truth[i].theta_rad, truth[i].pan_rad, truth[i].tilt_rad);
    EXPECT_LT((gt.translation() - expected.translation()).norm(), 1e-6);
    EXPECT_LT(RotationAngle(gt.linear().transpose() * expected.linear()), 1e-9);
    // head readings: 0.5 deg bias + 0.05 deg noise
    const double pan_error = (rec.odometry[i].pan_rad - truth[i].pan_rad) * 180 / M_PI;
    const double tilt_error = (rec.odometry[i].tilt_rad - truth[i].tilt_rad) * 180 / M_PI;
    EXPECT_NEAR(pan_error, 0.5, 0.25);
    EXPECT_NEAR(tilt_error, 0.5, 0.25);
    EXPECT_GT(rec.odometry[i].v_mm_s, truth[i].v_mm_s);  // +2 % scale error
  }
  // Odometry (start frame) vs truth after 9 steps of 25 mm: ~2 % longer path, but not wildly off.
  const Eigen::Vector3d true_end = start_from_world * Eigen::Vector3d(truth[9].x_mm, truth[9].y_mm, 0);
  const double true_dist = true_end.head<2>().norm();
  const double odo_dist = std::hypot(rec.odometry[9].x_mm, rec.odometry[9].y_mm);
  EXPECT_GT(odo_dist / true_dist, 1.005);
  EXPECT_LT(odo_dist / true_dist, 1.04);
  EXPECT_GT(std::hypot(rec.odometry[9].x_mm - true_end.x(), rec.odometry[9].y_mm - true_end.y()), 1.0);
  EXPECT_LT(std::hypot(rec.odometry[9].x_mm - true_end.x(), rec.odometry[9].y_mm - true_end.y()), 15.0);
  // the image shows the target in the middle
  ImageFrame frame;
  std::string error;
  ASSERT_TRUE(ImageFromMessage(rec.images[0], &frame, &error)) << error;
  EXPECT_EQ(frame.image.type(), CV_8UC3);
  // status
  EXPECT_EQ(node.status().value("frames_published"), 10);
  EXPECT_GT(node.status().value("render_ms"), 0);
  EXPECT_EQ(node.status().messages_out(), 41);
  node.OnShutdown();  // forces a final status message
  Drain(*bus);
  ASSERT_GE(rec.statuses.size(), 1u);
  const process_status_t& last = rec.statuses.back();
  EXPECT_EQ(last.name, "robot_sim");
  EXPECT_EQ(last.state, +process_status_t::STATE_FINISHED);
  bool has_frames = false;
  for (int k = 0; k < last.num_values; ++k)
    if (last.value_name[k] == "frames_published") has_frames = last.value[k] == 10;
  EXPECT_TRUE(has_frames);
  // ground-truth files
  std::ifstream poses(gt_dir + "/poses_gt.txt");
  std::string line;
  int data_lines = 0, comments = 0;
  while (std::getline(poses, line)) (line[0] == '#' ? comments : data_lines)++;
  EXPECT_EQ(data_lines, 10);
  EXPECT_EQ(comments, 1);
  EXPECT_TRUE(std::filesystem::exists(gt_dir + "/robot_gt.txt"));
  // scene.txt is the resolved scene and loads again as a scene file
  const Scene reloaded = LoadScene(gt_dir + "/scene.txt");
  ASSERT_EQ(reloaded.objects.size(), node.scene().objects.size());
  EXPECT_EQ(reloaded.target().name, node.scene().target().name);
  EXPECT_LT((reloaded.TargetCenter() - node.scene().TargetCenter()).norm(), 1e-6);
  EXPECT_EQ(reloaded.target().texture.seed, node.scene().target().texture.seed);
  const auto ply_size = std::filesystem::file_size(gt_dir + "/target_surface.ply");
  EXPECT_GT(ply_size, 24u * 120000u);  // ~4 pi 100^2 points of 24 bytes
  EXPECT_LT(ply_size, 24u * 132000u);
  // The rendered surface: the target's tessellation, every vertex on the true sphere (r 100 mm around its centre).
  RawMesh truth_mesh;
  ASSERT_TRUE(LoadMeshFile(gt_dir + "/target_mesh.ply", &truth_mesh, &error)) << error;
  EXPECT_EQ(truth_mesh.triangles.size(), node.scene().target().mesh.triangles.size());
  ASSERT_GT(truth_mesh.positions.size(), 100u);
  for (const Eigen::Vector3d& p : truth_mesh.positions)
    EXPECT_NEAR((p - node.scene().target().center_mm).norm(), node.scene().target().radius_mm, 1e-3);
}

// The ground-truth folder's robot.cfg describes the robot that ran: with --robot-file, its geometry, footprint and
// head limits (not the defaults), in objscan's angle convention (the simulator reports its head angles in it).
TEST(RobotSimNodeTest, TheGroundTruthRobotFileKeepsTheRobotFilesLimits) {
  const std::string dir = ::testing::TempDir() + "/robot_sim_robot_file";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RobotDescription given;
  given.geometry.mast_height_mm = 520;
  given.footprint_radius_mm = 180;
  given.pan_limit_deg = 120;
  given.tilt_min_deg = -10;
  given.tilt_max_deg = 45;
  given.pan_sign = -1;
  std::string error;
  ASSERT_TRUE(WriteRobotFile(dir + "/given.cfg", given, &error)) << error;
  auto bus = MakeLcmBus("memq://");
  RobotSimNodeOptions options = FastOptions(2);
  options.robot_file = dir + "/given.cfg";
  options.ground_truth_dir = dir + "/gt";
  {
    RobotSimNode node(*bus, options);
    RunToEnd(*bus, node);
  }
  RobotDescription written;
  ASSERT_TRUE(ReadRobotFile(dir + "/gt/robot.cfg", &written, &error)) << error;
  EXPECT_EQ(written.geometry.mast_height_mm, 520);
  EXPECT_EQ(written.footprint_radius_mm, 180);
  EXPECT_EQ(written.pan_limit_deg, 120);
  EXPECT_EQ(written.tilt_min_deg, -10);
  EXPECT_EQ(written.tilt_max_deg, 45);
  EXPECT_EQ(written.pan_sign, 1);  // objscan's convention
}

TEST(RobotSimNodeTest, OutputIsDeterministicAndEncodingsWork) {
  std::vector<std::vector<uint8_t>> runs;
  for (int run = 0; run < 2; ++run) {
    auto bus = MakeLcmBus("memq://");
    Recorder rec(*bus);
    RobotSimNode node(*bus, FastOptions(3));
    RunToEnd(*bus, node);
    ASSERT_EQ(rec.images.size(), 3u);
    runs.push_back(rec.images[2].data);
    runs.back().push_back(static_cast<uint8_t>(rec.odometry[2].x_mm));
  }
  EXPECT_EQ(runs[0], runs[1]);
  for (const char* encoding : {"gray8", "jpeg"}) {
    auto bus = MakeLcmBus("memq://");
    Recorder rec(*bus);
    RobotSimNodeOptions options = FastOptions(2);
    options.encoding = encoding;
    RobotSimNode node(*bus, options);
    RunToEnd(*bus, node);
    ASSERT_EQ(rec.images.size(), 2u);
    ImageFrame frame;
    std::string error;
    ASSERT_TRUE(ImageFromMessage(rec.images[1], &frame, &error)) << error;
    EXPECT_EQ(frame.image.cols, 640);
    if (std::string(encoding) == "gray8") {
      EXPECT_EQ(frame.image.type(), CV_8UC1);
    }
  }
}

// Every image and odometry reading carries the session's id: --session-id's, else one drawn at start (never 0).
TEST(RobotSimNodeTest, StampsItsSessionOnWhatItPublishes) {
  for (const char* given : {"", "abc"}) {
    auto bus = MakeLcmBus("memq://");
    Recorder rec(*bus);
    RobotSimNodeOptions options = FastOptions(2);
    options.session_id = given;
    RobotSimNode node(*bus, options);
    RunToEnd(*bus, node);
    ASSERT_EQ(rec.images.size(), 2u);
    ASSERT_EQ(rec.odometry.size(), 2u);
    const int64_t id = rec.images[0].session_id;
    if (std::string(given).empty())
      EXPECT_NE(id, 0);
    else
      EXPECT_EQ(id, 0xabc);
    EXPECT_EQ(rec.images[1].session_id, id);
    for (const odometry_t& o : rec.odometry) EXPECT_EQ(o.session_id, id);
    for (const camera_info_t& c : rec.infos) EXPECT_EQ(c.session_id, id);
  }
  auto bus = MakeLcmBus("memq://");
  RobotSimNodeOptions bad = FastOptions(2);
  bad.session_id = "not-hex";
  EXPECT_THROW(RobotSimNode(*bus, bad), std::invalid_argument);
}

// --blank FIRST,COUNT renders frames FIRST..FIRST+COUNT-1 grey (the tracking loss tests); anything else is refused.
TEST(RobotSimNodeTest, BlankFramesAreGreyAndBadSpecsRefused) {
  RobotSimNodeOptions options = FastOptions(4);
  std::string why;
  for (const char* bad : {"80", "80,", "80,20,", "-1,5", "80,2.5", "a,b", "1,2,3"}) {
    options.blank = bad;
    EXPECT_FALSE(ValidateRobotSimNodeOptions(options, &why)) << bad;
    EXPECT_NE(why.find("--blank"), std::string::npos) << why;
  }
  options.blank = "1,2";
  ASSERT_TRUE(ValidateRobotSimNodeOptions(options, &why)) << why;
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  RobotSimNode node(*bus, options);
  RunToEnd(*bus, node);
  ASSERT_EQ(rec.images.size(), 4u);
  for (size_t i = 0; i < rec.images.size(); ++i) {
    const image_t& m = rec.images[i];
    const auto [lo, hi] = std::minmax_element(m.data.begin(), m.data.end());
    const bool grey = *lo == *hi;
    EXPECT_EQ(grey, i == 1 || i == 2) << "frame " << i;
  }
}

TEST(RobotSimNodeTest, LockstepWaitsForTheConsumerAndTimesOut) {
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  RobotSimNodeOptions options = FastOptions(4);
  options.lockstep_channel = "FEATURE_TRACKS";
  options.lockstep_timeout_ms = 0;  // forever
  RobotSimNode node(*bus, options);
  for (int i = 0; i < 5; ++i) {
    node.Tick(WallTimeMicros());
    Drain(*bus);
  }
  EXPECT_EQ(rec.images.size(), 1u);
  feature_tracks_t tracks;
  tracks.utime = 0;
  tracks.seq = 0;
  tracks.camera_name = "sim";
  tracks.image_width = 640;
  tracks.image_height = 480;
  tracks.num_tracks = 0;
  bus->PublishMessage("FEATURE_TRACKS", tracks);
  Drain(*bus);
  for (int i = 0; i < 5; ++i) {
    node.Tick(WallTimeMicros());
    Drain(*bus);
  }
  EXPECT_EQ(rec.images.size(), 2u);
  tracks.seq = 3;  // covers everything
  bus->PublishMessage("FEATURE_TRACKS", tracks);
  Drain(*bus);
  RunToEnd(*bus, node, 20);
  EXPECT_EQ(rec.images.size(), 4u);
  EXPECT_TRUE(node.Finished());

  // with a timeout: goes on after waiting
  auto bus2 = MakeLcmBus("memq://");
  Recorder rec2(*bus2);
  options.lockstep_timeout_ms = 20;
  options.frames = 2;
  RobotSimNode node2(*bus2, options);
  node2.Tick(WallTimeMicros());
  node2.Tick(WallTimeMicros());
  Drain(*bus2);
  EXPECT_EQ(rec2.images.size(), 1u);
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  node2.Tick(WallTimeMicros());
  Drain(*bus2);
  EXPECT_EQ(rec2.images.size(), 2u);
  EXPECT_EQ(node2.lockstep_timeouts(), 1);
}

TEST(RobotSimNodeTest, CommandModeFollowsRobotCommandAndStopsOnShutdown) {
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  RobotSimNodeOptions options = FastOptions(0);
  options.mode = "command";
  RobotSimNode node(*bus, options);
  robot_command_t command{};
  command.utime = 0;
  command.seq = 0;
  command.mode = robot_command_t::MODE_VELOCITY;
  command.v_mm_s = 300;
  command.omega_rad_s = 0;
  command.has_pan_tilt = false;
  bus->PublishMessage("ROBOT_COMMAND", command);
  robot_command_t bad = command;
  bad.seq = 1;
  bad.v_mm_s = NAN;
  bus->PublishMessage("ROBOT_COMMAND", bad);
  bad.seq = 2;
  bad.v_mm_s = 0;
  bad.mode = 9;
  bus->PublishMessage("ROBOT_COMMAND", bad);
  bus->Publish("ROBOT_COMMAND", "xx", 2);
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("command: non-finite value"), 1);
  EXPECT_EQ(node.status().rejected("command: unknown mode"), 1);
  EXPECT_EQ(node.status().rejected("command: malformed"), 1);
  for (int i = 0; i < 11; ++i) {
    node.Tick(WallTimeMicros());
    Drain(*bus);
  }
  ASSERT_EQ(rec.images.size(), 11u);
  const auto& truth = node.truth_history();
  const double moved = std::hypot(truth[10].x_mm - truth[0].x_mm, truth[10].y_mm - truth[0].y_mm);
  EXPECT_NEAR(moved, 300.0 * 10 / 30, 1e-6);
  EXPECT_FALSE(node.Finished());
  control_t shutdown;
  shutdown.session_id = 0;
  shutdown.utime = 0;
  shutdown.sender = "test";
  shutdown.target = "robot_sim";
  shutdown.command = control_t::COMMAND_SHUTDOWN;
  shutdown.last_seq = -1;
  bus->PublishMessage("OBJSCAN_CONTROL", shutdown);
  Drain(*bus);
  RunToEnd(*bus, node, 5);
  EXPECT_TRUE(node.Finished());
  ASSERT_EQ(rec.controls.size(), 1u);
  EXPECT_EQ(rec.controls[0].last_seq, static_cast<int64_t>(rec.images.size()) - 1);
}

// The value `name` of a process_status_t (NAN when absent).
double StatusValue(const process_status_t& status, const std::string& name) {
  for (int k = 0; k < status.num_values; ++k)
    if (status.value_name[k] == name) return status.value[k];
  return NAN;
}

TEST(RobotSimNodeTest, CommandModeStopsAtAnObstacleCountsItAndWritesTheOutcome) {
  const std::string dir = ::testing::TempDir() + "/robot_sim_collision";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    std::ofstream scene(dir + "/crate.scene");
    scene << "sphere name=ball center=0,2000,100 radius=100 target=true\n"
             "box name=crate center=1000,0,250 size=400,400,500\n"
             "robot start=0,0,0\n";
  }
  auto bus = MakeLcmBus("memq://");
  Recorder rec(*bus);
  RobotSimNodeOptions options = FastOptions(0);
  options.mode = "command";
  options.scene = dir + "/crate.scene";
  std::string why;
  options.footprint_radius_mm = -5;
  EXPECT_FALSE(ValidateRobotSimNodeOptions(options, &why));
  EXPECT_NE(why.find("footprint_radius_mm"), std::string::npos) << why;
  options.footprint_radius_mm = 200;
  options.ground_truth_dir = dir + "/gt";
  RobotSimNode node(*bus, options);
  robot_command_t command{};
  command.mode = robot_command_t::MODE_VELOCITY;
  command.v_mm_s = 300;
  command.has_pan_tilt = false;
  for (int i = 0; i < 90; ++i) {  // 3 s at 300 mm/s towards a face 600 mm ahead (footprint 200 mm)
    command.seq = i;
    bus->PublishMessage("ROBOT_COMMAND", command);
    Drain(*bus);
    node.Tick(WallTimeMicros());
    Drain(*bus);
  }
  ASSERT_EQ(rec.images.size(), 90u);
  const auto& truth = node.truth_history();
  EXPECT_EQ(truth.front().x_mm, 0);  // the scene's start pose
  EXPECT_GE(truth.back().x_mm, 590 - 1e-9);
  EXPECT_LE(truth.back().x_mm, 600 + 1e-9);
  EXPECT_EQ(node.status().value("collisions"), 1);
  EXPECT_GE(node.status().value("blocked_frames"), 25);
  // the odometry reports the stop: no translation over the blocked frames
  EXPECT_EQ(rec.odometry[89].x_mm, rec.odometry[80].x_mm);
  control_t shutdown{};
  shutdown.sender = "test";
  shutdown.target = "*";
  shutdown.command = control_t::COMMAND_SHUTDOWN;
  shutdown.last_seq = -1;
  bus->PublishMessage("OBJSCAN_CONTROL", shutdown);
  Drain(*bus);
  RunToEnd(*bus, node, 5);
  ASSERT_TRUE(node.Finished());
  node.OnShutdown();
  Drain(*bus);
  ASSERT_FALSE(rec.statuses.empty());
  EXPECT_EQ(StatusValue(rec.statuses.back(), "collisions"), 1);
  EXPECT_EQ(StatusValue(rec.statuses.back(), "blocked_frames"), node.status().value("blocked_frames"));
  // sim_outcome.json
  std::ifstream file(dir + "/gt/sim_outcome.json");
  ASSERT_TRUE(file.good());
  const std::string json((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  for (const std::string expected :
       {"\"frames\": 90,", "\"collisions\": 1,", "\"name\": \"ball\"", "\"shape\": \"sphere\"",
        "\"center_mm\": [0, 2000, 100]", "\"size_mm\": [200, 200, 200]", "\"yaw_rad\": 0,"})
    EXPECT_NE(json.find(expected), std::string::npos) << expected << " in\n" << json;
  const size_t at = json.find("\"path_length_mm\": ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NEAR(std::stod(json.substr(at + 18)), truth.back().x_mm, 1e-6);
  // scene.txt keeps the robot line and loads again
  const Scene reloaded = LoadScene(dir + "/gt/scene.txt");
  ASSERT_TRUE(reloaded.has_robot_start);
  EXPECT_EQ(reloaded.robot_start.x_mm, 0);
  EXPECT_NEAR(reloaded.robot_start.tilt_rad, 25 * M_PI / 180, 1e-12);
}

TEST(RobotSimNodeTest, InvalidOptionsAreRejected) {
  auto bus = MakeLcmBus("memq://");
  RobotSimNodeOptions options;
  options.encoding = "png";
  EXPECT_THROW(RobotSimNode(*bus, options), std::invalid_argument);
  options = RobotSimNodeOptions();
  options.orbit_center = "1,2,3";
  std::string why;
  EXPECT_FALSE(ValidateRobotSimNodeOptions(options, &why));
  options = RobotSimNodeOptions();
  options.fx = -1;
  EXPECT_FALSE(ValidateRobotSimNodeOptions(options, &why));
  options = RobotSimNodeOptions();
  options.scene = "/nonexistent.scene";
  EXPECT_THROW(RobotSimNode(*bus, options), std::runtime_error);
  EXPECT_TRUE(ValidateRobotSimNodeOptions(RobotSimNodeOptions(), &why)) << why;
}

}  // namespace
}  // namespace objscan
