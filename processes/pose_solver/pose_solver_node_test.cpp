#include "processes/pose_solver/pose_solver_node.h"

#include "common/tum.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/geometry.h"
#include "objscan/control_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/pose_t.hpp"
#include "processes/pose_solver/synthetic_orbit.h"

namespace objscan {
namespace {

struct Sink {
  std::vector<pose_t> poses, final_poses;
  std::vector<landmarks_t> landmarks;
  std::vector<control_t> finished;
  explicit Sink(Bus& bus) {
    bus.SubscribeMessage<pose_t>("CAMERA_POSE", [this](const pose_t& m, const RawMessage&) { poses.push_back(m); });
    bus.SubscribeMessage<pose_t>("CAMERA_POSE_FINAL",
                                 [this](const pose_t& m, const RawMessage&) { final_poses.push_back(m); });
    bus.SubscribeMessage<landmarks_t>("LANDMARKS",
                                      [this](const landmarks_t& m, const RawMessage&) { landmarks.push_back(m); });
    bus.SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      if (m.command == control_t::COMMAND_FINISHED && m.sender == "pose_solver") finished.push_back(m);
    });
  }
};

void Drain(Bus& bus) {
  while (bus.Handle(0) > 0) {
  }
}

control_t TrackerFinished(int64_t last_seq) {
  control_t c;
  c.session_id = 0;
  c.utime = 0;
  c.sender = "tracker";
  c.target = "*";
  c.command = control_t::COMMAND_FINISHED;
  c.last_seq = last_seq;
  c.argument = "";
  return c;
}

TEST(PoseSolverNode, OrbitEndToEndWithOutputs) {
  SyntheticOrbitOptions so;
  so.odometry_scale_error = 0.003;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  auto bus = MakeLcmBus("memq://");
  Sink sink(*bus);
  PoseSolverNodeOptions o;
  o.output_dir = std::filesystem::temp_directory_path() / ("pose_solver_node_test_" + std::to_string(::getpid()));
  struct RemoveOnExit {
    std::string dir;
    ~RemoveOnExit() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } remove_on_exit{o.output_dir};
  PoseSolverNode node(*bus, o);
  // Tracks of the first 3 frames arrive before the camera info (buffered).
  for (int f = 0; f < 200; ++f) {
    if (f == 3) bus->PublishMessage("CAMERA_INFO", CameraToMessage(s.camera, s.frames[0].utime));
    bus->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(s.odometry[f]));
    bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[f]));
    Drain(*bus);
  }
  EXPECT_FALSE(node.final_phase_done());
  bus->PublishMessage("OBJSCAN_CONTROL", TrackerFinished(199));
  Drain(*bus);
  ASSERT_TRUE(node.final_phase_done());
  EXPECT_TRUE(node.Finished());
  // One pose per frame as it arrives, plus a late republication (same seq) of the earlier frames of the start
  // span once the preliminary phase succeeds: the latest pose of every frame is a tracked one.
  std::map<int64_t, pose_t> latest;
  for (const auto& p : sink.poses) latest[p.seq] = p;
  ASSERT_EQ(latest.size(), 200u);
  EXPECT_GT(sink.poses.size(), 200u);
  EXPECT_EQ(sink.poses.front().status, +pose_t::STATUS_INITIALIZING);
  std::vector<Eigen::Isometry3d> online_est, online_truth;
  for (const auto& [seq, p] : latest) {
    EXPECT_EQ(p.status, +pose_t::STATUS_TRACKING) << "seq " << seq;
    online_est.push_back(PoseFromArrays(p.position_mm, p.orientation));
    online_truth.push_back(s.world_from_camera[seq]);
  }
  TrajectoryError online_err;
  ASSERT_TRUE(EvaluateTrajectory(online_est, online_truth, true, &online_err));
  EXPECT_LT(online_err.ate_rmse, 2.0);  // mm (measured 1.16)
  ASSERT_EQ(sink.final_poses.size(), 200u);
  ASSERT_EQ(sink.finished.size(), 1u);
  EXPECT_EQ(sink.finished[0].last_seq, 199);
  EXPECT_GE(sink.landmarks.size(), 20u);
  EXPECT_GT(sink.landmarks.back().num_landmarks, 500);
  EXPECT_EQ(node.status().rejected_total(), 0);
  std::vector<Eigen::Isometry3d> est, truth;
  for (size_t i = 0; i < sink.final_poses.size(); ++i) {
    EXPECT_EQ(sink.final_poses[i].seq, static_cast<int64_t>(i));
    EXPECT_EQ(sink.final_poses[i].status, +pose_t::STATUS_TRACKING);
    EXPECT_EQ(sink.final_poses[i].scale_source, +pose_t::SCALE_CAMERA_HEIGHT);
    est.push_back(PoseFromArrays(sink.final_poses[i].position_mm, sink.final_poses[i].orientation));
    truth.push_back(s.world_from_camera[i]);
  }
  TrajectoryError err;
  ASSERT_TRUE(EvaluateTrajectory(est, truth, true, &err));
  EXPECT_LT(err.ate_rmse, 1.0);
  EXPECT_NEAR(err.scale, 1.0, 0.01);
  // Files.
  for (const char* f : {"trajectory.txt", "trajectory_online.txt", "landmarks.ply", "colmap/cameras.txt",
                        "colmap/images.txt", "colmap/points3D.txt"})
    EXPECT_TRUE(std::filesystem::exists(o.output_dir + "/" + f)) << f;
  std::vector<StampedPose> read;
  std::string error;
  ASSERT_TRUE(ReadTumTrajectory(o.output_dir + "/trajectory.txt", &read, &error)) << error;
  ASSERT_EQ(read.size(), 200u);
  EXPECT_EQ(std::llround(read[30].t * 1e6), s.frames[30].utime);
  EXPECT_LT((read[30].world_from_camera.translation() - est[30].translation()).norm(), 1e-3);
}

