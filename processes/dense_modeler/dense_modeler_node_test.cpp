#include "processes/dense_modeler/dense_modeler_node.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>
#include <limits>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/geometry.h"
#include "objscan/landmarks_t.hpp"
#include "objscan/model_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/voxel_map_t.hpp"
#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

using testing_scene::SphereScene;

struct Collected {
  std::vector<voxel_map_t> maps;
  std::vector<model_t> models;
  std::vector<control_t> controls;
  std::vector<process_status_t> statuses;
};

// The named value of a status message (NaN when absent).
double StatusValue(const process_status_t& s, const std::string& name) {
  for (int i = 0; i < s.num_values; ++i)
    if (s.value_name[i] == name) return s.value[i];
  return std::nan("");
}

class NodeFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    bus_ = MakeLcmBus("memq://");
    bus_->SubscribeMessage<voxel_map_t>("VOXEL_MAP",
                                        [this](const voxel_map_t& m, const RawMessage&) { out_.maps.push_back(m); });
    bus_->SubscribeMessage<model_t>("MODEL", [this](const model_t& m, const RawMessage&) { out_.models.push_back(m); });
    bus_->SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      if (m.sender == "dense_modeler") out_.controls.push_back(m);
    });
    bus_->SubscribeMessage<process_status_t>(
        "PROCESS_STATUS", [this](const process_status_t& m, const RawMessage&) { out_.statuses.push_back(m); });
    dir_ = (std::filesystem::temp_directory_path() / ("dense_node_test_" + std::to_string(::getpid()))).string();
    options_.output_dir = dir_;
    options_.pair_gap = 1;
    options_.pair_every = 1;
    options_.buffer_frames = 6;
    options_.voxel_map_every = 4;
    options_.carving_downsample = 2;
    options_.target_channel = "TARGET";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  // A fresh bus and empty collected output for the next node of the same test (a bus cannot unsubscribe; the old one
  // is kept alive until the test ends).
  void Restart() {
    out_ = Collected();
    retired_buses_.push_back(std::move(bus_));
    SetUp();
  }
  void Drain() {
    while (bus_->Handle(0) > 0) {
    }
  }
  void PublishInfo() { bus_->PublishMessage("CAMERA_INFO", CameraToMessage(scene_.camera, 0)); }
  // A node without output files that knows the camera and the target box (pairs run as soon as frames come).
  std::unique_ptr<DenseModelerNode> StartWithTarget() {
    options_.output_dir.clear();
    auto node = std::make_unique<DenseModelerNode>(*bus_, options_);
    PublishInfo();
    PublishTarget();
    return node;
  }
  // The frame's image and tracks (track ids + id_offset), of the true pose.
  void PublishImageAndTracks(int seq, int n_views, const std::vector<Eigen::Vector3d>& features,
                             int64_t id_offset = 0) {
    const Eigen::Isometry3d pose = scene_.RingPose(seq, n_views);
    ImageFrame frame;
    frame.seq = seq;
    frame.utime = std::llround(seq * 1e6 / 30);
    frame.camera_name = "sim";
    frame.image = scene_.Render(pose);
    bus_->PublishMessage("CAMERA_IMAGE", ImageToMessage(frame, +image_t::ENCODING_BGR8));
    TrackFrame tracks = scene_.Tracks(pose, features, seq);
    for (TrackedFeature& f : tracks.features) f.id += id_offset;
    bus_->PublishMessage("FEATURE_TRACKS", TracksToMessage(tracks));
  }
  // live_scale: the live pose's camera centre is scaled about the world origin (a map the pose solver rescales
  // later).
  void PublishPose(int seq, int n_views, PoseStatus status = PoseStatus::kGroundTruth, double live_scale = 1.0) {
    CameraPoseEstimate est;
    est.seq = seq;
    est.utime = std::llround(seq * 1e6 / 30);
    est.world_from_camera = scene_.RingPose(seq, n_views);
    est.world_from_camera.translation() *= live_scale;
    est.world_from_camera = live_from_truth_.Apply(est.world_from_camera);
    est.status = status;
    bus_->PublishMessage("CAMERA_POSE", PoseToMessage(est));
  }
  // Image, tracks and live pose of frame seq; the image and tracks are those of the true pose.
  void PublishFrame(int seq, int n_views, const std::vector<Eigen::Vector3d>& features,
                    PoseStatus status = PoseStatus::kGroundTruth, double live_scale = 1.0) {
    PublishImageAndTracks(seq, n_views, features);
    PublishPose(seq, n_views, status, live_scale);
    Drain();
  }
  // The true ring pose of frame seq, status TRACKING, with the given scale source.
  CameraPoseEstimate RingPoseEstimate(int seq, int n_views, ScaleSource scale = ScaleSource::kNone) const {
    CameraPoseEstimate est;
    est.seq = seq;
    est.utime = std::llround(seq * 1e6 / 30);
    est.world_from_camera = scene_.RingPose(seq, n_views);
    est.status = PoseStatus::kTracking;
    est.scale_source = scale;
    return est;
  }
  // A CONFIRMED target: the sphere's box (2.2 radii wide) around centre.
  void PublishSphereTarget(const Eigen::Vector3d& centre) {
    target_t target{};
    target.state = target_t::STATE_CONFIRMED;
    target.frame = "world";
    for (int k = 0; k < 3; ++k) target.center_mm[k] = centre[k];
    target.size_mm[0] = target.size_mm[1] = target.size_mm[2] = 2.2 * scene_.radius;
    bus_->PublishMessage("TARGET", target);
  }
  // The final pose of frame seq: the true ring pose moved by map_from_truth, in the map that began at map_start_seq.
  void PublishFinalPose(int seq, int n_views, const Eigen::Isometry3d& map_from_truth = Eigen::Isometry3d::Identity(),
                        int64_t map_start_seq = -1) {
    CameraPoseEstimate est;
    est.seq = seq;
    est.utime = std::llround(seq * 1e6 / 30);
    est.world_from_camera = map_from_truth * scene_.RingPose(seq, n_views);
    est.status = PoseStatus::kTracking;
    est.map_start_seq = map_start_seq;
    bus_->PublishMessage("CAMERA_POSE_FINAL", PoseToMessage(est));
  }
  void PublishTarget() {
    target_t target{};
    target.state = target_t::STATE_CONFIRMED;
    target.frame = "world";
    target.center_mm[2] = 100;
    target.size_mm[0] = target.size_mm[1] = target.size_mm[2] = 200;
    bus_->PublishMessage("TARGET", target);
  }
  // A LANDMARKS message (world frame) of frame seq: points[k] (mapped by `frame`) with id first_id + k.
  static landmarks_t LandmarksMessage(const std::vector<Eigen::Vector3d>& points, int64_t seq, int64_t first_id = 0,
                                      const Sim3& frame = Sim3()) {
    landmarks_t m;
    m.utime = std::llround(seq * 1e6 / 30);
    m.seq = seq;
    m.frame = "world";
    m.num_landmarks = static_cast<int32_t>(points.size());
    for (size_t k = 0; k < points.size(); ++k) {
      const Eigen::Vector3d p = frame * points[k];
      m.id.push_back(first_id + static_cast<int64_t>(k));
      m.position_mm.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
      m.num_observations.push_back(5);
      m.reprojection_error_px.push_back(0.5f);
      m.rgb.push_back({128, 128, 128});
    }
    return m;
  }
  // Median distance (mm) of the final VOXEL_MAP's voxel centres to the true sphere; NaN without a final map.
  double FinalVoxelMedianErrorMm() const { return FinalVoxelErrorMm(0.5); }
  // mm, the given percentile (0..1) of the final voxels' distances to the true sphere; NaN without final voxels.
  double FinalVoxelErrorMm(double fraction) const {
    if (out_.maps.empty() || !out_.maps.back().is_final || out_.maps.back().num_voxels == 0) return std::nan("");
    const voxel_map_t& map = out_.maps.back();
    std::vector<double> errors;
    for (int i = 0; i < map.num_voxels; ++i) {
      const Eigen::Vector3d c =
          (Eigen::Vector3d(map.ijk[i][0], map.ijk[i][1], map.ijk[i][2]).array() + 0.5).matrix() * map.voxel_size_mm;
      errors.push_back(std::abs((c - scene_.center).norm() - scene_.radius));
    }
    const size_t k = static_cast<size_t>(fraction * static_cast<double>(errors.size() - 1));
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(k), errors.end());
    return errors[k];
  }
  void PublishControl(int8_t command, const std::string& sender, const std::string& argument = "") {
    control_t c;
    c.session_id = 0;
    c.utime = 0;
    c.sender = sender;
    c.target = "*";
    c.command = command;
    c.last_seq = -1;
    c.argument = argument;
    bus_->PublishMessage("OBJSCAN_CONTROL", c);
    Drain();
  }

  SphereScene scene_;
  Sim3 live_from_truth_;  // the live poses' frame (identity: the truth's)
  std::unique_ptr<Bus> bus_;
  std::vector<std::unique_ptr<Bus>> retired_buses_;
  Collected out_;
  DenseModelerNodeOptions options_;
  std::string dir_;
};

