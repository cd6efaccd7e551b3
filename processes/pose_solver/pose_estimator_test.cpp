#include "processes/pose_solver/pose_estimator.h"

#include <algorithm>
#include <gtest/gtest.h>

#include <map>

#include <cstdio>

#include "common/geometry.h"
#include "processes/pose_solver/synthetic_orbit.h"

namespace objscan {
namespace {

struct RunFigures {
  TrajectoryError online, final_error;
  int online_tracked = 0, final_posed = 0;
  double scale_error_final = 1;  // |scale of the SE(3)-free alignment - 1|
  ScaleSource scale_source = ScaleSource::kNone;
  int landmarks = 0;
  size_t memory_bytes = 0;                         // PoseEstimator::ApproxMemoryBytes before Finish
  size_t memory_bytes_half = 0;                    // the same after half of the frames
  double mean_observations = 0;                    // Landmark::num_observations, mean over the final landmarks
  std::vector<std::pair<int64_t, int64_t>> fused;  // PoseEstimator::FusedTrackIds
  double final_bend_fraction = -1;                 // PoseEstimator::final_bend_fraction
  bool final_ba_dropped = false;
};

// with_odometry false: images only (AddFrame without odometry). final_heights_error_mm: max over the final poses of
// |estimated - true| camera height, without any alignment (the world's floor z = 0 in both).
// height_ratios: estimated / true camera height of every final pose (a levelled world at any scale: all equal).
RunFigures RunOrbit(const SyntheticOrbit& s, const PoseEstimatorOptions& options, bool with_odometry = true,
                    double* final_heights_error_mm = nullptr, std::vector<double>* height_ratios = nullptr) {
  PoseEstimator estimator(s.camera, options);
  std::vector<Eigen::Isometry3d> online_est, online_true;
  size_t memory_half = 0;
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const FrameResult r = estimator.AddFrame(s.frames[f], with_odometry ? &s.odometry[f] : nullptr);
    if (f + 1 == s.frames.size() / 2) memory_half = estimator.ApproxMemoryBytes();
    if (r.pose.status == PoseStatus::kTracking || r.pose.status == PoseStatus::kRelocalized) {
      online_est.push_back(r.pose.world_from_camera);
      online_true.push_back(s.world_from_camera[f]);
    }
  }
  RunFigures fig;
  fig.memory_bytes = estimator.ApproxMemoryBytes();
  fig.memory_bytes_half = memory_half;
  fig.online_tracked = static_cast<int>(online_est.size());
  EvaluateTrajectory(online_est, online_true, true, &fig.online);
  const std::vector<CameraPoseEstimate> final_poses = estimator.Finish();
  fig.final_bend_fraction = estimator.final_bend_fraction();
  fig.final_ba_dropped = estimator.final_ba_dropped();
  std::vector<Eigen::Isometry3d> fe, ft;
  for (size_t f = 0; f < final_poses.size(); ++f) {
    if (final_poses[f].status != PoseStatus::kTracking && final_poses[f].status != PoseStatus::kRelocalized) continue;
    fe.push_back(final_poses[f].world_from_camera);
    ft.push_back(s.world_from_camera[f]);
    if (height_ratios) height_ratios->push_back(fe.back().translation().z() / ft.back().translation().z());
    if (final_heights_error_mm)
      *final_heights_error_mm =
          std::max(*final_heights_error_mm, std::abs(fe.back().translation().z() - ft.back().translation().z()));
  }
  fig.final_posed = static_cast<int>(fe.size());
  EvaluateTrajectory(fe, ft, true, &fig.final_error);
  fig.scale_error_final = std::abs(fig.final_error.scale - 1.0);
  fig.scale_source = estimator.scale_source();
  const std::vector<Landmark> landmarks = estimator.Landmarks();
  fig.landmarks = static_cast<int>(landmarks.size());
  fig.fused = estimator.FusedTrackIds();
  for (const Landmark& l : landmarks)
    fig.mean_observations += l.num_observations / std::max<double>(1, landmarks.size());
  std::printf(
      "tracked %d online ATE %.3f mm (max %.3f, scale %.4f) | final posed %d ATE %.3f mm (rot %.4f deg, "
      "scale %.4f) | landmarks %d, keyframes %d, init %.1f ms, final %.1f ms\n  %s\n",
      fig.online_tracked, fig.online.ate_rmse, fig.online.ate_max, fig.online.scale, fig.final_posed,
      fig.final_error.ate_rmse, fig.final_error.rotation_mean_rad * 180 / M_PI, fig.final_error.scale, fig.landmarks,
      estimator.num_keyframes(), estimator.init_ms(), estimator.final_ba_ms(), estimator.last_message().c_str());
  return fig;
}

TEST(PoseEstimator, SixDofOrbitWithOdometryScale) {
  SyntheticOrbitOptions so;
  so.odometry_scale_error = 0.005;  // the odometry-only scale is as good as the odometry
  so.pan_bias_rad = 0.5 * M_PI / 180;
  so.tilt_bias_rad = 0.5 * M_PI / 180;
  so.odometry_heading_drift_rad_per_frame = 0.0005;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.model = MotionModel::kSixDof;
  o.use_floor_for_scale = false;
  const RunFigures fig = RunOrbit(s, o);
  EXPECT_GE(fig.online_tracked, 170);
  EXPECT_LE(fig.online.ate_rmse, 2.0);
  EXPECT_EQ(fig.final_posed, 200);
  EXPECT_LE(fig.final_error.ate_rmse, fig.online.ate_rmse);
  EXPECT_LE(fig.scale_error_final, 0.01);
  EXPECT_LE(std::abs(fig.online.scale - 1.0), 0.01);
  EXPECT_EQ(fig.scale_source, ScaleSource::kOdometry);
}

// Images only (no odometry), a camera height configured: the world starts as the first camera's frame, the floor
// found among the first landmarks levels it (floor z = 0, +z up) and gives it metric scale. Before, a plane facing
// the camera passed for the floor (the floor search took the first camera's optical axis for up): the image-only
// sphere orbit came out 1.62x too large while its files said mm.
TEST(PoseEstimator, SixDofOrbitWithoutOdometryIsLevelledAndScaledByTheFloor) {
  SyntheticOrbitOptions so;
  so.outlier_fraction = 0.02;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.model = MotionModel::kSixDof;
  double heights_error_mm = 0;
  const RunFigures fig = RunOrbit(s, o, false, &heights_error_mm);
  std::printf("images only: camera heights within %.3f mm of the truth (no alignment)\n", heights_error_mm);
  EXPECT_GE(fig.online_tracked, 170);
  EXPECT_LE(fig.online.ate_rmse, 2.0);
  EXPECT_LE(std::abs(fig.online.scale - 1.0), 0.01);
  EXPECT_EQ(fig.final_posed, 200);
  EXPECT_LE(fig.scale_error_final, 0.01);
  EXPECT_EQ(fig.scale_source, ScaleSource::kCameraHeight);
  EXPECT_LE(heights_error_mm, 5.0);
}

// Images only and no known camera height (an image folder): the floor still levels the world (every camera at the
// same multiple of its true height), the scale stays arbitrary and is reported so.
TEST(PoseEstimator, SixDofOrbitWithoutOdometryOrCameraHeightIsLevelledNotScaled) {
  SyntheticOrbitOptions so;
  so.outlier_fraction = 0.02;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.model = MotionModel::kSixDof;
  o.camera_height_known = false;
  std::vector<double> ratios;
  const RunFigures fig = RunOrbit(s, o, false, nullptr, &ratios);
  ASSERT_FALSE(ratios.empty());
  const auto [lo, hi] = std::minmax_element(ratios.begin(), ratios.end());
  std::printf("images only, height unknown: estimated / true camera height %.4f .. %.4f, alignment scale %.4f\n",
              *lo, *hi, fig.final_error.scale);
  EXPECT_EQ(fig.final_posed, 200);
  EXPECT_LE(fig.online.ate_rmse, 2.0);
  EXPECT_EQ(fig.scale_source, ScaleSource::kNone);
  EXPECT_GT(*lo, 0);
  EXPECT_LE(*hi / *lo, 1.01);  // levelled: one ratio for all (the camera's true height is constant)
}

// The robot simulator's odometry: 2 % slip, heading drift, 0.5 deg pan/tilt biases. The floor plane + camera height
// give the scale in 6-DOF too.
TEST(PoseEstimator, SixDofOrbitWithCameraHeightScale) {
  SyntheticOrbitOptions so;
  so.odometry_scale_error = 0.02;
  so.pan_bias_rad = 0.5 * M_PI / 180;
  so.tilt_bias_rad = 0.5 * M_PI / 180;
  so.odometry_heading_drift_rad_per_frame = 0.001;
  so.outlier_fraction = 0.02;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.model = MotionModel::kSixDof;
  const RunFigures fig = RunOrbit(s, o);
  EXPECT_GE(fig.online_tracked, 170);
  EXPECT_LE(fig.online.ate_rmse, 2.0);
  EXPECT_EQ(fig.final_posed, 200);
  EXPECT_LE(fig.final_error.ate_rmse, fig.online.ate_rmse);
  EXPECT_LE(fig.scale_error_final, 0.01);
  EXPECT_LE(std::abs(fig.online.scale - 1.0), 0.01);
  EXPECT_EQ(fig.scale_source, ScaleSource::kCameraHeight);
}

TEST(PoseEstimator, FourDofOrbitWithCameraHeightScale) {
  SyntheticOrbitOptions so;
  so.odometry_scale_error = 0.02;
  so.pan_bias_rad = 0.5 * M_PI / 180;
  so.tilt_bias_rad = 0.5 * M_PI / 180;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.model = MotionModel::kFourDof;
  const RunFigures fig = RunOrbit(s, o);
  EXPECT_GE(fig.online_tracked, 170);
  EXPECT_LE(fig.online.ate_rmse, 2.0);
  EXPECT_EQ(fig.final_posed, 200);
  EXPECT_LE(fig.final_error.ate_rmse, fig.online.ate_rmse);
  EXPECT_LE(fig.scale_error_final, 0.01);
  EXPECT_LE(std::abs(fig.online.scale - 1.0), 0.01);
  EXPECT_EQ(fig.scale_source, ScaleSource::kCameraHeight);
}

}  // namespace
}  // namespace objscan

