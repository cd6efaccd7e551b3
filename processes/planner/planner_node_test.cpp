#include "processes/planner/planner_node.h"

#include <gtest/gtest.h>

#include "processes/planner/motion.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/options.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"
#include "objscan/robot_command_t.hpp"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

class PlannerNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bus_ = MakeLcmBus("memq://");
    bus_->SubscribeMessage<robot_command_t>("ROBOT_COMMAND", [this](const robot_command_t& m, const RawMessage&) {
      commands_.push_back(m);
      order_.push_back("command " + std::to_string(m.seq) + (m.mode == robot_command_t::MODE_STOP ? " stop" : ""));
    });
    bus_->SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      controls_.push_back(m);
      order_.push_back("control " + std::to_string(m.command) + " " + m.target);
    });
    bus_->SubscribeMessage<process_status_t>(
        "PROCESS_STATUS", [this](const process_status_t& m, const RawMessage&) { statuses_.push_back(m); });
    options_.planner.map.size_mm = 6000;
  }
  void Start() { node_ = std::make_unique<PlannerNode>(*bus_, options_); }
  void Drain() {
    while (bus_->Handle(0) > 0) {
    }
  }
  static int64_t Utime(int64_t seq) { return seq * 1000000 / 30; }
  // Odometry and camera pose of frame seq for a robot that starts at the origin and drives as the last command said
  // (a base that stood still while driven would be a contact), head at pan 0, tilt 20 deg.
  void Frame(int64_t seq, int8_t status = pose_t::STATUS_TRACKING) {
    if (!commands_.empty())
      base_ = Integrate(base_, Velocity{commands_.back().v_mm_s, commands_.back().omega_rad_s}, 1.0 / 30.0);
    OdometryReading r;
    r.utime = Utime(seq) + 15000;
    r.seq = seq;
    r.x_mm = base_.x_mm;
    r.y_mm = base_.y_mm;
    r.theta_rad = base_.theta_rad;
    r.tilt_rad = 20 * kDeg;
    ASSERT_TRUE(bus_->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(r)));
    CameraPoseEstimate p;
    p.utime = Utime(seq);
    p.seq = seq;
    p.world_from_camera = WorldFromCamera(RobotGeometry{}, base_, 0, 20 * kDeg);
    p.status = static_cast<PoseStatus>(status);
    ASSERT_TRUE(bus_->PublishMessage("CAMERA_POSE", PoseToMessage(p)));
    Drain();
  }
  void EndOfStream() {
    control_t c;
    c.session_id = 0;
    c.utime = 0;
    c.sender = "robot_sim";
    c.target = "*";
    c.command = control_t::COMMAND_END_OF_STREAM;
    c.last_seq = 0;
    ASSERT_TRUE(bus_->PublishMessage("OBJSCAN_CONTROL", c));
    Drain();
  }

  std::unique_ptr<Bus> bus_;
  PlannerNodeOptions options_;
  std::unique_ptr<PlannerNode> node_;
  std::vector<robot_command_t> commands_;
  std::vector<control_t> controls_;
  std::vector<process_status_t> statuses_;
  std::vector<std::string> order_;
  BasePose base_;
};

