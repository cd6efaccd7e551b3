#include "processes/object_finder/object_finder_node.h"

#include <gtest/gtest.h>

#include <regex>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/core/persistence.hpp>
#include <vector>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/options.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"
#include "common/message_size_check.h"
#include "processes/object_finder/synthetic_room.h"

namespace objscan {
namespace {

using testing_support::SyntheticRoom;

const Eigen::Vector3d kBoxCentre(400, -200, 70);  // the target: 150 x 120 x 140 mm box

landmarks_t LandmarksMessage(const FinderInput& in) {
  landmarks_t m;
  m.utime = in.utime;
  m.seq = in.seq;
  m.frame = "world";
  m.num_landmarks = static_cast<int32_t>(in.landmarks.size());
  for (const MapLandmark& l : in.landmarks) {
    m.id.push_back(l.id);
    m.position_mm.push_back({static_cast<float>(l.position_mm.x()), static_cast<float>(l.position_mm.y()),
                             static_cast<float>(l.position_mm.z())});
    m.num_observations.push_back(l.num_observations);
    m.reprojection_error_px.push_back(static_cast<float>(l.reprojection_error_px));
    m.rgb.push_back({128, 128, 128});
  }
  return m;
}

std::vector<uint8_t> Encode(const landmarks_t& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return bytes;
}

// Overwrites a big-endian int32 field (the caller's offset lies inside the message).
void PutInt32(std::vector<uint8_t>* bytes, size_t offset, int32_t value) {
  const uint32_t v = static_cast<uint32_t>(value);
  const uint8_t be[4] = {static_cast<uint8_t>(v >> 24), static_cast<uint8_t>(v >> 16), static_cast<uint8_t>(v >> 8),
                         static_cast<uint8_t>(v)};
  if (offset + 4 <= bytes->size()) std::memcpy(bytes->data() + offset, be, 4);
}

class ObjectFinderNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    MakeBus();
    room_.AddFloor(2500, 2000, 2.0);
    room_.AddBox("box", kBoxCentre.head<2>(), Eigen::Vector3d(150, 120, 140), 0.3, 12);
    room_.AddSphere("sphere", Eigen::Vector2d(-2000, 1500), 200, 12);
    room_.AddWall("wall", Eigen::Vector2d(2200, -2000), Eigen::Vector2d(2200, 2000), 1000, 3);
    room_.AddPhantoms(30, 2000, 100, 1000);
    out_dir_ = std::filesystem::temp_directory_path() /
               ("object_finder_node_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(out_dir_);
    options_.output_dir = out_dir_.string();
  }
  void TearDown() override { std::filesystem::remove_all(out_dir_); }

  // A new bus (a node's subscriptions live as long as its bus: one bus per node).
  void MakeBus() {
    node_.reset();
    bus_ = MakeLcmBus("memq://");
    bus_->SubscribeMessage<target_t>("TARGET", [this](const target_t& m, const RawMessage&) { targets_.push_back(m); });
    bus_->SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      if (m.command == control_t::COMMAND_FINISHED && m.sender == "object_finder") finished_.push_back(m);
    });
  }
  void Start() { node_ = std::make_unique<ObjectFinderNode>(*bus_, options_); }
  void Drain() {
    while (bus_->Handle(0) > 0) {
    }
  }
  void PublishInfo() {
    PinholeCamera camera;
    camera.name = "sim";
    camera.width = room_.camera().width;
    camera.height = room_.camera().height;
    camera.fx = room_.camera().fx;
    camera.fy = room_.camera().fy;
    camera.cx = room_.camera().cx;
    camera.cy = room_.camera().cy;
    ASSERT_TRUE(bus_->PublishMessage("CAMERA_INFO", CameraToMessage(camera, 0)));
  }
  void PublishPose(int64_t seq, const Eigen::Isometry3d& world_from_camera, PoseStatus status = PoseStatus::kTracking,
                   const std::string& channel = "CAMERA_POSE") {
    CameraPoseEstimate pose;
    pose.seq = seq;
    pose.utime = seq * 100000;
    pose.world_from_camera = world_from_camera;
    pose.status = status;
    ASSERT_TRUE(bus_->PublishMessage(channel, PoseToMessage(pose)));
  }
  void PoseSolverFinished() { Finished("pose_solver"); }
  void Finished(const std::string& sender) {
    control_t c;
    c.session_id = 0;
    c.utime = 0;
    c.sender = sender;
    c.target = "*";
    c.command = control_t::COMMAND_FINISHED;
    c.last_seq = 100;
    ASSERT_TRUE(bus_->PublishMessage("OBJSCAN_CONTROL", c));
  }
  // Keyframe k of a circle about the box: CAMERA_POSE then LANDMARKS, as the pose solver publishes them.
  FinderInput Keyframe(int k) {
    const Eigen::Isometry3d pose = room_.OnCircle(kBoxCentre.head<2>(), 1200, k * 25.0 - 60, kBoxCentre);
    return room_.Observe(pose, 10 * k + 3);
  }
  void PublishKeyframe(int k) {
    const FinderInput in = Keyframe(k);
    PublishPose(in.seq, in.world_from_camera);
    ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", LandmarksMessage(in)));
  }
  void EndOfStream() {
    control_t c;
    c.session_id = 0;
    c.utime = 0;
    c.sender = "robot_sim";
    c.target = "*";
    c.command = control_t::COMMAND_END_OF_STREAM;
    c.last_seq = 100;
    ASSERT_TRUE(bus_->PublishMessage("OBJSCAN_CONTROL", c));
  }

  SyntheticRoom room_;
  std::unique_ptr<Bus> bus_;
  ObjectFinderNodeOptions options_;
  std::unique_ptr<ObjectFinderNode> node_;
  std::vector<target_t> targets_;
  std::vector<control_t> finished_;
  std::filesystem::path out_dir_;
};