namespace objscan {
namespace {

// The robot simulator's odometry errors: 2 % slip, heading drift, 0.5 deg pan/tilt biases.
SyntheticOrbitOptions SimLikeOdometryErrors() {
  SyntheticOrbitOptions so;
  so.odometry_scale_error = 0.02;
  so.pan_bias_rad = 0.5 * M_PI / 180;
  so.tilt_bias_rad = 0.5 * M_PI / 180;
  so.odometry_heading_drift_rad_per_frame = 0.001;
  return so;
}

// Features vanish for 15 frames: the estimator reports LOST (num_inliers 0, last good pose); when features return
// (every track has a new id) it finds the old map by position (relocalize_search_px > 0), or else restarts the
// preliminary phase, chains the new map through odometry and joins it to the old one by the landmarks both saw
// (Sim(3)); either way it reports RELOCALIZED. Returns the final ATE (mm).
double RunLostOrbit(const PoseEstimatorOptions& o, std::string* notices = nullptr, int lost_end = 95) {
  SyntheticOrbitOptions so = SimLikeOdometryErrors();
  so.lost_begin = 80;
  so.lost_end = lost_end;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimator est(s.camera, o);
  int lost = 0, relocalized = 0, tracking_after = 0;
  std::string join_message;
  Eigen::Isometry3d last_good = Eigen::Isometry3d::Identity();
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const FrameResult r = est.AddFrame(s.frames[f], &s.odometry[f]);
    if (r.initialized_now && f > 95) join_message = est.last_message();
    if (r.initialized_now && f > 95 && notices) *notices += est.last_message() + "\n";
    const std::string notice = est.TakeNotice();
    if (notices && !notice.empty()) *notices += notice + "\n";
    if (r.pose.status == PoseStatus::kTracking && f < 80) last_good = r.pose.world_from_camera;
    if (r.pose.status == PoseStatus::kLost) {
      ++lost;
      EXPECT_EQ(r.pose.num_inliers, 0);
      if (f < 95) {
        EXPECT_TRUE(r.pose.world_from_camera.isApprox(last_good, 1e-12)) << f;
      }
    }
    if (r.pose.status == PoseStatus::kRelocalized) ++relocalized;
    if (f > 120 && r.pose.status == PoseStatus::kTracking) ++tracking_after;
  }
  EXPECT_GE(lost, so.lost_end - so.lost_begin);
  EXPECT_GE(relocalized, 1);
  EXPECT_GE(tracking_after, 70);
  const std::vector<CameraPoseEstimate> fin = est.Finish();
  std::vector<Eigen::Isometry3d> e, t;
  for (size_t f = 0; f < fin.size(); ++f)
    if (fin[f].status == PoseStatus::kTracking || fin[f].status == PoseStatus::kRelocalized) {
      e.push_back(fin[f].world_from_camera);
      t.push_back(s.world_from_camera[f]);
    }
  TrajectoryError err;
  EXPECT_TRUE(EvaluateTrajectory(e, t, true, &err));
  std::printf("after loss (%s, join search %.0f mm): %zu posed, ATE %.2f mm, scale %.4f\n  %s\n",
              o.model == MotionModel::kFourDof ? "4-DOF" : "6-DOF", o.join_search_mm, e.size(), err.ate_rmse, err.scale,
              join_message.c_str());
  return err.ate_rmse;
}

// Every track ends at once (one blank frame, then KLT ids never come back): the frame after is relocalized by
// position (its new tracks paired with the landmarks projected from the odometry's prediction), no new map starts,
// and the orbit is as accurate as one without the loss.
TEST(PoseEstimator, AllTracksEndingAtOnceIsRelocalizedByPosition) {
  PoseEstimatorOptions o;
  ASSERT_GT(o.relocalize_search_px, 0);
  std::string notices;
  const double relocalized = RunLostOrbit(o, &notices, 81);
  EXPECT_NE(notices.find("relocalized frame 81 by position"), std::string::npos) << notices;
  EXPECT_EQ(notices.find("initialized"), std::string::npos) << notices;
  o.relocalize_search_px = 0;
  o.join_search_mm = 0;  // a new map chained through odometry only
  const double chained = RunLostOrbit(o, nullptr, 81);
  EXPECT_LT(relocalized, 0.5);  // mm
  EXPECT_LT(relocalized, 0.5 * chained);
}

// Lost for 15 frames: a new map starts. Without the 3-D join (join_search_mm 0), it is joined by position: the old
// landmarks projected from the span's last pose (chained through the odometry) pair with its tracks, and the new map
// moves to that frame's pose against the old map. Better than the odometry chaining alone, not as good as the 3-D join
// (0.22 mm below), which is tried first.
TEST(PoseEstimator, ARestartTheLandmarksCannotJoinIsJoinedByPosition) {
  PoseEstimatorOptions o;
  o.join_search_mm = 0;
  std::string notices;
  const double by_position = RunLostOrbit(o, &notices);
  EXPECT_NE(notices.find("joined to the old map by position"), std::string::npos) << notices;
  o.relocalize_search_px = 0;
  const double chained = RunLostOrbit(o);
  EXPECT_LT(by_position, 0.5 * chained);
}

// The joins below need a restart: relocalization by position is off.
TEST(PoseEstimator, LostTrackingRecoversAndJoinsTheMaps) {
  PoseEstimatorOptions o;
  o.relocalize_search_px = 0;
  ASSERT_GT(o.join_search_mm, 0);
  const double joined = RunLostOrbit(o);
  o.join_search_mm = 0;  // odometry chaining only
  const double chained = RunLostOrbit(o);
  // Chained through odometry (2 % slip, heading drift, pan/tilt bias) the maps disagree by millimetres; joined by
  // their common landmarks the whole orbit is as good as one without a loss.
  EXPECT_LT(joined, 0.5);  // mm
  EXPECT_LT(joined, 0.5 * chained);
  // The robot's 4-DOF model on the floor: the join moves x, y, yaw and the scale about the floor plane.
  o = PoseEstimatorOptions();
  o.relocalize_search_px = 0;
  o.model = MotionModel::kFourDof;
  const double joined_4dof = RunLostOrbit(o);
  o.join_search_mm = 0;
  const double chained_4dof = RunLostOrbit(o);
  EXPECT_LT(joined_4dof, 0.5);  // mm
  EXPECT_LT(joined_4dof, 0.5 * chained_4dof);
  // 4-DOF without the floor (odometry scale): still x, y, yaw only.
  o = PoseEstimatorOptions();
  o.relocalize_search_px = 0;
  o.model = MotionModel::kFourDof;
  o.use_floor_for_scale = false;
  const double joined_no_floor = RunLostOrbit(o);
  o.join_search_mm = 0;
  const double chained_no_floor = RunLostOrbit(o);
  EXPECT_LT(joined_no_floor, chained_no_floor);
}

// A restarted map with too few landmarks in common to join at its start (here: 200 needed, 173 shared) is joined at
// a later keyframe, once it has grown into what the old map saw (room_07: restarts sharing 5-10 landmarks at their
// start were never joined, and the model mixed frames).
TEST(PoseEstimator, AMapTooSmallToJoinAtItsStartJoinsLater) {
  PoseEstimatorOptions o;
  o.relocalize_search_px = 0;
  o.join_min_landmarks = 200;
  std::string notices;
  const double late = RunLostOrbit(o, &notices);
  EXPECT_NE(notices.find("joined to the old map"), std::string::npos) << notices;
  EXPECT_NE(notices.find("map restarted at frame 95"), std::string::npos) << notices;
  o.join_search_mm = 0;
  const double chained = RunLostOrbit(o);
  EXPECT_LT(late, 0.5 * chained);
  EXPECT_LT(late, 1.0);  // mm
}

// While a restarted map is not joined to the old one, Landmarks(true) (what the node publishes at keyframes) holds
// the new map's landmarks only: every track after the loss has a new id, so they are the ones with ids above every
// landmark of the old map. Once joined (late, here), the whole map again. The poses say which map they lie in
// (map_start_seq): the restart's first frame for the new map's, online and, when never joined, in the final poses;
// once joined, the final poses are all in the first map.
TEST(PoseEstimator, AnUnjoinedRestartIsAMapOfItsOwnInLandmarksAndPoses) {
  SyntheticOrbitOptions so = SimLikeOdometryErrors();
  so.lost_begin = 80;
  so.lost_end = 95;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  for (const int min_landmarks : {100000, 200}) {  // never joined; joined at a later keyframe
    PoseEstimatorOptions o;
    o.relocalize_search_px = 0;
    o.join_min_landmarks = min_landmarks;
    PoseEstimator est(s.camera, o);
    int64_t old_max_id = -1;
    size_t restarted_current = 0, restarted_all = 0;
    int64_t restart_seq = -1;  // map_start_seq of the restarted map's online poses
    for (size_t f = 0; f < s.frames.size(); ++f) {
      const FrameResult r = est.AddFrame(s.frames[f], &s.odometry[f]);
      if (f < 80) {  // no map yet: -1; then the first map
        EXPECT_EQ(r.pose.map_start_seq, r.pose.status == PoseStatus::kTracking ? s.frames[0].seq : -1) << f;
      }
      if (f == 110) {
        restart_seq = r.pose.map_start_seq;
        EXPECT_GE(restart_seq, s.frames[95].seq) << "the restarted map began after the loss";
        EXPECT_LE(restart_seq, s.frames[110].seq);
      }
      if (f == 79)
        for (const Landmark& l : est.Landmarks()) old_max_id = std::max(old_max_id, l.id);
      if (f == 110) {
        const std::vector<Landmark> current = est.Landmarks(true);
        restarted_current = current.size();
        restarted_all = est.Landmarks().size();
        for (const Landmark& l : current) EXPECT_GT(l.id, old_max_id) << "an old landmark in the new map's list";
      }
    }
    EXPECT_GT(restarted_current, 50u) << min_landmarks;
    EXPECT_LT(restarted_current, restarted_all) << min_landmarks;
    const size_t end_current = est.Landmarks(true).size(), end_all = est.Landmarks().size();
    if (min_landmarks == 200)
      EXPECT_EQ(end_current, end_all);  // joined
    else
      EXPECT_LT(end_current, end_all);  // still apart
    const std::vector<CameraPoseEstimate> fin = est.Finish();
    int first_map = 0, restarted_map = 0;
    for (const CameraPoseEstimate& p : fin) {
      if (p.status != PoseStatus::kTracking && p.status != PoseStatus::kRelocalized) continue;
      const bool in_first = p.map_start_seq == s.frames[0].seq;
      first_map += in_first;
      restarted_map += p.map_start_seq == restart_seq;
      // Before the loss: the first map; from the restart's span on: its own map (unless joined); the lost frames
      // between are registered at the end into the map of the neighbour they were posed from, either one.
      if (min_landmarks == 200 || p.seq < s.frames[80].seq) {
        EXPECT_TRUE(in_first) << "frame " << p.seq << " map " << p.map_start_seq;
      } else if (p.seq >= restart_seq) {
        EXPECT_EQ(p.map_start_seq, restart_seq) << "frame " << p.seq;
      } else {
        EXPECT_TRUE(in_first || p.map_start_seq == restart_seq) << "frame " << p.seq << " map " << p.map_start_seq;
      }
    }
    std::printf("join_min_landmarks %d: restart began at frame %lld; final poses in the first map %d, in the "
                "restarted map %d\n",
                min_landmarks, static_cast<long long>(restart_seq), first_map, restarted_map);
    EXPECT_GT(first_map, 70);
    if (min_landmarks != 200) {
      EXPECT_GT(restarted_map, 50);
    }
  }
}

// A map restarted through odometry while no floor is in view takes the odometry's scale over a short span (20 %
// slip here; room_05's closed loop: its floor 75 mm above the old one, a room of phantom obstacles for the planner).
// Once its keyframes see the floor, the camera height above it rescales the new map.
TEST(PoseEstimator, RestartWithoutFloorIsScaledByTheFloorLater) {
  SyntheticOrbitOptions so = SimLikeOdometryErrors();
  so.odometry_scale_error = 0.2;
  so.lost_begin = 80;
  so.lost_end = 95;
  so.floor_hidden_begin = 80;
  so.floor_hidden_end = 120;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.join_search_mm = 0;  // chained, never joined: the new map keeps the scale it was given
  PoseEstimator est(s.camera, o);
  std::string notice, restart;
  std::vector<Eigen::Vector3d> est_path, true_path;
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const FrameResult r = est.AddFrame(s.frames[f], &s.odometry[f]);
    if (r.initialized_now && f > 95) restart = est.last_message();
    const std::string n = est.TakeNotice();
    if (!n.empty()) notice = n;
    if (f >= 150 && (r.pose.status == PoseStatus::kTracking || r.pose.status == PoseStatus::kRelocalized)) {
      est_path.push_back(r.pose.world_from_camera.translation());
      true_path.push_back(s.world_from_camera[f].translation());
    }
  }
  ASSERT_GE(est_path.size(), 40u);
  double est_length = 0, true_length = 0;
  for (size_t i = 1; i < est_path.size(); ++i) {
    est_length += (est_path[i] - est_path[i - 1]).norm();
    true_length += (true_path[i] - true_path[i - 1]).norm();
  }
  const double scale = est_length / true_length;
  std::printf("restart: %s\n  notice: %s\n  online scale after the restart %.4f\n", restart.c_str(), notice.c_str(),
              scale);
  EXPECT_NE(restart.find("scale source 2"), std::string::npos) << "the span should have had no floor: " << restart;
  EXPECT_NE(notice.find("scaled by"), std::string::npos) << notice;
  EXPECT_NEAR(scale, 1.0, 0.02);
}