TEST_F(NodeFixture, RingOfViewsGivesModelFilesAndFinished) {
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  PublishTarget();
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  for (int i = 0; i <= n; ++i) PublishFrame(i, n, features);  // frame n closes the ring (same pose as 0)
  EXPECT_EQ(node.pairs_done(), n);
  ASSERT_GE(out_.maps.size(), 4u);
  EXPECT_FALSE(out_.maps.back().is_final);
  EXPECT_GT(out_.maps.back().num_voxels, 1000);
  EXPECT_FALSE(node.Finished());
  // Final poses (here the same true poses) for half of the frames: no pair (gap 1) has both, so the live votes stay
  // and the carving takes the live poses they were cast with, not a mix.
  for (int i = 0; i <= n; i += 2) PublishFinalPose(i, n);
  Drain();
  PublishControl(+control_t::COMMAND_FINISHED, "tracker");  // not the awaited sender
  EXPECT_FALSE(node.final_phase_done());
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  EXPECT_TRUE(node.Finished());
  EXPECT_EQ(node.final_poses_used(), 0);
  ASSERT_EQ(out_.models.size(), 1u);
  const model_t& m = out_.models[0];
  EXPECT_GT(m.num_voxels, 5000);
  EXPECT_GT(m.num_mesh_triangles, 5000);
  EXPECT_EQ(m.num_views, n + 1);
  EXPECT_TRUE(std::filesystem::exists(m.voxels_ply_path));
  EXPECT_TRUE(std::filesystem::exists(m.mesh_ply_path));
  EXPECT_TRUE(std::filesystem::exists(m.octomap_path));
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(m.bbox_min_mm[k], -140);
    EXPECT_LT(m.bbox_max_mm[k], 140);
  }
  ASSERT_TRUE(out_.maps.back().is_final);
  EXPECT_EQ(out_.maps.back().num_voxels, m.num_voxels);
  ASSERT_EQ(out_.controls.size(), 1u);
  EXPECT_EQ(out_.controls[0].command, +control_t::COMMAND_FINISHED);
  EXPECT_EQ(out_.controls[0].last_seq, n);
  EXPECT_EQ(node.status().rejected_total(), 0);
  // The last status carries the final phase's figures.
  ASSERT_FALSE(out_.statuses.empty());
  const process_status_t& last = out_.statuses.back();
  EXPECT_EQ(StatusValue(last, "final_voxels"), m.num_voxels);
  EXPECT_NEAR(StatusValue(last, "live_final_offset_mm"), 0.0, 1e-6);  // live votes kept, final poses = live ones
  EXPECT_EQ(StatusValue(last, "final_triangles"), m.num_mesh_triangles);
  for (const char* name : {"final_floor_band_dropped", "final_carved", "final_hidden_vertices",
                           "final_curled_triangles", "final_voxels_off_mesh", "final_weak_vertices", "final_weak_moved",
                           "final_rim_vertices_removed", "final_carving_s", "final_visibility_s"})
    EXPECT_GE(StatusValue(last, name), 0.0) << name;
  // The pairs' epipolar searches (refinement on by default), some of which scored every step.
  EXPECT_GT(StatusValue(last, "refine_searches"), 1000.0);
  EXPECT_GE(StatusValue(last, "refine_full_searches"), 0.0);
  EXPECT_LE(StatusValue(last, "refine_full_searches"), StatusValue(last, "refine_searches"));
  // Snapshot on request, loadable, same content.
  PublishControl(+control_t::COMMAND_SNAPSHOT, "viewer", dir_ + "/snap.bin");
  VoxelVoteGrid loaded;
  std::string error;
  ASSERT_TRUE(loaded.LoadSnapshot(dir_ + "/snap.bin", &error)) << error;
  EXPECT_EQ(loaded.total_votes(), node.grid().total_votes());
  node.OnShutdown();
  EXPECT_TRUE(std::filesystem::exists(dir_ + "/votes_snapshot.bin"));
}