TEST_F(ObjectFinderNodeTest, ConfirmsTheTargetAndWritesTargetJson) {
  Start();
  PublishInfo();
  for (int k = 0; k < 6; ++k) {
    // no pose of the keyframe itself: the newest usable one before it is taken, not a LOST one
    const FinderInput in = Keyframe(k);
    PublishPose(in.seq - 2, in.world_from_camera);
    PublishPose(in.seq - 1, Eigen::Isometry3d(Eigen::Translation3d(9000, 9000, 9000)), PoseStatus::kLost);
    ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", LandmarksMessage(in)));
  }
  Drain();
  ASSERT_EQ(targets_.size(), 6u);
  for (size_t i = 0; i < targets_.size(); ++i) {
    EXPECT_EQ(targets_[i].seq, static_cast<int64_t>(10 * i + 3));
    EXPECT_EQ(targets_[i].utime, targets_[i].seq * 100000);
    EXPECT_EQ(targets_[i].frame, "world");
  }
  EXPECT_EQ(targets_[0].state, +target_t::STATE_CANDIDATE);
  const target_t& t = targets_.back();
  ASSERT_EQ(t.state, +target_t::STATE_CONFIRMED);
  EXPECT_LT((Eigen::Vector3d(t.center_mm[0], t.center_mm[1], t.center_mm[2]) - kBoxCentre).norm(), 10.0);
  EXPECT_NEAR(t.size_mm[0], 150, 15);
  EXPECT_NEAR(t.size_mm[1], 120, 15);
  EXPECT_NEAR(t.size_mm[2], 140, 15);
  EXPECT_NEAR(t.yaw_rad, 0.3, 0.05);
  EXPECT_GE(t.confidence, 0.5);
  // the box is at the image centre, ~1.2 m away: ~100 px wide
  EXPECT_GT(t.roi_width, 70);
  EXPECT_LT(t.roi_width, 200);
  EXPECT_NEAR(t.roi_u + 0.5 * t.roi_width, 320, 40);
  EXPECT_EQ(node_->status().value("state"), +target_t::STATE_CONFIRMED);
  EXPECT_EQ(node_->status().value("confirmed_seq"), node_->finder().result().confirmed_seq);
  EXPECT_EQ(node_->status().value("lost_poses"), 6);
  EXPECT_GT(node_->status().value("floor_points"), 1000);
  EXPECT_EQ(node_->status().rejected_total(), 0);

  // stateless: the latest TARGET again every target_period_s of wall time (clock given to Tick: deterministic)
  const int64_t later = WallTimeMicros() + 1000000000;
  node_->Tick(later);
  Drain();
  ASSERT_EQ(targets_.size(), 7u);
  EXPECT_EQ(targets_.back().seq, t.seq);
  EXPECT_EQ(targets_.back().state, +target_t::STATE_CONFIRMED);
  node_->Tick(later + 300000);
  Drain();
  EXPECT_EQ(targets_.size(), 7u);
  node_->Tick(later + 1000000);
  Drain();
  EXPECT_EQ(targets_.size(), 8u);

  // With a target, the end waits for the pose solver's final poses; none came (3 frames since the confirmation have
  // online poses here): target.json stays in the online frame.
  EndOfStream();
  Drain();
  EXPECT_TRUE(finished_.empty());
  EXPECT_FALSE(node_->Finished());
  EXPECT_TRUE(std::filesystem::exists(out_dir_ / "target.json"));  // the online one, at once
  PoseSolverFinished();
  Drain();
  EXPECT_TRUE(finished_.empty());  // then it waits for the dense model; the dense modeler ends without one
  Finished("dense_modeler");
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].sender, "object_finder");
  EXPECT_EQ(finished_[0].last_seq, 53);
  EXPECT_TRUE(node_->Finished());

  cv::FileStorage json((out_dir_ / "target.json").string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
  ASSERT_TRUE(json.isOpened());
  EXPECT_EQ(static_cast<std::string>(json["state"]), "confirmed");
  std::vector<double> centre, size, normal;
  json["centre_mm"] >> centre;
  json["size_mm"] >> size;
  json["floor"]["normal"] >> normal;
  ASSERT_EQ(centre.size(), 3u);
  ASSERT_EQ(size.size(), 3u);
  EXPECT_LT((Eigen::Vector3d(centre[0], centre[1], centre[2]) - kBoxCentre).norm(), 10.0);
  EXPECT_NEAR(size[2], 140, 15);
  EXPECT_NEAR(static_cast<double>(json["yaw_rad"]), 0.3, 0.05);
  EXPECT_EQ(static_cast<int>(json["confirmed_seq"]), node_->finder().result().confirmed_seq);
  EXPECT_GE(static_cast<int>(json["views"]), 3);
  EXPECT_GE(static_cast<double>(json["confidence"]), 0.5);
  ASSERT_EQ(normal.size(), 3u);
  EXPECT_GT(normal[2], 0.999);
  EXPECT_NEAR(static_cast<double>(json["floor"]["offset_mm"]), 0.0, 2.0);
  EXPECT_TRUE(json["other_candidates"].isSeq());
  EXPECT_EQ(static_cast<std::string>(json["box_source"]), "landmarks");
  EXPECT_NE(static_cast<std::string>(json["model_box_error"]).find("no model on MODEL (the dense modeler finished"),
            std::string::npos);
}