// The same restart, but its floor stays out of view beyond the first search (online_scale_frames): the odometry's
// 20 % scale error stayed for the rest of the run. While the map is not joined, its scale is measured again from the
// floor among all its landmarks at the late-join tries (room_02, 7 Dec: a restart 11 % off all run, never joined).
TEST(PoseEstimator, AnUnjoinedRestartIsRescaledWhenItsFloorComesIntoView) {
  SyntheticOrbitOptions so = SimLikeOdometryErrors();
  so.num_frames = 520;
  so.odometry_scale_error = 0.2;
  so.lost_begin = 80;
  so.lost_end = 95;
  so.floor_hidden_begin = 80;
  so.floor_hidden_end = 300;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  o.join_min_landmarks = 100000;  // never joined: the restarted map keeps its own scale
  o.relocalize_search_px = 0;
  PoseEstimator est(s.camera, o);
  std::string notices;
  // Online path length / true path length over frames [from, to): before the floor came into view and at the end.
  std::map<int, std::pair<Eigen::Vector3d, Eigen::Vector3d>> online;  // frame -> (estimated, true) position
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const FrameResult r = est.AddFrame(s.frames[f], &s.odometry[f]);
    const std::string n = est.TakeNotice();
    if (!n.empty()) notices += n + "\n";
    if (r.pose.status == PoseStatus::kTracking || r.pose.status == PoseStatus::kRelocalized)
      online[static_cast<int>(f)] = {r.pose.world_from_camera.translation(), s.world_from_camera[f].translation()};
  }
  const auto scale_over = [&](int from, int to) {
    double e = 0, t = 0;
    for (int f = from + 1; f < to; ++f)
      if (online.count(f) && online.count(f - 1)) {
        e += (online[f].first - online[f - 1].first).norm();
        t += (online[f].second - online[f - 1].second).norm();
      }
    return t > 0 ? e / t : 0.0;
  };
  const double before = scale_over(200, 290), after = scale_over(460, 520);
  std::printf("online scale of the unjoined restart: %.4f before its floor came into view, %.4f at the end\n  %s",
              before, after, notices.c_str());
  EXPECT_NE(notices.find("(not joined) rescaled by"), std::string::npos) << notices;
  EXPECT_GT(std::abs(before - 1.0), 0.05);  // the odometry's scale error over the restart's short span
  EXPECT_NEAR(after, 1.0, 0.02);
}