// A second, different pose for a frame (forged, or a second session on the bus) and a second calibration are
// rejected and counted; the frame takes part in no later pair and the model stays where the object is.
TEST_F(NodeFixture, ConflictingPoseAndCalibrationAreRejected) {
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  PublishTarget();
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  for (int i = 0; i <= n; ++i) {
    PublishFrame(i, n, features);
    if (i == 5) {  // a forged pose for frame 5, 300 mm off, and a forged calibration
      CameraPoseEstimate forged;
      forged.seq = 5;
      forged.utime = std::llround(5 * 1e6 / 30);
      forged.world_from_camera = scene_.RingPose(5, n);
      forged.world_from_camera.translation().x() += 300;
      forged.status = PoseStatus::kTracking;
      bus_->PublishMessage("CAMERA_POSE", PoseToMessage(forged));
      PinholeCamera other = scene_.camera;
      other.fx *= 1.1;
      bus_->PublishMessage("CAMERA_INFO", CameraToMessage(other, 0));
      PublishPose(5, n);  // the true pose once more: rejected too, the frame is used no more
      Drain();
    }
  }
  EXPECT_EQ(node.status().rejected_total(), 3);  // the forged pose, the calibration, the pose after the conflict
  EXPECT_LE(node.pairs_done(), n - 1);            // pair 5-6 not run
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  ASSERT_EQ(out_.models.size(), 1u);
  const model_t& m = out_.models[0];
  EXPECT_GT(m.num_voxels, 5000);
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(m.bbox_min_mm[k], -140);
    EXPECT_LT(m.bbox_max_mm[k], 140);
  }
}

// The live poses belong to a map 3 % too large (the pose solver rescales it later, as after a loop or a scale
// correction): the live votes make a sphere 3 % too large, 3-6 mm off; the final poses, true here, give the
// final phase's re-triangulated votes the true sphere (0.55 mm median). With the re-vote off the final model keeps
// most of the error (carving with the final poses removes some).
TEST_F(NodeFixture, FinalPosesReplaceTheLiveVotes) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  double error_mm[2] = {0, 0};
  for (const bool revote : {true, false}) {
    Restart();
    DenseModelerNodeOptions options = options_;
    options.revote_final_poses = revote;
    DenseModelerNode node(*bus_, options);
    PublishInfo();
    PublishTarget();
    for (int i = 0; i <= n; ++i) PublishFrame(i, n, features, PoseStatus::kTracking, 1.03);
    EXPECT_EQ(node.pairs_done(), n);
    for (int i = 0; i <= n; ++i) PublishFinalPose(i, n);
    Drain();
    PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
    ASSERT_TRUE(node.final_phase_done());
    error_mm[revote ? 0 : 1] = FinalVoxelMedianErrorMm();
    ASSERT_FALSE(out_.statuses.empty());
    EXPECT_EQ(node.final_poses_used(), revote ? n + 1 : 0) << "carving takes the poses the votes were cast with";
    if (revote) {
      EXPECT_EQ(StatusValue(out_.statuses.back(), "final_revoted_pairs"), n);
      EXPECT_EQ(StatusValue(out_.statuses.back(), "final_revote_rejected"), 0);  // a scale keeps the epipolar lines
      EXPECT_EQ(StatusValue(out_.statuses.back(), "live_final_offset_mm"), -1.0);  // final poses used
      EXPECT_EQ(StatusValue(out_.statuses.back(), "model_off_trajectory_frame"), 0);
    } else {
      // The live votes kept while the final poses lie 3 % of the ring's radius away: reported (the session fails).
      const double offset = StatusValue(out_.statuses.back(), "live_final_offset_mm");
      const double radius = scene_.RingPose(0, n).translation().norm();
      EXPECT_NEAR(offset, 0.03 * radius, 0.01 * radius);
      EXPECT_GT(offset, 5.0);
      EXPECT_EQ(StatusValue(out_.statuses.back(), "model_off_trajectory_frame"), 1);
    }
    std::printf("re-vote %s: final voxels' median error %.2f mm\n", revote ? "on" : "off", error_mm[revote ? 0 : 1]);
  }
  EXPECT_LT(error_mm[0], 0.8);
  EXPECT_FALSE(error_mm[1] < 1.5);  // 1.96 measured; NaN (carving removed everything) counts as worse
}

