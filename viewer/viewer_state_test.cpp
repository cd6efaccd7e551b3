#include "viewer/viewer_state.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/adapters.h"
#include "common/bus.h"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"
#include "viewer/log_player.h"
#include "viewer/view_camera.h"

namespace objscan {
namespace {

template <class Msg>
std::vector<uint8_t> Encode(const Msg& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

pose_t MakePose(int64_t seq, double x, double y, double z) {
  pose_t p{};
  p.utime = seq * 33333;
  p.seq = seq;
  p.parent_frame = "world";
  p.child_frame = "camera";
  p.position_mm[0] = x;
  p.position_mm[1] = y;
  p.position_mm[2] = z;
  p.orientation[0] = 1.0;
  p.status = pose_t::STATUS_TRACKING;
  return p;
}

class DispatcherTest : public ::testing::Test {
 protected:
  template <class Msg>
  bool Send(const std::string& channel, const Msg& msg, int64_t recv_utime = 0) {
    const auto bytes = Encode(msg);
    return dispatcher_.Dispatch(channel, bytes.data(), static_cast<int>(bytes.size()), recv_utime);
  }
  ViewerState state_;
  MessageDispatcher dispatcher_{&state_, ViewerChannels{}};
};

TEST_F(DispatcherTest, TrajectoriesAndLivePositionError) {
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(Send("GROUND_TRUTH_POSE", MakePose(i, 100.0 * i, 0, 300)));
  EXPECT_FALSE(state_.latest_position_error_mm().has_value());
  ASSERT_TRUE(Send("CAMERA_POSE", MakePose(0, 0, 3, 304)));    // error 5
  ASSERT_TRUE(Send("CAMERA_POSE", MakePose(1, 100, 0, 310)));  // error 10
  EXPECT_EQ(state_.estimated_trajectory().size(), 2u);
  EXPECT_EQ(state_.ground_truth_trajectory().size(), 5u);
  ASSERT_TRUE(state_.latest_position_error_mm().has_value());
  EXPECT_NEAR(*state_.latest_position_error_mm(), 10.0, 1e-9);
  EXPECT_EQ(state_.latest_error_seq(), 1);
  EXPECT_NEAR(state_.position_error_rms_mm(), std::sqrt((25.0 + 100.0) / 2), 1e-9);
  // A re-estimate of frame 1 replaces its error instead of adding one.
  ASSERT_TRUE(Send("CAMERA_POSE", MakePose(1, 100, 0, 300)));
  EXPECT_NEAR(*state_.latest_position_error_mm(), 0.0, 1e-9);
  EXPECT_EQ(state_.position_error_count(), 2);
  EXPECT_NEAR(state_.position_error_rms_mm(), std::sqrt(25.0 / 2), 1e-9);
}

// The estimate lives in its own world frame (here: the truth moved by 800 mm); from 3 frames on the error is
// measured after the similarity alignment, so a correct estimate shows ~0 mm, not the frames' offset.
TEST_F(DispatcherTest, PositionErrorIsMeasuredAfterAligningTheFrames) {
  const double xs[] = {0, 100, 180, 230};
  const double ys[] = {0, 20, 70, 140};
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(Send("GROUND_TRUTH_POSE", MakePose(i, xs[i], ys[i], 300)));
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(Send("CAMERA_POSE", MakePose(i, xs[i], ys[i] + 800, 300)));
  ASSERT_TRUE(state_.truth_aligned());
  ASSERT_TRUE(state_.latest_position_error_mm().has_value());
  EXPECT_NEAR(*state_.latest_position_error_mm(), 0.0, 1e-6);
  EXPECT_NEAR(state_.position_error_rms_mm(), 0.0, 1e-6);
  EXPECT_NEAR((state_.estimate_from_truth() * Eigen::Vector3d(0, 0, 300) - Eigen::Vector3d(0, 800, 300)).norm(), 0.0,
              1e-6);
  // A wrong estimate of the newest frame shows up (reduced by the refit, never hidden).
  ASSERT_TRUE(Send("CAMERA_POSE", MakePose(3, 230, 140 + 800 + 40, 300)));
  EXPECT_GT(*state_.latest_position_error_mm(), 10.0);
  EXPECT_LT(*state_.latest_position_error_mm(), 40.0);
}

TEST_F(DispatcherTest, MalformedAndUnknownAreCountedNeverApplied) {
  ASSERT_TRUE(Send("CAMERA_POSE", MakePose(0, 1, 2, 3)));
  const char junk[] = "definitely not a pose";
  EXPECT_FALSE(dispatcher_.Dispatch("CAMERA_POSE", junk, sizeof(junk), 0));
  EXPECT_FALSE(dispatcher_.Dispatch("CAMERA_POSE", nullptr, 0, 0));
  // Right type, truncated.
  auto bytes = Encode(MakePose(1, 0, 0, 0));
  EXPECT_FALSE(dispatcher_.Dispatch("CAMERA_POSE", bytes.data(), static_cast<int>(bytes.size()) - 5, 0));
  // Wrong type on the channel (fingerprint mismatch).
  odometry_t odo{};
  EXPECT_FALSE(Send("CAMERA_POSE", odo));
  // Decodes, but non-finite / not a unit quaternion.
  pose_t nan_pose = MakePose(2, NAN, 0, 0);
  EXPECT_FALSE(Send("CAMERA_POSE", nan_pose));
  pose_t bad_quat = MakePose(3, 0, 0, 0);
  bad_quat.orientation[0] = 2.0;
  EXPECT_FALSE(Send("CAMERA_POSE", bad_quat));
  EXPECT_EQ(state_.estimated_trajectory().size(), 1u);  // only the good one
  EXPECT_EQ(state_.channels().at("CAMERA_POSE").malformed, 6);
  EXPECT_EQ(state_.channels().at("CAMERA_POSE").messages, 7);
  EXPECT_EQ(state_.total_malformed(), 6);
  EXPECT_EQ(state_.malformed_reasons().at("pose: malformed"), 4);

  // Unknown channel: counted and listed, nothing decoded.
  EXPECT_FALSE(dispatcher_.Dispatch("SOMETHING_ELSE", junk, sizeof(junk), 5));
  EXPECT_EQ(state_.total_unknown(), 1);
  EXPECT_EQ(state_.channels().at("SOMETHING_ELSE").type, "unknown");
  EXPECT_EQ(state_.total_malformed(), 6);
}

TEST_F(DispatcherTest, CorruptArrayCountDoesNotCrash) {
  landmarks_t lm{};
  lm.frame = "world";
  lm.num_landmarks = 1;
  lm.id = {7};
  lm.position_mm = {{1, 2, 3}};
  lm.num_observations = {2};
  lm.reprojection_error_px = {0.5f};
  lm.rgb = {{1, 2, 3}};
  auto bytes = Encode(lm);
  // num_landmarks sits right after utime, seq and the frame string: 8 (hash) + 8 + 8 + 4 + 6 ("world\0").
  const size_t count_offset = 8 + 8 + 8 + 4 + 6;
  for (uint8_t value : {0x80, 0x7f, 0xff}) {  // negative and huge counts
    auto corrupt = bytes;
    corrupt[count_offset] = value;
    EXPECT_FALSE(dispatcher_.Dispatch("LANDMARKS", corrupt.data(), static_cast<int>(corrupt.size()), 0));
  }
  EXPECT_FALSE(state_.landmarks().has_value());
  EXPECT_TRUE(dispatcher_.Dispatch("LANDMARKS", bytes.data(), static_cast<int>(bytes.size()), 0));
  ASSERT_TRUE(state_.landmarks().has_value());
  EXPECT_EQ(state_.landmarks()->num_landmarks, 1);
  EXPECT_EQ(state_.LandmarkFirstSeq(7), 0);
}

TEST_F(DispatcherTest, SequenceGapsRatesAndStatus) {
  for (int64_t seq : {0, 1, 2, 5, 6, 6, 4, 10}) {
    odometry_t odo{};
    odo.seq = seq;
    odo.utime = seq * 1000;
    ASSERT_TRUE(Send("ROBOT_ODOMETRY", odo, seq * 100000));
  }
  EXPECT_EQ(state_.channels().at("ROBOT_ODOMETRY").dropped, 2 + 3);  // 3,4 then 7,8,9
  EXPECT_EQ(state_.channels().at("ROBOT_ODOMETRY").messages, 8);
  // Messages within the 2 s window ending at 1.0 s: recv 0..1.0 s -> 8 messages / 2 s.
  EXPECT_NEAR(state_.ChannelRate("ROBOT_ODOMETRY", 1000000), 4.0, 1e-9);
  EXPECT_NEAR(state_.ChannelRate("ROBOT_ODOMETRY", 3500000), 0.0, 1e-9);

  for (const char* name : {"tracker", "pose_solver"}) {
    for (int64_t seq : {0, 2}) {
      process_status_t s{};
      s.name = name;
      s.seq = seq;
      s.state = process_status_t::STATE_RUNNING;
      ASSERT_TRUE(Send("PROCESS_STATUS", s, 7));
    }
  }
  EXPECT_EQ(state_.processes().size(), 2u);
  EXPECT_EQ(state_.processes().at("tracker").status.seq, 2);
  EXPECT_EQ(state_.channels().at("PROCESS_STATUS").dropped, 2);  // one missing per process
  process_status_t nameless{};
  EXPECT_FALSE(Send("PROCESS_STATUS", nameless));
}

TEST_F(DispatcherTest, ImageTracksVoxelsTarget) {
  ImageFrame frame;
  frame.seq = 3;
  frame.camera_name = "cam";
  frame.image = cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3));
  ASSERT_TRUE(Send("CAMERA_IMAGE", ImageToMessage(frame, image_t::ENCODING_BGR8)));
  image_t bad = ImageToMessage(frame, image_t::ENCODING_BGR8);
  bad.encoding = 42;
  EXPECT_FALSE(Send("CAMERA_IMAGE", bad));
  EXPECT_EQ(state_.malformed_reasons().at("image: unknown encoding"), 1);
  ASSERT_TRUE(state_.image().has_value());
  EXPECT_EQ(state_.image()->image.cols, 6);
  EXPECT_EQ(state_.image_version(), 1);