TEST(PoseSolverNode, RejectsBadInputWithoutCorruptingState) {
  SyntheticOrbitOptions so;
  so.num_frames = 40;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  auto bus = MakeLcmBus("memq://");
  Sink sink(*bus);
  PoseSolverNodeOptions o;
  o.pending_tracks_capacity = 2;
  o.exit_when_finished = false;
  PoseSolverNode node(*bus, o);
  // 3 frames before camera info: 2 buffered, the third rejected.
  for (int f = 0; f < 3; ++f) bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[f]));
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("tracks: no camera_info (buffer full)"), 1);
  EXPECT_TRUE(sink.poses.empty());
  bus->PublishMessage("CAMERA_INFO", CameraToMessage(s.camera, 0));
  Drain(*bus);
  EXPECT_EQ(sink.poses.size(), 2u);
  // Changed calibration is ignored.
  PinholeCamera other = s.camera;
  other.fx = 700;
  bus->PublishMessage("CAMERA_INFO", CameraToMessage(other, 0));
  // Malformed bytes on every input.
  const uint8_t junk[5] = {1, 2, 3, 4, 5};
  bus->Publish("FEATURE_TRACKS", junk, 5);
  bus->Publish("ROBOT_ODOMETRY", junk, 5);
  bus->Publish("CAMERA_INFO", junk, 5);
  bus->Publish("OBJSCAN_CONTROL", junk, 5);
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("camera_info: changed"), 1);
  EXPECT_EQ(node.status().rejected("tracks: malformed"), 1);
  EXPECT_EQ(node.status().rejected("odometry: malformed"), 1);
  EXPECT_EQ(node.status().rejected("camera_info: malformed"), 1);
  EXPECT_EQ(node.status().rejected("control: malformed"), 1);
  // Bad track frames.
  feature_tracks_t nan_msg = TracksToMessage(s.frames[3]);
  nan_msg.u[0] = NAN;
  feature_tracks_t outside = TracksToMessage(s.frames[3]);
  outside.v[1] = 900;
  feature_tracks_t dup = TracksToMessage(s.frames[3]);
  dup.track_id[1] = dup.track_id[0];
  feature_tracks_t wrong_size = TracksToMessage(s.frames[3]);
  wrong_size.image_width = 320;
  for (const auto& m : {nan_msg, outside, dup, wrong_size}) bus->PublishMessage("FEATURE_TRACKS", m);
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("tracks: non-finite coordinate"), 1);
  EXPECT_EQ(node.status().rejected("tracks: coordinate outside the image"), 1);
  EXPECT_EQ(node.status().rejected("tracks: duplicate id"), 1);
  // (An array length mismatch cannot be encoded by LCM; TracksFromMessage covers it in common/adapters_test.)
  EXPECT_EQ(node.status().rejected("tracks: image size differs from camera_info"), 1);
  EXPECT_EQ(sink.poses.size(), 2u);
  // Odometry with NaN and out of order.
  odometry_t odo_nan = OdometryToMessage(s.odometry[3]);
  odo_nan.x_mm = NAN;
  bus->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(s.odometry[3]));
  bus->PublishMessage("ROBOT_ODOMETRY", odo_nan);
  bus->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(s.odometry[2]));
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("odometry: non-finite value"), 1);
  EXPECT_EQ(node.status().rejected("odometry: out of order"), 1);
  // The rest of the stream, with a repeated and an old frame in between.
  for (int f = 3; f < 40; ++f) {
    if (f > 3) bus->PublishMessage("ROBOT_ODOMETRY", OdometryToMessage(s.odometry[f]));
    bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[f]));
    if (f == 20) {
      bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[20]));
      bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[5]));
    }
    Drain(*bus);
  }
  EXPECT_EQ(node.status().rejected("tracks: out of order or repeated"), 2);
  std::set<int64_t> seqs;
  for (const auto& p : sink.poses) seqs.insert(p.seq);
  ASSERT_EQ(seqs.size(), 39u);  // frames 0, 1, 3..39 (frame 2 was rejected); span frames published twice
  EXPECT_EQ(seqs.count(2), 0u);
  // The map was built and tracking works despite the bad input.
  EXPECT_EQ(sink.poses.back().status, +pose_t::STATUS_TRACKING);
  EXPECT_GT(sink.poses.back().num_inliers, 100);
  // Finished from another sender is ignored; from the tracker it runs the final phase.
  control_t other_sender = TrackerFinished(39);
  other_sender.sender = "robot_sim";
  bus->PublishMessage("OBJSCAN_CONTROL", other_sender);
  Drain(*bus);
  EXPECT_FALSE(node.final_phase_done());
  bus->PublishMessage("OBJSCAN_CONTROL", TrackerFinished(39));
  Drain(*bus);
  EXPECT_TRUE(node.final_phase_done());
  EXPECT_FALSE(node.Finished());  // exit_when_finished = false
  EXPECT_EQ(sink.final_poses.size(), 39u);
  EXPECT_EQ(sink.finished.size(), 1u);
  // Tracks after the end are rejected.
  bus->PublishMessage("FEATURE_TRACKS", TracksToMessage(s.frames[39]));
  Drain(*bus);
  EXPECT_EQ(node.status().rejected("tracks: after end of stream"), 1);
}