// The final poses lie in two maps never joined (a restart after a tracking loss at frame 10): frames 10-16 are 15 mm
// and 1 degree off in their own map. The re-vote keeps the map with the most matches (frames 0-9: 9 pairs against 6),
// drops the other map's pairs and the pair across the restart, carves with that map's views only: the model is the
// true sphere. Without map ids (old logs: -1) both maps vote and carve together: a double surface.
TEST_F(NodeFixture, AModelFromFinalPosesInTwoMapsKeepsOneMap) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  Eigen::Isometry3d second_map = Eigen::Isometry3d::Identity();
  second_map.translate(Eigen::Vector3d(15, 0, 0));
  second_map.rotate(Eigen::AngleAxisd(1.0 * M_PI / 180, Eigen::Vector3d::UnitZ()));
  double error_mm[2] = {0, 0};
  for (const bool with_map_ids : {true, false}) {
    Restart();
    DenseModelerNode node(*bus_, options_);
    PublishInfo();
    PublishTarget();
    for (int i = 0; i <= n; ++i) PublishFrame(i, n, features, PoseStatus::kTracking);
    ASSERT_EQ(node.pairs_done(), n);
    for (int i = 0; i <= n; ++i)
      PublishFinalPose(i, n, i < 10 ? Eigen::Isometry3d::Identity() : second_map,
                       with_map_ids ? (i < 10 ? 0 : 10) : -1);
    Drain();
    ::testing::internal::CaptureStderr();
    PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
    const std::string log = ::testing::internal::GetCapturedStderr();
    ASSERT_TRUE(node.final_phase_done());
    error_mm[with_map_ids ? 0 : 1] = FinalVoxelErrorMm(0.9);
    const process_status_t& st = out_.statuses.back();
    if (with_map_ids) {
      EXPECT_NE(log.find("final votes from one map"), std::string::npos) << log;
      EXPECT_EQ(StatusValue(st, "final_maps"), 2);
      EXPECT_EQ(StatusValue(st, "final_model_map_start_seq"), 0);
      EXPECT_EQ(StatusValue(st, "final_pairs_other_maps"), 7);  // 6 in the second map, 1 across
      EXPECT_EQ(StatusValue(st, "final_revoted_pairs"), 9);
      EXPECT_EQ(node.final_poses_used(), 10) << "only the kept map's views carve";
    } else {
      EXPECT_EQ(StatusValue(st, "final_maps"), 0);
      EXPECT_EQ(StatusValue(st, "final_model_map_start_seq"), -1);
      EXPECT_EQ(StatusValue(st, "final_revoted_pairs"), n);
    }
    std::printf("final poses in two maps 15 mm / 1 deg apart, %s: final voxels' p90 error %.2f mm\n",
                with_map_ids ? "one map kept" : "both maps (no map ids)", error_mm[with_map_ids ? 0 : 1]);
  }
  // p90 of the 2 mm voxels' distances to the sphere: 0.99 mm from one map, 9.12 mm from both (measured).
  EXPECT_LT(error_mm[0], 1.5);
  EXPECT_FALSE(error_mm[1] < 3 * error_mm[0]);  // NaN (carving removed everything) counts as worse
}

// The live map lies in another frame than the final poses (an unjoined restart rescaled by its floor in the final
// phase: room_02, 7 Dec, 351 mm), and the TARGET box came in the live frame: the region moves with the final poses,
// the re-vote keeps the model (in the final frame, on the true sphere). Without the move every re-voted point fell
// outside the live region, the live votes stayed and the model lay 300 mm off trajectory.txt's frame.
TEST_F(NodeFixture, TheRegionFollowsTheFinalPosesIntoTheirFrame) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  live_from_truth_.scale = 1.1;
  live_from_truth_.rotation = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  live_from_truth_.translation = Eigen::Vector3d(300, -200, 0);
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  target_t target{};  // the sphere's box in the live frame
  target.state = target_t::STATE_CONFIRMED;
  target.frame = "world";
  const Eigen::Vector3d centre = live_from_truth_ * scene_.center;
  for (int k = 0; k < 3; ++k) target.center_mm[k] = centre[k];
  target.size_mm[0] = target.size_mm[1] = target.size_mm[2] = 2.2 * scene_.radius * live_from_truth_.scale;
  target.yaw_rad = 0.2;
  bus_->PublishMessage("TARGET", target);
  for (int i = 0; i <= n; ++i) PublishFrame(i, n, features, PoseStatus::kTracking);
  ASSERT_EQ(node.pairs_done(), n);
  for (int i = 0; i <= n; ++i) PublishFinalPose(i, n);
  Drain();
  ::testing::internal::CaptureStderr();
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_TRUE(node.final_phase_done());
  EXPECT_NE(log.find("the region moved with the final poses"), std::string::npos) << log;
  EXPECT_EQ(StatusValue(out_.statuses.back(), "final_revoted_pairs"), n);
  EXPECT_EQ(StatusValue(out_.statuses.back(), "model_off_trajectory_frame"), 0);
  const double error_mm = FinalVoxelMedianErrorMm();
  std::printf("live frame 300 mm / 11 deg / scale 1.1 off the final one: final voxels' median error %.2f mm\n", error_mm);
  EXPECT_LT(error_mm, 0.8);
}