// The final phase moved the frames since the confirmation rigidly (a joined or re-chained map restart: room_07's
// target.json was 117 mm off trajectory.txt's frame): target.json follows them into the final poses' frame.
TEST_F(ObjectFinderNodeTest, WhileSearchingTheLogSaysWhyTheClustersAreNoTarget) {
  options_.finder.target_max_size_mm = 100;  // the 150 x 120 x 140 mm box is now too big to be the target
  Start();
  PublishInfo();
  Drain();
  ::testing::internal::CaptureStderr();
  for (int k = 0; k < 20; ++k) {
    PublishKeyframe(k);
    Drain();
  }
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_FALSE(targets_.empty());
  EXPECT_EQ(static_cast<int>(targets_.back().state), static_cast<int>(target_t::STATE_SEARCHING));
  // Every 20 updates: the biggest plausible clusters and the rule's reason, the box first.
  const auto line = log.find("searching: ");
  ASSERT_NE(line, std::string::npos) << log;
  const std::string text = log.substr(line, log.find('\n', line) - line);
  // The box (centre 400, -200) is named first, with the rule's first failing check (height 140 > 100 * 1.15).
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(not a target: \((39\d|40\d), -(19\d|20\d)\) mm [0-9x]+ mm \d+ points too high;)")))
      << text;
}