  TrackFrame tracks;
  tracks.seq = 3;
  tracks.width = 6;
  tracks.height = 4;
  tracks.features = {{1, 1.0f, 2.0f, 0}, {2, 3.0f, 1.0f, 5}};
  ASSERT_TRUE(Send("FEATURE_TRACKS", TracksToMessage(tracks)));
  tracks.seq = 4;
  ASSERT_TRUE(Send("FEATURE_TRACKS", TracksToMessage(tracks)));
  ASSERT_NE(state_.TracksFor(3), nullptr);
  EXPECT_EQ(state_.TracksFor(3)->seq, 3);
  EXPECT_EQ(state_.TracksFor(99)->seq, 4);  // newest as fallback

  voxel_map_t map{};
  map.frame = "world";
  map.voxel_size_mm = 0;  // invalid
  EXPECT_FALSE(Send("VOXEL_MAP", map));
  map.voxel_size_mm = 10;
  map.num_voxels = 2;
  map.ijk = {{0, 0, 0}, {1, 0, 0}};
  map.votes = {3, 4};
  map.rgb = {{255, 0, 0}, {0, 255, 0}};
  ASSERT_TRUE(Send("VOXEL_MAP", map));
  EXPECT_EQ(state_.voxel_map()->num_voxels, 2);
  EXPECT_EQ(state_.voxel_map_version(), 1);