// Without a target box the region is the automatic one, derived from the landmarks in use (the tracks seen in the
// image centre). In the final phase those are the final map's, so the region is in the final frame already: it stays
// where it is, while the final poses lie 300 mm / 11 deg / scale 1.1 from the live ones (moved again by that Sim(3) it
// would miss the sphere).
TEST_F(NodeFixture, TheAutomaticRegionFromTheFinalMapStays) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  live_from_truth_.scale = 1.1;
  live_from_truth_.rotation = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  live_from_truth_.translation = Eigen::Vector3d(300, -200, 0);
  options_.target_channel = "";
  options_.auto_roi = true;
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  // The landmarks: the features (track id = index), in the live frame while tracking, in the true one at the end.
  for (int i = 0; i <= n; ++i) {
    PublishFrame(i, n, features, PoseStatus::kTracking);
    if (i == 1) {
      bus_->PublishMessage("LANDMARKS", LandmarksMessage(features, i, 0, live_from_truth_));
      Drain();
    }
  }
  ASSERT_GT(node.pairs_done(), n / 2);
  for (int i = 0; i <= n; ++i) PublishFinalPose(i, n);
  bus_->PublishMessage("LANDMARKS", LandmarksMessage(features, n));  // the pose solver's final map
  Drain();
  EXPECT_EQ(node.status().rejected_total(), 0);
  ::testing::internal::CaptureStderr();
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_TRUE(node.final_phase_done());
  EXPECT_EQ(node.region_source(), 3);
  EXPECT_NE(log.find("the automatic region, derived from the final map's landmarks, stays"), std::string::npos)
      << log;
  ASSERT_EQ(out_.models.size(), 1u);
  EXPECT_GT(out_.models[0].num_voxels, 3000);
  const double error_mm = FinalVoxelMedianErrorMm();
  std::printf("automatic region from the final map: %d final voxels, median error %.2f mm\n",
              out_.models[0].num_voxels, error_mm);
  EXPECT_LT(error_mm, 0.8);
}

// The live poses lie 40 mm below the final (true) ones, in one case alternate live views also 8 mm off sideways (no
// Sim(3): room_03, 7 Dec, 18 mm RMS after a restart rescaled in the orbit). The region (TARGET box in the live frame)
// moves with the Sim(3) of the camera centres. Its floor, fitted in the final phase among the final landmarks (the
// true floor z = 0), is in the final frame already: it is fitted again around the moved box, not moved 40 mm up
// (which cut the sphere below 44 mm: model from z = 46 mm). Landmarks that came before the final poses are live ones
// (the floor at z = -40 mm): that floor moves with the box. Either way the model reaches down to the sphere's lowest
// seen points (20 mm).
TEST_F(NodeFixture, RegionFloorInTheFinalFrameWhateverFrameItWasFittedIn) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  const Eigen::Vector3d live_shift(0, 0, -40);
  // The final landmarks (true frame): 200 on the floor z = 0 around the sphere, 300 on the sphere (ids no track has).
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 200; ++i) {
    const double a = 2 * M_PI * i / 200, r = 150 + 250 * ((i * 37) % 100) / 100.0;
    points.emplace_back(r * std::cos(a), r * std::sin(a), 0.0);
  }
  for (const Eigen::Vector3d& p : scene_.SurfacePoints(300)) points.push_back(p);
  const landmarks_t landmarks = LandmarksMessage(points, n, 1000000);
  Sim3 live_from_final;  // the same map in the live frame
  live_from_final.translation = live_shift;
  const landmarks_t live_landmarks = LandmarksMessage(points, n - 1, 1000000, live_from_final);
  struct Case {
    double sideways_mm;
    bool final_landmarks;
  };
  for (const Case c : {Case{8.0, true}, Case{0.0, true}, Case{0.0, false}}) {
    const double sideways_mm = c.sideways_mm;
    Restart();
    DenseModelerNode node(*bus_, options_);
    PublishInfo();
    PublishSphereTarget(scene_.center + live_shift);  // the sphere's box in the live frame
    for (int i = 0; i <= n; ++i) {
      PublishImageAndTracks(i, n, features);
      CameraPoseEstimate est = RingPoseEstimate(i, n);
      const Eigen::Vector3d sideways = est.world_from_camera.linear().col(0);  // the camera's x axis
      est.world_from_camera.translation() += live_shift + (i % 2 == 0 ? sideways_mm : -sideways_mm) * sideways;
      bus_->PublishMessage("CAMERA_POSE", PoseToMessage(est));
      Drain();
    }
    ASSERT_EQ(node.pairs_done(), n);
    if (!c.final_landmarks) bus_->PublishMessage("LANDMARKS", live_landmarks);
    for (int i = 0; i <= n; ++i) PublishFinalPose(i, n);
    if (c.final_landmarks) bus_->PublishMessage("LANDMARKS", landmarks);  // the pose solver's final map
    Drain();
    EXPECT_EQ(node.status().rejected_total(), 0);
    ::testing::internal::CaptureStderr();
    PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
    const std::string log = ::testing::internal::GetCapturedStderr();
    ASSERT_TRUE(node.final_phase_done());
    EXPECT_NE(log.find("the region moved with the final poses by 40 mm"), std::string::npos) << log;
    EXPECT_EQ(StatusValue(out_.statuses.back(), "final_revoted_pairs"), n);
    EXPECT_EQ(StatusValue(out_.statuses.back(), "model_off_trajectory_frame"), 0);
    EXPECT_LT(FinalVoxelMedianErrorMm(), 0.8);
    ASSERT_EQ(out_.models.size(), 1u);
    const double model_bottom_mm = out_.models[0].bbox_min_mm[2];
    std::printf("live views %.0f mm off sideways, %s landmarks: model from z = %.1f mm\n", sideways_mm,
                c.final_landmarks ? "final" : "live", model_bottom_mm);
    if (c.final_landmarks) {
      // (the 200 floor landmarks and the sphere's lowest ones within the floor tolerance)
      EXPECT_NE(log.find("; floor fitted again among the final landmarks around it ("), std::string::npos) << log;
      EXPECT_NE(log.find("points), 40.0 mm from the moved one at its centre"), std::string::npos) << log;
    } else {
      EXPECT_EQ(log.find("floor fitted again"), std::string::npos) << log;
    }
    EXPECT_LT(model_bottom_mm, 30.0);  // 20 mm measured; the floor moved 40 mm up cut below 44 mm
  }
}