// The robot turns in place before it drives (as after a loss, when the planner turns towards a new path): a span of
// pure rotation has no depth, so the preliminary phase waits for the odometry to show travel instead of building a
// map on it.
TEST(PoseEstimator, WaitsForTravelBeforeInitializingOnATurnInPlace) {
  SyntheticOrbitOptions so = SimLikeOdometryErrors();
  so.turn_in_place_frames = 60;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  PoseEstimatorOptions o;
  PoseEstimator estimator(s.camera, o);
  int first_posed = -1;
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const FrameResult r = estimator.AddFrame(s.frames[f], &s.odometry[f]);
    if (first_posed < 0 && r.pose.status == PoseStatus::kTracking) {
      first_posed = static_cast<int>(f);
      std::printf("frame %zu: %s\n", f, estimator.last_message().c_str());
    }
  }
  EXPECT_GE(first_posed, 60);
  EXPECT_GE(estimator.span_first_frame(), 59);  // the span holds no frame of the turn (59 -> 60 is the first step)
  const std::vector<CameraPoseEstimate> final_poses = estimator.Finish();
  std::vector<Eigen::Isometry3d> e, t;
  for (size_t f = 60; f < final_poses.size(); ++f) {
    if (final_poses[f].status != PoseStatus::kTracking && final_poses[f].status != PoseStatus::kRelocalized) continue;
    e.push_back(final_poses[f].world_from_camera);
    t.push_back(s.world_from_camera[f]);
  }
  TrajectoryError err;
  EXPECT_TRUE(EvaluateTrajectory(e, t, true, &err));
  std::printf("orbit after the turn: %zu posed, ATE %.3f mm, scale %.4f\n", e.size(), err.ate_rmse, err.scale);
  EXPECT_GE(e.size(), 190u);
  EXPECT_LT(err.ate_rmse, 1.0);  // mm
  EXPECT_LT(std::abs(err.scale - 1.0), 0.01);
}