TEST_F(ObjectFinderNodeTest, TargetJsonFollowsTheFinalPoses) {
  options_.model_channel = "";  // the landmarks' box, carried into the final frame
  Start();
  PublishInfo();
  for (int k = 0; k < 6; ++k) PublishKeyframe(k);
  Drain();
  ASSERT_EQ(node_->finder().result().state, TargetState::kConfirmed);
  // More views after the confirmation, then their final poses: the online ones turned by 5 deg and shifted.
  Eigen::Isometry3d final_from_online = Eigen::Isometry3d::Identity();
  final_from_online.linear() = Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  final_from_online.translation() = Eigen::Vector3d(100, -50, 0);
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> online;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Isometry3d pose = room_.OnCircle(kBoxCentre.head<2>(), 1200, 90 + i * 10.0, kBoxCentre);
    online.emplace_back(60 + i, pose);
    PublishPose(60 + i, pose);
  }
  Drain();
  EndOfStream();
  Drain();
  EXPECT_TRUE(finished_.empty());
  for (const auto& [seq, pose] : online) PublishPose(seq, final_from_online * pose, PoseStatus::kTracking, "CAMERA_POSE_FINAL");
  PoseSolverFinished();
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  cv::FileStorage json((out_dir_ / "target.json").string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
  ASSERT_TRUE(json.isOpened());
  std::vector<double> centre, normal;
  json["centre_mm"] >> centre;
  json["floor"]["normal"] >> normal;
  ASSERT_EQ(centre.size(), 3u);
  const Eigen::Vector3d expected = final_from_online * kBoxCentre;
  EXPECT_LT((Eigen::Vector3d(centre[0], centre[1], centre[2]) - expected).norm(), 10.0)
      << centre[0] << " " << centre[1] << " " << centre[2];
  EXPECT_NEAR(static_cast<double>(json["yaw_rad"]), 0.3 + 5 * M_PI / 180, 0.05);
  ASSERT_EQ(normal.size(), 3u);
  EXPECT_GT(normal[2], 0.999);
  EXPECT_NEAR(static_cast<double>(json["floor"]["offset_mm"]), 0.0, 2.0);
}

// The dense modeler's final model, 2 mm voxels on the five visible faces of the target box moved by `shift`, as
// model_voxels.ply in out_dir; the MODEL message that announces it.
model_t WriteBoxModel(const std::filesystem::path& dir, const Eigen::Vector3d& shift) {
  std::vector<Eigen::Vector3d> voxels;
  const Eigen::Vector3d half(75, 60, 70);
  const Eigen::Rotation2Dd yaw(0.3);
  for (double x = -half.x(); x <= half.x(); x += 2)
    for (double y = -half.y(); y <= half.y(); y += 2)
      for (double z = -half.z(); z <= half.z(); z += 2)
        if (std::abs(x) > half.x() - 1 || std::abs(y) > half.y() - 1 || z > half.z() - 1) {
          const Eigen::Vector2d xy = yaw * Eigen::Vector2d(x, y);
          voxels.push_back(kBoxCentre + shift + Eigen::Vector3d(xy.x(), xy.y(), z));
        }
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "model_voxels.ply").string();
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\nelement vertex " << voxels.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  for (const auto& v : voxels) out << v.x() << " " << v.y() << " " << v.z() << "\n";
  model_t m{};
  m.utime = 0;
  m.voxels_ply_path = path;
  m.voxel_size_mm = 2;
  m.num_voxels = static_cast<int32_t>(voxels.size());
  return m;
}