// The final map's floor around the target is checked: one thin layer (poses that agree) lets the run finish; two
// layers 8 mm apart (room_09's rerun: 9.0 mm, its model's mesh p90 14.9 mm in its own frame) end it in the error
// state with why and what to try, the model files written all the same. In an arbitrary unit it is only logged.
TEST_F(NodeFixture, AFloorInTwoLayersAroundTheTargetIsAnError) {
  const int n = 16;
  const auto features = scene_.SurfacePoints(2000);
  struct Case {
    double second_layer_mm;
    ScaleSource scale;
    bool error;
  };
  for (const Case c : {Case{0.0, ScaleSource::kOdometry, false}, Case{8.0, ScaleSource::kOdometry, true},
                       Case{8.0, ScaleSource::kNone, false}}) {
    std::vector<Eigen::Vector3d> points;  // the final map: a floor ring 160-600 mm around the sphere, the sphere
    for (int i = 0; i < 800; ++i) {
      const double a = 2 * M_PI * i / 800, r = 160 + 440 * ((i * 37) % 100) / 100.0;
      points.emplace_back(r * std::cos(a), r * std::sin(a), i % 2 == 0 ? 0.0 : c.second_layer_mm);
    }
    for (const Eigen::Vector3d& p : scene_.SurfacePoints(300)) points.push_back(p);
    Restart();
    DenseModelerNode node(*bus_, options_);
    PublishInfo();
    PublishSphereTarget(scene_.center);
    for (int i = 0; i <= n; ++i) {
      PublishImageAndTracks(i, n, features);
      bus_->PublishMessage("CAMERA_POSE", PoseToMessage(RingPoseEstimate(i, n, c.scale)));
      Drain();
    }
    for (int i = 0; i <= n; ++i) bus_->PublishMessage("CAMERA_POSE_FINAL", PoseToMessage(RingPoseEstimate(i, n, c.scale)));
    bus_->PublishMessage("LANDMARKS", LandmarksMessage(points, n, 1000000));  // the pose solver's final map
    Drain();
    ::testing::internal::CaptureStderr();
    PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
    const std::string log = ::testing::internal::GetCapturedStderr();
    ASSERT_TRUE(node.final_phase_done());
    ASSERT_FALSE(out_.statuses.empty());
    const process_status_t& last = out_.statuses.back();
    const double thickness = StatusValue(last, "final_floor_thickness_mm");
    std::printf("second layer %.0f mm, scale %s: floor %.1f mm thick (%.0f points), state %d\n", c.second_layer_mm,
                IsMetric(c.scale) ? "metric" : "arbitrary", thickness, StatusValue(last, "final_floor_points"),
                last.state);
    // (two layers: the region's floor, fitted among both, tilts a little across them: 13.7 mm measured)
    EXPECT_GE(thickness, c.second_layer_mm - 0.5);
    EXPECT_LE(thickness, c.second_layer_mm == 0 ? 0.5 : 16.0);
    EXPECT_GE(StatusValue(last, "final_floor_points"), 400);
    ASSERT_EQ(out_.models.size(), 1u);  // written either way
    EXPECT_GT(out_.models[0].num_voxels, 0);
    if (c.error) {
      EXPECT_EQ(last.state, +process_status_t::STATE_ERROR);
      EXPECT_NE(last.state_detail.find("the map is inconsistent around the target"), std::string::npos)
          << last.state_detail;
      EXPECT_NE(last.state_detail.find("run again"), std::string::npos) << last.state_detail;
    } else {
      EXPECT_EQ(last.state, +process_status_t::STATE_FINISHED) << last.state_detail;
      EXPECT_NE(log.find("map consistency: the floor around the target is"), std::string::npos) << log;
    }
  }
}

TEST_F(NodeFixture, BadInputIsCountedAndSkipped) {
  options_.output_dir.clear();
  DenseModelerNode node(*bus_, options_);
  const auto features = scene_.SurfacePoints(500);
  // Image before camera info.
  PublishFrame(0, 16, features);
  EXPECT_EQ(node.status().rejected("image: no camera_info yet"), 1);
  EXPECT_EQ(node.status().rejected("pose: unknown frame"), 1);
  PublishInfo();
  Drain();
  // Malformed bytes on the image channel.
  const char junk[5] = {1, 2, 3, 4, 5};
  bus_->Publish("CAMERA_IMAGE", junk, 5);
  Drain();
  EXPECT_EQ(node.status().rejected("image: malformed"), 1);
  // Lost pose.
  PublishFrame(1, 16, features, PoseStatus::kLost);
  EXPECT_EQ(node.status().rejected("pose: not tracking"), 1);
  // NaN pose.
  CameraPoseEstimate est;
  est.seq = 1;
  est.status = PoseStatus::kTracking;
  pose_t msg = PoseToMessage(est);
  msg.position_mm[0] = std::numeric_limits<double>::quiet_NaN();
  bus_->PublishMessage("CAMERA_POSE", msg);
  Drain();
  EXPECT_EQ(node.status().rejected_total(), 5);
  // Wrong image size.
  ImageFrame small;
  small.seq = 2;
  small.image = cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3));
  bus_->PublishMessage("CAMERA_IMAGE", ImageToMessage(small, +image_t::ENCODING_BGR8));
  Drain();
  EXPECT_EQ(node.status().rejected("image: wrong size"), 1);
  EXPECT_EQ(node.status().rejected_total(), 6);
  // Good frames still work after all that; frames without a usable pose are evicted and counted.
  // No region comes here (no TARGET, no landmarks): the 8 pairs wait for one while their frames stay in the 6-frame
  // buffer, 3 run unrestricted as their older frame leaves it, the rest at the final phase.
  for (int i = 3; i < 12; ++i) PublishFrame(i, 16, features);
  EXPECT_EQ(node.pairs_done(), 3);
  EXPECT_EQ(node.status().rejected("frame: evicted without pose"), 2);  // seq 0 and 1
  // Snapshot without a path.
  PublishControl(+control_t::COMMAND_SNAPSHOT, "viewer");
  EXPECT_EQ(node.status().rejected("snapshot: no path"), 1);
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  EXPECT_EQ(node.pairs_done(), 8);
  EXPECT_EQ(StatusValue(out_.statuses.back(), "pairs_without_region"), 8);
  ASSERT_EQ(out_.models.size(), 1u);
  EXPECT_TRUE(out_.models[0].voxels_ply_path.empty());
  EXPECT_GT(out_.models[0].num_voxels, 100);
}