// Non-keyframes drop their observations 30 frames after they were posed (the default): the estimator then holds
// about a third of the memory, and the final poses (which follow the keyframes for those frames) are as accurate as
// with every frame's observations kept for a pose refit after the final BA.
TEST(PoseEstimator, DroppingOldObservationsKeepsTheFinalAccuracy) {
  const SyntheticOrbit s = MakeSyntheticOrbit(SimLikeOdometryErrors());
  PoseEstimatorOptions o;
  ASSERT_GT(o.observations_kept_frames, 0);
  const RunFigures dropped = RunOrbit(s, o);
  o.observations_kept_frames = 0;
  const RunFigures kept = RunOrbit(s, o);
  EXPECT_EQ(dropped.final_posed, 200);
  EXPECT_LE(dropped.final_error.ate_rmse, 1.1 * kept.final_error.ate_rmse + 0.02);  // mm
  EXPECT_LE(dropped.final_error.rotation_mean_rad, 1.1 * kept.final_error.rotation_mean_rad + 0.002 * M_PI / 180);
  EXPECT_LT(dropped.memory_bytes, kept.memory_bytes / 2);
  // Landmark observation counts still include the dropped observations.
  EXPECT_GT(dropped.mean_observations, 0.9 * kept.mean_observations);
  EXPECT_GT(kept.mean_observations, 10.0);
  std::printf("mean observations per landmark: %.1f with old observations dropped, %.1f with all kept\n",
              dropped.mean_observations, kept.mean_observations);
  std::printf("estimator memory: %.0f kB with old observations dropped, %.0f kB with all kept\n",
              dropped.memory_bytes / 1024.0, kept.memory_bytes / 1024.0);
  PoseEstimatorOptions bad;
  bad.global_ba_all_frames = true;  // needs every frame's observations
  std::string why;
  EXPECT_FALSE(ValidatePoseEstimatorOptions(bad, &why));
  bad.observations_kept_frames = 0;
  EXPECT_FALSE(ValidatePoseEstimatorOptions(bad, &why));
  bad.max_active_keyframes = 0;
  EXPECT_TRUE(ValidatePoseEstimatorOptions(bad, &why)) << why;
}