TEST_F(PlannerNodeTest, OneCommandPerPoseWithItsSeqAndUtime) {
  Start();
  for (int64_t seq = 0; seq < 40; ++seq)
    Frame(seq, seq < 10 ? pose_t::STATUS_INITIALIZING : (seq % 7 == 0 ? pose_t::STATUS_LOST : pose_t::STATUS_TRACKING));
  ASSERT_EQ(commands_.size(), 40u);
  for (int64_t seq = 0; seq < 40; ++seq) {
    const robot_command_t& c = commands_[static_cast<size_t>(seq)];
    EXPECT_EQ(c.seq, seq);
    EXPECT_EQ(c.utime, Utime(seq));
    EXPECT_EQ(c.mode, +robot_command_t::MODE_VELOCITY);
    EXPECT_TRUE(c.has_pan_tilt);
    EXPECT_GE(c.v_mm_s, 0.0);
    EXPECT_LE(std::abs(c.omega_rad_s), 30 * kDeg + 1e-9);
    EXPECT_LE(std::abs(c.pan_rad), 170 * kDeg + 1e-9);
    EXPECT_GE(c.tilt_rad, 0.0);
    EXPECT_LE(c.tilt_rad, 60 * kDeg + 1e-9);
  }
  // The start arc: slowly forward into the floor taken as free, turning gently, the head on a floor point ahead.
  EXPECT_GT(commands_.back().omega_rad_s, 0.0);
  EXPECT_GT(commands_.back().v_mm_s, 0.0);
  EXPECT_LE(commands_.back().v_mm_s, 100.0 + 1e-9);
  EXPECT_GT(commands_.back().tilt_rad, 5 * kDeg);
  // A republished older pose (the pose solver's late window) gets no command.
  CameraPoseEstimate late;
  late.utime = Utime(35);
  late.seq = 35;
  late.status = PoseStatus::kTracking;
  ASSERT_TRUE(bus_->PublishMessage("CAMERA_POSE", PoseToMessage(late)));
  Drain();
  EXPECT_EQ(commands_.size(), 40u);
  EXPECT_EQ(node_->commands_sent(), 40);
  EXPECT_EQ(node_->planner().phase(), Phase::kExplore);
}