// Pairs wait for the region of interest while it can still come: here the TARGET box arrives after 3 pairs, which
// then run restricted to it like every later one. Without the wait they would vote the unrestricted scene.
TEST_F(NodeFixture, PairsWaitForTheRegionOfInterest) {
  options_.output_dir.clear();
  options_.target_margin_mm = 0;
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  const auto features = scene_.SurfacePoints(2000);
  for (int i = 0; i < 4; ++i) PublishFrame(i, 16, features);
  EXPECT_EQ(node.pairs_done(), 0);
  EXPECT_EQ(node.grid().total_votes(), 0);
  // A confirmed box over the sphere's upper half only: z from 100 to 200 mm.
  target_t target{};
  target.state = target_t::STATE_CONFIRMED;
  target.frame = "world";
  target.center_mm[2] = 150;
  target.size_mm[0] = target.size_mm[1] = 220;
  target.size_mm[2] = 100;
  bus_->PublishMessage("TARGET", target);
  Drain();
  for (int i = 4; i < 8; ++i) PublishFrame(i, 16, features);
  EXPECT_EQ(node.pairs_done(), 7);
  ASSERT_GT(node.grid().total_votes(), 0);
  // Every voted voxel lies in the box (votes spread one voxel beyond the points).
  int64_t below = 0;
  for (const VoxelRecord& v : node.grid().Extract(1))
    if (node.grid().CenterOf(v.ijk).z() < 100 - 2 * node.grid().voxel_size()) ++below;
  EXPECT_EQ(below, 0);
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  ASSERT_FALSE(out_.statuses.empty());
  EXPECT_EQ(StatusValue(out_.statuses.back(), "pairs_without_region"), 0);
  EXPECT_EQ(StatusValue(out_.statuses.back(), "pairs_waiting"), 0);
}

// The robot searching its target: without a confirmed TARGET nothing is modeled (the pairs are dropped, never run
// unrestricted), and views that do not see the box are not kept for carving.
TEST_F(NodeFixture, RequireTargetModelsNothingBeforeTheTarget) {
  options_.output_dir.clear();
  options_.require_target = true;
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  const auto features = scene_.SurfacePoints(2000);
  for (int i = 0; i < 12; ++i) PublishFrame(i, 16, features);
  EXPECT_EQ(node.pairs_done(), 0);
  EXPECT_EQ(node.grid().total_votes(), 0);
  PublishTarget();
  Drain();
  for (int i = 12; i < 18; ++i) PublishFrame(i, 16, features);
  EXPECT_GE(node.pairs_done(), 5);
  EXPECT_GT(node.grid().total_votes(), 0);
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  ASSERT_FALSE(out_.statuses.empty());
  // 12 frames, pair gap 1: 11 pairs before the target, at most the last one (its frame still buffered) runs after.
  EXPECT_GE(StatusValue(out_.statuses.back(), "pairs_before_target"), 6);
  EXPECT_EQ(StatusValue(out_.statuses.back(), "pairs_without_region"), 0);
  // The 6 frames after the target see the sphere: only they are kept for carving.
  EXPECT_LE(StatusValue(out_.statuses.back(), "carving_views"), 6);
  EXPECT_GE(StatusValue(out_.statuses.back(), "carving_views"), 5);
}

// A run that ends without a model fails loudly: STATE_ERROR with what happened and what to try (room_03: the target
// confirmed 8 frames before the end, "modeled" with empty files and status ok).
TEST_F(NodeFixture, EmptyFinalModelIsAnError) {
  options_.output_dir.clear();
  options_.require_target = true;
  DenseModelerNode node(*bus_, options_);
  PublishInfo();
  const auto features = scene_.SurfacePoints(2000);
  for (int i = 0; i < 8; ++i) PublishFrame(i, 16, features);  // no TARGET ever: every pair is dropped
  PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
  ASSERT_FALSE(out_.statuses.empty());
  const process_status_t& last = out_.statuses.back();
  EXPECT_EQ(last.state, +process_status_t::STATE_ERROR);
  EXPECT_NE(last.state_detail.find("the final model is empty"), std::string::npos) << last.state_detail;
  EXPECT_NE(last.state_detail.find("try"), std::string::npos) << last.state_detail;
}

TEST(DenseModelerNodeOptions, RequireTargetNeedsTheTargetChannel) {
  DenseModelerNodeOptions o;
  o.require_target = true;
  std::string why;
  EXPECT_TRUE(ValidateDenseModelerNodeOptions(o, &why)) << why;
  o.target_channel.clear();
  EXPECT_FALSE(ValidateDenseModelerNodeOptions(o, &why));
  EXPECT_NE(why.find("require-target"), std::string::npos);
}

TEST_F(NodeFixture, SameInputGivesIdenticalOutput) {
  options_.output_dir.clear();
  std::vector<std::vector<uint8_t>> encoded[2];
  for (int run = 0; run < 2; ++run) {
    out_ = Collected();
    auto bus = MakeLcmBus("memq://");
    bus_.swap(bus);
    SetUp();
    options_.output_dir.clear();
    {
      DenseModelerNode node(*bus_, options_);
      PublishInfo();
      const auto features = scene_.SurfacePoints(1000);
      for (int i = 0; i < 6; ++i) PublishFrame(i, 24, features);
      for (int i = 0; i < 4; ++i) PublishFinalPose(i, 24);  // re-vote: pairs 0-1 to 2-3 final, 3-4 and 4-5 live
      Drain();
      PublishControl(+control_t::COMMAND_FINISHED, "pose_solver");
    }
    ASSERT_FALSE(out_.statuses.empty());
    EXPECT_EQ(StatusValue(out_.statuses.back(), "final_revoted_pairs"), 3);
    for (const auto& m : out_.maps) {
      std::vector<uint8_t> buf(m.getEncodedSize());
      m.encode(buf.data(), 0, static_cast<int>(buf.size()));
      encoded[run].push_back(buf);
    }
    ASSERT_EQ(out_.models.size(), 1u);
    std::vector<uint8_t> buf(out_.models[0].getEncodedSize());
    out_.models[0].encode(buf.data(), 0, static_cast<int>(buf.size()));
    encoded[run].push_back(buf);
  }
  ASSERT_GE(encoded[0].size(), 2u);
  EXPECT_TRUE(encoded[0] == encoded[1]);
}