// With a target, the end waits for the dense model after the final poses and measures target.json's box on it (here
// 25 mm from the landmarks' box); the model may also come first. A model file this host cannot read, or a model of
// something else: the landmarks' box stays, and target.json says why.
TEST_F(ObjectFinderNodeTest, TargetJsonBoxIsMeasuredOnTheDenseModel) {
  const Eigen::Vector3d shift(20, -15, 0);
  for (const char* order : {"model last", "model first", "unreadable", "elsewhere"}) {
    SCOPED_TRACE(order);
    const std::string mode = order;
    finished_.clear();
    std::filesystem::remove_all(out_dir_);
    MakeBus();
    Start();
    PublishInfo();
    for (int k = 0; k < 6; ++k) PublishKeyframe(k);
    Drain();
    ASSERT_EQ(node_->finder().result().state, TargetState::kConfirmed);
    model_t model = WriteBoxModel(out_dir_, mode == "elsewhere" ? Eigen::Vector3d(900, 0, 0) : shift);
    if (mode == "unreadable") model.voxels_ply_path = (out_dir_ / "elsewhere" / "model_voxels.ply").string();
    EndOfStream();
    if (mode == "model first") ASSERT_TRUE(bus_->PublishMessage("MODEL", model));
    PoseSolverFinished();
    Drain();
    if (mode != "model first") {
      EXPECT_TRUE(finished_.empty());
      ASSERT_TRUE(bus_->PublishMessage("MODEL", model));
      Drain();
    }
    ASSERT_EQ(finished_.size(), 1u);
    EXPECT_TRUE(node_->Finished());
    cv::FileStorage json((out_dir_ / "target.json").string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
    ASSERT_TRUE(json.isOpened());
    std::vector<double> centre, size, landmarks_centre;
    json["centre_mm"] >> centre;
    json["size_mm"] >> size;
    ASSERT_EQ(centre.size(), 3u);
    ASSERT_EQ(size.size(), 3u);
    const Eigen::Vector3d c(centre[0], centre[1], centre[2]);
    if (mode == "model last" || mode == "model first") {
      EXPECT_EQ(static_cast<std::string>(json["box_source"]), "model");
      EXPECT_LT((c - (kBoxCentre + shift)).norm(), 2.0) << c.transpose();
      EXPECT_NEAR(size[0], 150, 2.0);
      EXPECT_NEAR(size[1], 120, 2.0);
      EXPECT_NEAR(size[2], 140, 2.0);
      EXPECT_NEAR(static_cast<double>(json["yaw_rad"]), 0.3, 0.02);
      json["landmarks_centre_mm"] >> landmarks_centre;
      ASSERT_EQ(landmarks_centre.size(), 3u);
      EXPECT_LT((Eigen::Vector3d(landmarks_centre[0], landmarks_centre[1], landmarks_centre[2]) - kBoxCentre).norm(),
                10.0);
      EXPECT_GT(static_cast<int>(json["model_voxels"]), 10000);
    } else {
      EXPECT_EQ(static_cast<std::string>(json["box_source"]), "landmarks");
      EXPECT_LT((c - kBoxCentre).norm(), 10.0) << c.transpose();
      const std::string error = json["model_box_error"];
      EXPECT_NE(error.find(mode == "unreadable" ? "cannot read the model's voxels on this host" : "outside"),
                std::string::npos) << error;
    }
  }
}

TEST_F(ObjectFinderNodeTest, MalformedMessagesAreRejectedBeforeDecoding) {
  Start();
  PublishInfo();
  const FinderInput first = Keyframe(0);
  PublishPose(first.seq, first.world_from_camera);
  std::vector<uint8_t> bytes = Encode(LandmarksMessage(first));
  const size_t count_offset = 8 + 8 + 8 + 4 + 6;  // hash, utime, seq, frame "world" (length incl. NUL)
  std::vector<uint8_t> huge = bytes;
  PutInt32(&huge, count_offset, 100000000);  // would allocate ~3 GB in the generated decoder
  std::vector<uint8_t> negative = bytes;
  PutInt32(&negative, count_offset, -5);
  std::vector<uint8_t> truncated(bytes.begin(), bytes.end() - 31);
  const uint8_t junk[5] = {1, 2, 3, 4, 5};
  std::string why;
  EXPECT_FALSE(CheckLandmarksMessageSize(huge.data(), static_cast<int>(huge.size()), &why));
  EXPECT_NE(why.find("declared 100000000 landmarks"), std::string::npos) << why;
  EXPECT_FALSE(CheckLandmarksMessageSize(negative.data(), static_cast<int>(negative.size()), &why));
  EXPECT_FALSE(CheckLandmarksMessageSize(truncated.data(), static_cast<int>(truncated.size()), &why));
  EXPECT_TRUE(CheckLandmarksMessageSize(bytes.data(), static_cast<int>(bytes.size()), &why));
  ASSERT_TRUE(bus_->Publish("LANDMARKS", huge.data(), static_cast<int>(huge.size())));
  ASSERT_TRUE(bus_->Publish("LANDMARKS", negative.data(), static_cast<int>(negative.size())));
  ASSERT_TRUE(bus_->Publish("LANDMARKS", truncated.data(), static_cast<int>(truncated.size())));
  ASSERT_TRUE(bus_->Publish("LANDMARKS", junk, 5));
  ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", control_t{}));  // another type
  camera_info_t info;
  info.width = 640;
  info.height = 480;
  info.fx = info.fy = 800;
  info.cx = 320;
  info.cy = 240;
  info.distortion_model = "none";
  info.num_distortion = 0;
  std::vector<uint8_t> info_bytes(static_cast<size_t>(info.getEncodedSize()));
  info.encode(info_bytes.data(), 0, static_cast<int>(info_bytes.size()));
  PutInt32(&info_bytes, info_bytes.size() - 4, 50000000);  // num_distortion is the last field
  EXPECT_FALSE(CheckCameraInfoMessageSize(info_bytes.data(), static_cast<int>(info_bytes.size()), &why));
  ASSERT_TRUE(bus_->Publish("CAMERA_INFO", info_bytes.data(), static_cast<int>(info_bytes.size())));
  ASSERT_TRUE(bus_->Publish("CAMERA_POSE", junk, 5));
  ASSERT_TRUE(bus_->Publish("ROBOT_ODOMETRY", junk, 5));
  ASSERT_TRUE(bus_->Publish("OBJSCAN_CONTROL", junk, 5));
  landmarks_t other_frame = LandmarksMessage(first);
  other_frame.frame = "camera";
  ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", other_frame));
  Drain();
  EXPECT_TRUE(targets_.empty());
  EXPECT_EQ(node_->status().rejected("landmarks: malformed"), 5);
  EXPECT_EQ(node_->status().rejected("camera_info: malformed"), 1);
  EXPECT_EQ(node_->status().rejected("pose: malformed"), 1);
  EXPECT_EQ(node_->status().rejected("odometry: malformed"), 1);
  EXPECT_EQ(node_->status().rejected("control: malformed"), 1);
  EXPECT_EQ(node_->status().rejected("landmarks: not in world frame"), 1);

  // the node goes on: the good message is used, an older keyframe is rejected, the same keyframe again is used
  ASSERT_TRUE(bus_->Publish("LANDMARKS", bytes.data(), static_cast<int>(bytes.size())));
  PublishKeyframe(1);
  ASSERT_TRUE(bus_->Publish("LANDMARKS", bytes.data(), static_cast<int>(bytes.size())));
  Drain();
  EXPECT_EQ(targets_.size(), 2u);
  EXPECT_EQ(node_->status().rejected("landmarks: out of order"), 1);
  PublishKeyframe(2);
  ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", LandmarksMessage(Keyframe(2))));  // seq 23 again (a final map)
  Drain();
  ASSERT_EQ(targets_.size(), 4u);
  EXPECT_EQ(targets_[3].seq, 23);
  EXPECT_EQ(node_->status().rejected_total(), 11);
}

TEST_F(ObjectFinderNodeTest, NoPoseOrCameraYetIsRejectedAndNoTargetBeforeTheFirstMap) {
  Start();
  node_->Tick(WallTimeMicros() + 5000000);
  Drain();
  EXPECT_TRUE(targets_.empty());  // nothing before the first map
  const FinderInput first = Keyframe(0);
  ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", LandmarksMessage(first)));
  Drain();
  EXPECT_EQ(node_->status().rejected("landmarks: no camera_info"), 1);
  PublishInfo();
  ASSERT_TRUE(bus_->PublishMessage("LANDMARKS", LandmarksMessage(first)));
  Drain();
  EXPECT_EQ(node_->status().rejected("landmarks: no camera pose"), 1);
  EndOfStream();
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].last_seq, -1);
  cv::FileStorage json((out_dir_ / "target.json").string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
  ASSERT_TRUE(json.isOpened());
  EXPECT_EQ(static_cast<std::string>(json["state"]), "searching");
  EXPECT_EQ(static_cast<int>(json["confirmed_seq"]), -1);
}

TEST(ObjectFinderNodeOptionsTest, ParsesAndValidates) {
  ObjectFinderNodeOptions o;
  OptionParser parser("object_finder", "test");
  AddObjectFinderNodeOptions(parser, &o);
  std::string error;
  ASSERT_TRUE(parser.ParseArgs({"--target-min-size", "60", "--target-max-size=250"}, &error)) << error;
  EXPECT_EQ(o.finder.target_min_size_mm, 60);
  EXPECT_EQ(o.finder.target_max_size_mm, 250);
  EXPECT_TRUE(ValidateObjectFinderNodeOptions(o, &error));
  o.target_period_s = 0;
  o.finder.min_views = 0;
  EXPECT_FALSE(ValidateObjectFinderNodeOptions(o, &error));
  EXPECT_NE(error.find("target_period_s"), std::string::npos);
  EXPECT_NE(error.find("min_views"), std::string::npos);
}

}  // namespace
}  // namespace objscan