// Only the last max_active_keyframes keyframes keep their observations (bounded memory on long streams): the final
// BA adjusts them with the two oldest held, the frozen ones stay where the windowed BA left them.
TEST(PoseEstimator, FrozenKeyframesBoundTheMemory) {
  const SyntheticOrbit s = MakeSyntheticOrbit(SimLikeOdometryErrors());
  PoseEstimatorOptions o;
  const RunFigures all_active = RunOrbit(s, o);  // 40 keyframes < max_active_keyframes
  o.max_active_keyframes = 12;
  const RunFigures bounded = RunOrbit(s, o);
  EXPECT_EQ(bounded.final_posed, 200);
  EXPECT_LE(bounded.final_error.ate_rmse, bounded.online.ate_rmse);
  // The global BA was checked (frozen keyframes) and kept: it refines the map, it does not bend it.
  EXPECT_FALSE(bounded.final_ba_dropped);
  EXPECT_GE(bounded.final_bend_fraction, 0.0);
  EXPECT_LT(bounded.final_bend_fraction, kMaxFinalBendFraction);
  EXPECT_LT(all_active.final_bend_fraction, 0.0);  // no frozen keyframe: not checked
  // Memory growth over the second half of the orbit (100 frames, 20 keyframes): flat once 12 keyframes are active.
  const double growth_bounded = (double(bounded.memory_bytes) - double(bounded.memory_bytes_half)) / 100 / 1024;
  const double growth_all = (double(all_active.memory_bytes) - double(all_active.memory_bytes_half)) / 100 / 1024;
  std::printf(
      "final ATE %.3f mm with 12 active keyframes, %.3f mm with all; estimator memory growth %.2f / %.2f "
      "kB per frame\n",
      bounded.final_error.ate_rmse, all_active.final_error.ate_rmse, growth_bounded, growth_all);
  EXPECT_LT(growth_bounded, 2.0);               // kB per frame: poses (and a frames_ reallocation), new landmarks
  EXPECT_GT(growth_all, growth_bounded + 3.0);  // 20 keyframes x ~1000 observations
}