// A rejected image with a wild sequence number must not move the stream on (it blocked every later image); tracks
// for frames older than a full ring buffer are rejected instead of growing it.
TEST_F(NodeFixture, WildSequenceNumbersAndStaleTracksNeitherBlockNorGrow) {
  const auto node_ptr = StartWithTarget();
  const DenseModelerNode& node = *node_ptr;
  const auto features = scene_.SurfacePoints(1000);
  PublishFrame(0, 16, features);
  PublishFrame(1, 16, features);
  ImageFrame wild;
  wild.seq = int64_t{1} << 50;
  wild.image = cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3));  // wrong size: rejected
  bus_->PublishMessage("CAMERA_IMAGE", ImageToMessage(wild, +image_t::ENCODING_BGR8));
  Drain();
  EXPECT_EQ(node.status().rejected("image: wrong size"), 1);
  for (int i = 2; i < 8; ++i) PublishFrame(i, 16, features);
  EXPECT_EQ(node.pairs_done(), 7);
  EXPECT_EQ(node.status().rejected("image: out of order or repeated"), 0);
  EXPECT_EQ(node.status().dropped_inputs(), 0);
  // 500 tracks messages for ever older frames (a replayed or restarted tracker): all rejected, none kept.
  const TrackFrame tracks = scene_.Tracks(scene_.RingPose(0, 16), features, 0);
  for (int k = 0; k < 500; ++k) {
    TrackFrame stale = tracks;
    stale.seq = -1 - k;
    bus_->PublishMessage("FEATURE_TRACKS", TracksToMessage(stale));
  }
  Drain();
  EXPECT_EQ(node.status().rejected("tracks: older than the ring buffer"), 500);
  EXPECT_EQ(node.status().rejected("frame: evicted without pose"), 0);  // nothing stale got in to be evicted
  PublishFrame(8, 16, features);
  EXPECT_EQ(node.pairs_done(), 8);
}

// Frames complete in whichever order their poses come: frame 1's pose arrives after frame 2 is complete, and both
// of frame 1's pairs (0-1 and 1-2) still run.
TEST_F(NodeFixture, FramesCompletingOutOfOrderKeepTheirPairs) {
  const auto node_ptr = StartWithTarget();
  const DenseModelerNode& node = *node_ptr;
  const auto features = scene_.SurfacePoints(1000);
  PublishFrame(0, 16, features);
  PublishImageAndTracks(1, 16, features);
  Drain();
  PublishFrame(2, 16, features);
  EXPECT_EQ(node.pairs_done(), 0);  // both pairs need frame 1
  PublishPose(1, 16);
  Drain();
  EXPECT_EQ(node.pairs_done(), 2);
  PublishFrame(3, 16, features);
  EXPECT_EQ(node.pairs_done(), 3);
  EXPECT_EQ(node.status().rejected_total(), 0);
}

// Track ids whose central views are counted stay bounded in a long run: beyond max_central_track_ids, ids that are
// neither landmarks nor in the current frame are forgotten.
TEST_F(NodeFixture, CentralTrackCountsStayBounded) {
  options_.max_central_track_ids = 300;
  const auto node_ptr = StartWithTarget();
  const DenseModelerNode& node = *node_ptr;
  const auto features = scene_.SurfacePoints(200);
  for (int i = 0; i < 12; ++i) {
    PublishImageAndTracks(i, 16, features, int64_t{100000} * i);  // every frame's tracks are new
    PublishPose(i, 16);
    Drain();
  }
  const double ids = node.status().value("central_track_ids");
  EXPECT_GT(ids, 0);
  EXPECT_LE(ids, 300 + 200);  // the limit plus one frame's new ids, not 12 frames' (up to 2 400)
}

TEST_F(NodeFixture, EmptyTargetBoxIsRejected) {
  options_.output_dir.clear();
  options_.target_margin_mm = 0;
  DenseModelerNode node(*bus_, options_);
  target_t target{};
  target.state = target_t::STATE_CONFIRMED;
  target.frame = "world";
  target.size_mm[0] = 100;  // flat in y and z
  bus_->PublishMessage("TARGET", target);
  Drain();
  EXPECT_EQ(node.status().rejected("target: empty box"), 1);
}

TEST(DenseModelerNodeOptions, Validation) {
  DenseModelerNodeOptions o;
  std::string why;
  EXPECT_TRUE(ValidateDenseModelerNodeOptions(o, &why)) << why;
  o.pair_gap = 50;
  EXPECT_FALSE(ValidateDenseModelerNodeOptions(o, &why));
  EXPECT_NE(why.find("buffer-frames"), std::string::npos);
  o = DenseModelerNodeOptions();
  o.model.votes.neighbourhood = 5;
  EXPECT_FALSE(ValidateDenseModelerNodeOptions(o, &why));
  o = DenseModelerNodeOptions();
  o.max_central_track_ids = 0;
  EXPECT_FALSE(ValidateDenseModelerNodeOptions(o, &why));
  EXPECT_NE(why.find("max_central_track_ids"), std::string::npos);
  o.model.votes.neighbourhood = 5;
  auto bus = MakeLcmBus("memq://");
  EXPECT_THROW(DenseModelerNode(*bus, o), std::invalid_argument);
}

}  // namespace
}  // namespace objscan