TEST(PoseSolverNode, RejectedInputsAreNotCountedAsDropped) {
  SyntheticOrbitOptions so;
  so.num_frames = 12;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  auto bus = MakeLcmBus("memq://");
  PoseSolverNodeOptions o;
  o.exit_when_finished = false;
  PoseSolverNode node(*bus, o);
  bus->PublishMessage("CAMERA_INFO", CameraToMessage(s.camera, 0));
  for (int f = 0; f < 12; ++f) {
    odometry_t odo = OdometryToMessage(s.odometry[f]);
    if (f == 3) odo.x_mm = NAN;                              // received, rejected: not a drop
    if (f == 5) odo.utime = s.odometry[1].utime;             // out of order (its seq is new): not a drop either
    if (f != 8) bus->PublishMessage("ROBOT_ODOMETRY", odo);  // never sent: one drop
    feature_tracks_t m = TracksToMessage(s.frames[f]);
    if (f == 4) m.u[0] = NAN;         // received, rejected: not a drop
    if (f == 6) m.v[1] = 900;         // outside the image: not a drop either
    if (f == 7) m.image_width = 320;  // wrong size: nor this
    if (f == 9) continue;             // never sent: one drop
    bus->PublishMessage("FEATURE_TRACKS", m);
    Drain(*bus);
  }
  EXPECT_EQ(node.status().rejected_total(), 5);
  EXPECT_EQ(node.status().rejected("odometry: non-finite value"), 1);
  EXPECT_EQ(node.status().rejected("odometry: out of order"), 1);
  EXPECT_EQ(node.status().dropped_inputs(), 2);  // odometry 8 and tracks 9
}

TEST(PoseSolverNode, InvalidOptionsThrow) {
  auto bus = MakeLcmBus("memq://");
  PoseSolverNodeOptions o;
  o.model = "7dof";
  std::string why;
  EXPECT_FALSE(ValidatePoseSolverNodeOptions(o, &why));
  EXPECT_NE(why.find("model"), std::string::npos);
  EXPECT_THROW(PoseSolverNode(*bus, o), std::invalid_argument);
}

}  // namespace
}  // namespace objscan