TEST_F(PlannerNodeTest, FinishedPlanStopsAsksTheDriverToEndAndWritesPlanJson) {
  const std::string dir = ::testing::TempDir() + "planner_node_test_plan";
  std::filesystem::remove_all(dir);
  options_.output_dir = dir;
  options_.planner.explore_budget_s = 1.0;  // nothing to find: NO_TARGET after 1 s of data time
  Start();
  for (int64_t seq = 0; seq < 45; ++seq) Frame(seq);
  ASSERT_EQ(commands_.size(), 45u);
  EXPECT_EQ(node_->planner().phase(), Phase::kNoTarget);
  EXPECT_TRUE(node_->shutdown_sent());
  // The first MODE_STOP, then the SHUTDOWN for robot_sim, then only MODE_STOP commands.
  size_t first_stop = 0;
  while (first_stop < commands_.size() && commands_[first_stop].mode != robot_command_t::MODE_STOP) ++first_stop;
  ASSERT_LT(first_stop, commands_.size());
  EXPECT_EQ(commands_[first_stop].seq, 30);  // utime 1.0 s
  for (size_t i = first_stop; i < commands_.size(); ++i) EXPECT_EQ(commands_[i].mode, +robot_command_t::MODE_STOP);
  int shutdowns = 0;
  for (const control_t& c : controls_) shutdowns += c.command == control_t::COMMAND_SHUTDOWN;
  EXPECT_EQ(shutdowns, 1);
  auto at = [&](const std::string& text) {
    return std::find(order_.begin(), order_.end(), text) - order_.begin();
  };
  EXPECT_EQ(at("control 4 robot_sim"), at("command 30 stop") + 1);
  // End of stream: plan.json, then FINISHED from "planner".
  EndOfStream();
  EXPECT_TRUE(node_->end_of_stream_answered());
  EXPECT_TRUE(node_->Finished());
  ASSERT_FALSE(controls_.empty());
  const control_t& finished = controls_.back();
  EXPECT_EQ(finished.command, +control_t::COMMAND_FINISHED);
  EXPECT_EQ(finished.sender, "planner");
  EXPECT_EQ(finished.last_seq, 44);
  std::ifstream in(dir + "/plan.json");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("\"outcome\": \"no_target\""), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("\"name\": \"NO_TARGET\""), std::string::npos);
  EXPECT_NE(text.str().find("\"seconds\": 1.000"), std::string::npos);  // EXPLORE lasted 1 s of data time
  // No model: the last status is the error state, saying what happened and what to try (the session fails on it).
  ASSERT_FALSE(statuses_.empty());
  EXPECT_EQ(statuses_.back().state, +process_status_t::STATE_ERROR);
  EXPECT_NE(statuses_.back().state_detail.find("no target found"), std::string::npos) << statuses_.back().state_detail;
  EXPECT_NE(statuses_.back().state_detail.find("try"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_F(PlannerNodeTest, MalformedAndInvalidInputsAreCountedAndNeverStopTheNode) {
  Start();
  Frame(0);
  // landmarks_t declaring more landmarks than its bytes hold.
  landmarks_t l;
  l.utime = 0;
  l.seq = 0;
  l.frame = "world";
  l.num_landmarks = 2;
  l.id = {1, 2};
  l.position_mm = {{0, 0, 100}, {1, 1, 100}};
  l.num_observations = {3, 3};
  l.reprojection_error_px = {0.5f, 0.5f};
  l.rgb = {{0, 0, 0}, {0, 0, 0}};
  std::vector<uint8_t> bytes(static_cast<size_t>(l.getEncodedSize()));
  ASSERT_EQ(l.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  ASSERT_TRUE(bus_->Publish("LANDMARKS", bytes.data(), static_cast<int>(bytes.size()) - 20));  // truncated
  bytes[8 + 8 + 8 + 4 + 6 + 3] = 0xff;  // num_landmarks = 255 (low byte)
  ASSERT_TRUE(bus_->Publish("LANDMARKS", bytes.data(), static_cast<int>(bytes.size())));
  // voxel_map_t truncated, camera_info_t and pose_t garbage.
  voxel_map_t v;
  v.frame = "world";
  v.voxel_size_mm = 2;
  v.num_voxels = 1;
  v.ijk = {{1, 2, 3}};
  v.votes = {4};
  v.rgb = {{0, 0, 0}};
  std::vector<uint8_t> vbytes(static_cast<size_t>(v.getEncodedSize()));
  v.encode(vbytes.data(), 0, static_cast<int>(vbytes.size()));
  ASSERT_TRUE(bus_->Publish("VOXEL_MAP", vbytes.data(), static_cast<int>(vbytes.size()) - 1));
  const uint8_t garbage[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  ASSERT_TRUE(bus_->Publish("CAMERA_INFO", garbage, sizeof(garbage)));
  ASSERT_TRUE(bus_->Publish("CAMERA_POSE", garbage, sizeof(garbage)));
  // A target in another frame, a voxel map with a bad voxel size.
  target_t t;
  t.frame = "camera";
  ASSERT_TRUE(bus_->PublishMessage("TARGET", t));
  v.voxel_size_mm = -1;
  ASSERT_TRUE(bus_->PublishMessage("VOXEL_MAP", v));
  Drain();
  // A pose with a NaN position is rejected but still answered (the simulator waits for the command).
  CameraPoseEstimate nan_pose;
  nan_pose.utime = Utime(1);
  nan_pose.seq = 1;
  nan_pose.status = PoseStatus::kTracking;
  pose_t m = PoseToMessage(nan_pose);
  m.position_mm[0] = NAN;
  ASSERT_TRUE(bus_->PublishMessage("CAMERA_POSE", m));
  Drain();
  const StatusReporter& s = node_->status();
  EXPECT_EQ(s.rejected("landmarks: malformed"), 2);
  EXPECT_EQ(s.rejected("voxel_map: malformed"), 1);
  EXPECT_EQ(s.rejected("camera_info: malformed"), 1);
  EXPECT_EQ(s.rejected("pose: malformed"), 1);
  EXPECT_EQ(s.rejected("target: not in world frame"), 1);
  EXPECT_EQ(s.rejected("voxel_map: bad values"), 1);
  EXPECT_EQ(s.rejected_total(), 8);
  ASSERT_EQ(commands_.size(), 2u);
  EXPECT_EQ(commands_[1].seq, 1);
  // Still running: the next frames are answered as before.
  Frame(2);
  Frame(3);
  EXPECT_EQ(commands_.size(), 4u);
}

TEST_F(PlannerNodeTest, StatusCarriesThePhaseAndPlanFigures) {
  options_.status_period_s = 0.001;
  Start();
  for (int64_t seq = 0; seq < 5; ++seq) Frame(seq);
  node_->Tick(WallTimeMicros() + 10000000);
  Drain();
  ASSERT_FALSE(statuses_.empty());
  const process_status_t& st = statuses_.back();
  EXPECT_EQ(st.name, "planner");
  EXPECT_EQ(st.state, +process_status_t::STATE_RUNNING);
  EXPECT_EQ(st.state_detail.rfind("EXPLORE", 0), 0u) << st.state_detail;
  std::vector<std::string> names(st.value_name.begin(), st.value_name.end());
  for (const char* n : {"phase", "coverage", "orbit_percent", "next_views", "path_mm", "odometry_disagreement_mm",
                        "plan_ms", "next_view_ms"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  EXPECT_EQ(node_->status().value("phase"), 0.0);
  EXPECT_EQ(node_->status().value("commands"), 5.0);
}

TEST(PlannerNodeOptionsTest, ValidatesAndConvertsDegrees) {
  PlannerNodeOptions o;
  std::string why;
  EXPECT_TRUE(ValidatePlannerNodeOptions(o, &why)) << why;
  OptionParser parser("planner", "test");
  AddPlannerNodeOptions(parser, &o);
  ASSERT_TRUE(parser.ParseArgs({"--orbit-radius", "900", "--tracking-turn-deg-s", "20", "--next-view-radii",
                                "450,700", "--driver-name", "base"},
                               &why))
      << why;
  PlannerOptions p;
  ASSERT_TRUE(ToPlannerOptions(o, &p, &why)) << why;
  EXPECT_EQ(p.orbit_radius_mm, 900.0);
  EXPECT_NEAR(p.tracking_turn_rad_s, 20 * kDeg, 1e-12);
  ASSERT_EQ(p.next_view.radii_mm.size(), 2u);
  EXPECT_EQ(p.next_view.radii_mm[1], 700.0);
  EXPECT_EQ(o.driver_name, "base");
  o.next_view_radii = "450,abc";
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
  o.next_view_radii = "500";
  o.planner.orbit_radius_mm = 250;  // inside footprint + margin
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
  EXPECT_NE(why.find("orbit radius"), std::string::npos) << why;
  o.planner.orbit_radius_mm = 800;
  o.tracking_turn_deg_s = 120;  // faster than the base may turn
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
  o.tracking_turn_deg_s = 30;
  o.driver_name = "";
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
}

// The robot's geometry comes from robot.cfg (the pose solver reads the same file); a missing or bad file is an
// error that names it.
TEST(PlannerNodeOptionsTest, RobotGeometryFromTheRobotFile) {
  const std::string path = ::testing::TempDir() + "planner_node_test_robot.cfg";
  std::ofstream(path) << "mast_height_mm = 452.5\nmast_offset_x_mm = -30\ncamera_offset_x_mm = 55\n"
                          "footprint_radius_mm = 250\nmax_speed_mm_s = 300\npan_limit_deg = 120\n";
  PlannerNodeOptions o;
  OptionParser parser("planner", "test");
  AddPlannerNodeOptions(parser, &o);
  std::string why;
  ASSERT_TRUE(parser.ParseArgs({"--robot-file", path}, &why)) << why;
  EXPECT_TRUE(ValidatePlannerNodeOptions(o, &why)) << why;
  PlannerOptions p;
  ASSERT_TRUE(ToPlannerOptions(o, &p, &why)) << why;
  EXPECT_EQ(p.robot.mast_height_mm, 452.5);
  EXPECT_EQ(p.robot.mast_offset_x_mm, -30.0);
  EXPECT_EQ(p.robot.camera_offset_mm.x(), 55.0);
  EXPECT_EQ(p.map.footprint_radius_mm, 250.0);
  EXPECT_EQ(p.limits.max_speed_mm_s, 300.0);
  EXPECT_NEAR(p.limits.max_pan_rad, 120 * kDeg, 1e-12);
  EXPECT_NEAR(p.limits.max_omega_rad_s, 90 * kDeg, 1e-12);  // not in the file: the default
  std::ofstream(path) << "mast_height_mm = 45cm\n";
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
  EXPECT_NE(why.find(path), std::string::npos) << why;
  o.robot_file = path + ".missing";
  EXPECT_FALSE(ValidatePlannerNodeOptions(o, &why));
  EXPECT_NE(why.find(".missing"), std::string::npos) << why;
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace objscan