TEST(MapBendFraction, ZeroForASimilarityLargeForABend) {
  // 40 camera centres on a 1 m circle; moved as a whole, then with a 10 mm sag over a quarter of it.
  std::vector<Eigen::Vector3d> before, moved, bent;
  Sim3 sim;
  sim.scale = 1.2;
  sim.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
  sim.translation = Eigen::Vector3d(300, -50, 20);
  for (int i = 0; i < 40; ++i) {
    const double a = 2 * M_PI * i / 40;
    before.emplace_back(1000 * std::cos(a), 1000 * std::sin(a), 400);
    moved.push_back(sim * before.back());
    bent.push_back(before.back() + Eigen::Vector3d(0, 0, i < 10 ? -10.0 * std::sin(M_PI * i / 10) : 0.0));
  }
  EXPECT_NEAR(MapBendFraction(before, moved), 0.0, 1e-9);
  // 10 of 40 centres sag: the p90 offset after the best similarity is a few mm, well over the limit (1 m spread:
  // 1 mm).
  const double bend = MapBendFraction(before, bent);
  EXPECT_GT(bend, kMaxFinalBendFraction);
  EXPECT_LT(bend, 0.01);
  // Too few centres, or none spread: not measured.
  EXPECT_LT(MapBendFraction({before.begin(), before.begin() + 9}, {moved.begin(), moved.begin() + 9}), 0.0);
  EXPECT_LT(MapBendFraction(std::vector<Eigen::Vector3d>(12, Eigen::Vector3d(1, 2, 3)),
                            std::vector<Eigen::Vector3d>(12, Eigen::Vector3d(1, 2, 3))),
            0.0);
}

TEST(PoseEstimator, DeterministicOutput) {
  SyntheticOrbitOptions so;
  so.num_frames = 60;
  so.outlier_fraction = 0.02;
  const SyntheticOrbit s = MakeSyntheticOrbit(so);
  std::vector<std::vector<CameraPoseEstimate>> runs;
  for (int k = 0; k < 2; ++k) {
    PoseEstimator est(s.camera, PoseEstimatorOptions());
    for (size_t f = 0; f < s.frames.size(); ++f) est.AddFrame(s.frames[f], &s.odometry[f]);
    runs.push_back(est.Finish());
  }
  ASSERT_EQ(runs[0].size(), runs[1].size());
  for (size_t f = 0; f < runs[0].size(); ++f)
    EXPECT_TRUE(runs[0][f].world_from_camera.matrix() == runs[1][f].world_from_camera.matrix()) << f;
}

}  // namespace
}  // namespace objscan