  target_t target{};
  target.frame = "world";
  target.size_mm[0] = -1;
  EXPECT_FALSE(Send("TARGET", target));
  target.size_mm[0] = 100;
  target.state = target_t::STATE_CONFIRMED;
  ASSERT_TRUE(Send("TARGET", target));
  EXPECT_EQ(state_.target()->state, +target_t::STATE_CONFIRMED);
}

TEST_F(DispatcherTest, FastForwardDecodesOnlyTheLastImage) {
  ImageFrame frame;
  frame.image = cv::Mat(4, 6, CV_8UC1, cv::Scalar(7));
  dispatcher_.BeginFastForward();
  for (int i = 0; i < 5; ++i) {
    frame.seq = i;
    ASSERT_TRUE(Send("CAMERA_IMAGE", ImageToMessage(frame, image_t::ENCODING_GRAY8)));
  }
  EXPECT_FALSE(state_.image().has_value());  // nothing decoded yet
  EXPECT_EQ(state_.channels().at("CAMERA_IMAGE").messages, 5);
  dispatcher_.EndFastForward();
  ASSERT_TRUE(state_.image().has_value());
  EXPECT_EQ(state_.image()->seq, 4);
  EXPECT_EQ(state_.image_version(), 1);
  // A bad last image is still counted as malformed when it is finally decoded.
  dispatcher_.BeginFastForward();
  image_t bad = ImageToMessage(frame, image_t::ENCODING_GRAY8);
  bad.encoding = 99;
  ASSERT_TRUE(Send("CAMERA_IMAGE", bad));
  dispatcher_.EndFastForward();
  EXPECT_EQ(state_.channels().at("CAMERA_IMAGE").malformed, 1);
  EXPECT_EQ(state_.image()->seq, 4);
}

TEST_F(DispatcherTest, ConfigurableChannelNames) {
  ViewerChannels channels;
  channels.camera_pose = "SLAM_POSE";
  channels.ground_truth = "";
  ViewerState state;
  MessageDispatcher dispatcher(&state, channels);
  auto bytes = Encode(MakePose(0, 1, 2, 3));
  EXPECT_TRUE(dispatcher.Dispatch("SLAM_POSE", bytes.data(), static_cast<int>(bytes.size()), 0));
  EXPECT_FALSE(dispatcher.Dispatch("CAMERA_POSE", bytes.data(), static_cast<int>(bytes.size()), 0));
  EXPECT_FALSE(dispatcher.Dispatch("GROUND_TRUTH_POSE", bytes.data(), static_cast<int>(bytes.size()), 0));
  EXPECT_EQ(state.estimated_trajectory().size(), 1u);
  EXPECT_EQ(state.total_unknown(), 2);
}

// Random byte corruption of valid messages of every decoded type: never crashes or throws, state stays usable.
TEST(DispatcherFuzzTest, CorruptedMessagesNeverCrash) {
  ViewerState state;
  MessageDispatcher dispatcher(&state, ViewerChannels{});
  std::vector<std::pair<std::string, std::vector<uint8_t>>> seeds;
  seeds.emplace_back("CAMERA_POSE", Encode(MakePose(1, 1, 2, 3)));
  landmarks_t lm{};
  lm.frame = "world";
  lm.num_landmarks = 2;
  lm.id = {1, 2};
  lm.position_mm = {{1, 2, 3}, {4, 5, 6}};
  lm.num_observations = {2, 3};
  lm.reprojection_error_px = {0.1f, 0.2f};
  lm.rgb = {{1, 2, 3}, {4, 5, 6}};
  seeds.emplace_back("LANDMARKS", Encode(lm));
  voxel_map_t map{};
  map.frame = "world";
  map.voxel_size_mm = 10;
  map.num_voxels = 2;
  map.ijk = {{0, 0, 0}, {1, 0, 0}};
  map.votes = {3, 4};
  map.rgb = {{255, 0, 0}, {0, 255, 0}};
  seeds.emplace_back("VOXEL_MAP", Encode(map));
  ImageFrame frame;
  frame.image = cv::Mat(4, 6, CV_8UC1, cv::Scalar(7));
  seeds.emplace_back("CAMERA_IMAGE", Encode(ImageToMessage(frame, image_t::ENCODING_GRAY8)));
  TrackFrame tracks;
  tracks.width = 6;
  tracks.height = 4;
  tracks.features = {{1, 1.0f, 2.0f, 0}};
  seeds.emplace_back("FEATURE_TRACKS", Encode(TracksToMessage(tracks)));
  process_status_t status{};
  status.name = "x";
  status.num_rejection_reasons = 1;
  status.rejection_reason = {"r"};
  status.rejection_count = {1};
  seeds.emplace_back("PROCESS_STATUS", Encode(status));
  target_t target{};
  target.frame = "world";
  seeds.emplace_back("TARGET", Encode(target));
  odometry_t odo{};
  seeds.emplace_back("ROBOT_ODOMETRY", Encode(odo));

  uint64_t rng = 12345;
  auto next = [&rng] {
    rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<uint32_t>(rng >> 33);
  };
  int64_t accepted = 0;
  for (const auto& [channel, bytes] : seeds) {
    for (int trial = 0; trial < 2000; ++trial) {
      std::vector<uint8_t> mutated = bytes;
      const int flips = 1 + static_cast<int>(next() % 4);
      for (int f = 0; f < flips; ++f) mutated[8 + next() % (mutated.size() - 8)] = static_cast<uint8_t>(next());
      if (next() % 4 == 0) mutated.resize(next() % mutated.size());  // truncation
      accepted += dispatcher.Dispatch(channel, mutated.data(), static_cast<int>(mutated.size()), trial);
    }
  }
  EXPECT_EQ(state.total_messages(), static_cast<int64_t>(seeds.size()) * 2000);
  EXPECT_EQ(state.total_malformed() + accepted, state.total_messages());
  EXPECT_GT(state.total_malformed(), 0);
}

TEST(ViewerStateMemqTest, FedFromBusIncludingGarbage) {
  auto bus = MakeLcmBus("memq://");
  ViewerState state;
  MessageDispatcher dispatcher(&state, ViewerChannels{});
  bus->Subscribe(".*",
                 [&](const RawMessage& raw) { dispatcher.Dispatch(raw.channel, raw.data, raw.size, raw.recv_utime); });
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(bus->PublishMessage("CAMERA_POSE", MakePose(i, i, 0, 0)));
  const char junk[] = {1, 2, 3};
  ASSERT_TRUE(bus->Publish("VOXEL_MAP", junk, sizeof(junk)));
  ASSERT_TRUE(bus->Publish("NOISE", junk, sizeof(junk)));
  while (bus->Handle(0) > 0) {
  }
  EXPECT_EQ(state.estimated_trajectory().size(), 10u);
  EXPECT_EQ(state.total_messages(), 12);
  EXPECT_EQ(state.total_malformed(), 1);
  EXPECT_EQ(state.total_unknown(), 1);
  EXPECT_GT(state.ChannelRate("CAMERA_POSE", state.channels().at("CAMERA_POSE").last_recv_utime), 0.0);
}

TEST(LogPlayerTest, PlaysStepsAndSeeks) {
  const std::string path = ::testing::TempDir() + "objscan_viewer_state_test_" + std::to_string(getpid()) + ".lcmlog";
  {
    auto writer = MakeLcmBus("datalog://" + path);
    for (int i = 0; i < 30; ++i) ASSERT_TRUE(writer->PublishMessage("CAMERA_POSE", MakePose(i, i, 0, 0)));
  }
  LogPlayer player;
  std::string error;
  ASSERT_TRUE(player.Open(path, &error)) << error;
  EXPECT_EQ(player.num_events(), 30);
  EXPECT_EQ(player.first_utime(), 0);
  EXPECT_EQ(player.last_utime(), 29 * 33333);
  ViewerState state;
  MessageDispatcher dispatcher(&state, ViewerChannels{});
  auto handler = [&](const std::string& channel, const void* data, int size, int64_t utime) {
    dispatcher.Dispatch(channel, data, size, utime);
  };
  // 0.1 s at speed 2 = 0.2 s of log: frames 0..6 (6 * 33333 <= 200000).
  player.set_speed(2.0);
  EXPECT_EQ(player.Advance(0.1, handler), 7);
  EXPECT_TRUE(player.Step(handler));
  EXPECT_FALSE(player.playing());
  EXPECT_EQ(state.estimated_trajectory().size(), 8u);
  player.Seek(
      3 * 33333, [&] { state.Reset(); }, handler);  // backwards: reset + replay
  EXPECT_EQ(state.estimated_trajectory().size(), 4u);
  player.Seek(
      20 * 33333, [&] { state.Reset(); }, handler);  // forwards
  EXPECT_EQ(state.estimated_trajectory().size(), 21u);
  EXPECT_EQ(player.DeliverUntil(INT64_MAX, handler), 9);
  EXPECT_TRUE(player.at_end());
  EXPECT_FALSE(player.Step(handler));
  EXPECT_FALSE(LogPlayer().Open("/nonexistent/log", &error));
  std::remove(path.c_str());
}

TEST(ViewCameraTest, ProjectionMatchesGeometry) {
  OrbitView view;
  view.target_mm = Eigen::Vector3d(100, 200, 0);
  view.yaw_rad = 0.3;
  view.pitch_rad = 0.5;
  view.distance_mm = 2000;
  Viewport viewport{0, 0, 800, 600};
  Eigen::Vector2d pixel;
  ASSERT_TRUE(ProjectToWindow(view, viewport, view.target_mm, &pixel));
  EXPECT_NEAR(pixel.x(), 399.5, 1e-3);  // the target is at the viewport centre
  EXPECT_NEAR(pixel.y(), 299.5, 1e-3);
  // A point above the target appears above the centre (smaller row); world z is up on screen.
  ASSERT_TRUE(ProjectToWindow(view, viewport, view.target_mm + Eigen::Vector3d(0, 0, 100), &pixel));
  EXPECT_LT(pixel.y(), 299.5);
  EXPECT_NEAR(pixel.x(), 399.5, 1e-3);
  // Behind the eye: not projected.
  EXPECT_FALSE(ProjectToWindow(view, viewport, EyePosition(view) + (EyePosition(view) - view.target_mm), &pixel));
  // Top preset still gives a proper basis (no degeneracy looking straight down).
  ASSERT_TRUE(ApplyViewPreset("top", &view));
  ASSERT_TRUE(ProjectToWindow(view, viewport, view.target_mm + Eigen::Vector3d(100, 0, 0), &pixel));
  EXPECT_GT(pixel.x(), 399.5);  // +x to the right when looking down with yaw -90 deg
  EXPECT_FALSE(ApplyViewPreset("nonsense", &view));
}

TEST(ViewCameraTest, ViewSpecPresetOrAnglesThenDistanceTargetFov) {
  OrbitView view, iso;
  std::string why;
  ASSERT_TRUE(ApplyViewPreset("iso", &iso));
  ASSERT_TRUE(ParseViewSpec("iso", &view, &why)) << why;  // a preset: its angles, the defaults
  EXPECT_DOUBLE_EQ(view.yaw_rad, iso.yaw_rad);
  EXPECT_DOUBLE_EQ(view.pitch_rad, iso.pitch_rad);
  EXPECT_DOUBLE_EQ(view.distance_mm, 3000);
  EXPECT_EQ(view.target_mm, Eigen::Vector3d::Zero());
  EXPECT_DOUBLE_EQ(view.fovy_rad, 50 * M_PI / 180);
  ASSERT_TRUE(ParseViewSpec("top,800", &view, &why)) << why;  // a preset and a distance
  EXPECT_DOUBLE_EQ(view.pitch_rad, 1.55);
  EXPECT_DOUBLE_EQ(view.distance_mm, 800);
  ASSERT_TRUE(ParseViewSpec("-90,70", &view, &why)) << why;
  EXPECT_DOUBLE_EQ(view.yaw_rad, -M_PI / 2);
  EXPECT_DOUBLE_EQ(view.pitch_rad, 70 * M_PI / 180);
  EXPECT_DOUBLE_EQ(view.distance_mm, 3000);
  ASSERT_TRUE(ParseViewSpec("180,25,600.5", &view, &why)) << why;
  EXPECT_DOUBLE_EQ(view.distance_mm, 600.5);
  EXPECT_EQ(view.target_mm, Eigen::Vector3d::Zero());
  ASSERT_TRUE(ParseViewSpec("0,85,450,10.5,-20,80", &view, &why)) << why;
  EXPECT_EQ(view.target_mm, Eigen::Vector3d(10.5, -20, 80));
  EXPECT_DOUBLE_EQ(view.fovy_rad, 50 * M_PI / 180);
  ASSERT_TRUE(ParseViewSpec("0,95,450,0,0,0,30", &view, &why)) << why;
  EXPECT_DOUBLE_EQ(view.pitch_rad, 1.55);  // clamped as the mouse does
  EXPECT_DOUBLE_EQ(view.fovy_rad, 30 * M_PI / 180);

  // Bad specs: refused with a reason naming the spec, and the view is left alone.
  const OrbitView before = view;
  for (const char* bad : {"", "nonsense", "iso,", "10", "10,x", "x,10", "10,20,", "10,20,0", "10,20,-5", "10,20,nan",
                          "10,20,inf", "10,20,100,1", "10,20,100,1,2", "10,20,100,1,2,3,0", "10,20,100,1,2,3,180",
                          "10,20,100,1,2,3,50,1", "iso,800,1", "top,0", "1e999,20", "10,20,100,1,2,3,50mm"}) {
    why.clear();
    EXPECT_FALSE(ParseViewSpec(bad, &view, &why)) << bad;
    EXPECT_EQ(why.rfind(std::string("--view '") + bad + "'", 0), 0u) << why;
    EXPECT_EQ(view.yaw_rad, before.yaw_rad) << bad;
    EXPECT_EQ(view.distance_mm, before.distance_mm) << bad;
  }
}

}  // namespace
}  // namespace objscan
