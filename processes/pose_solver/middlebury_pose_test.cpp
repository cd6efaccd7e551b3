// Real wide-baseline images: Middlebury templeSparseRing and dinoSparseRing (16 calibrated views on a ring, ~22.5 deg
// apart, ../shared/data/middlebury_* (common/test_data.h), see SOURCE.txt there). KLT cannot bridge such steps; the
// descriptor tracker (processes/tracker/descriptor_seeding.h, SIFT) makes the tracks, the PoseEstimator runs on them
// with the given K and no odometry (scale free), and the result is compared with the given calibration after a Sim(3)
// alignment of the camera centres. The calibration is used ONLY for the evaluation (and its K as the known intrinsics).
// Ring order: dino = file order; temple = the azimuth order listed in its SOURCE.txt (gantry angles; the file order
// jumps around the ring). The ring is started right after its weakest link (fewest F-RANSAC inliers between
// neighbours, from the images alone). Loop closure (last view next to the first) is not used.
// Reported per set: frames posed, camera-centre error RMSE / max in % of the ring radius (mean distance of the true
// centres from their centroid), rotation error mean / max (deg), final reprojection RMS. Skipped without the data.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "common/geometry.h"
#include "common/test_data.h"
#include "drivers/camera/frame_source.h"
#include "processes/pose_solver/pose_estimator.h"
#include "processes/tracker/descriptor_seeding.h"

namespace objscan {
namespace {

std::string DataDir(const std::string& name) { return SharedDataPath(name); }

struct RingFigures {
  int views = 0;
  int posed = 0;
  double radius_mm = 0;
  double centre_rmse_pct = 0, centre_max_pct = 0;  // % of the ring radius
  double rot_mean_deg = 0, rot_max_deg = 0;
  double reprojection_rms_px = 0;  // over the final inlier observations of the posed frames
  double truth_rms_px = 0;         // same tracks triangulated with the GIVEN calibration: median track RMS (the
                                   // consistency of the calibration with the image content)
  double seconds = 0;
  std::string message;
};

// Ring rotation from the images alone: matches every consecutive pair of the ring (including last -> first) with the
// descriptor tracker and returns the ring order started right after the pair with the fewest F-RANSAC inliers, so
// that the weakest link of the ring falls at the (unused) loop closure. *weakest: that pair's inliers.
std::vector<int> StartAfterWeakestLink(const std::string& dir, const std::vector<MiddleburyView>& views,
                                       const std::vector<int>& order, const DescriptorTrackerOptions& options,
                                       int* weakest) {
  DescriptorTrackerOptions o = options;
  o.history_frames = 1;
  DescriptorTracker tracker(o);
  const int n = static_cast<int>(order.size());
  int best = 0;
  *weakest = std::numeric_limits<int>::max();
  for (int i = 0; i <= n; ++i) {
    ImageFrame frame;
    frame.image = cv::imread(dir + "/" + views.at(order[i % n] - 1).image_name, cv::IMREAD_GRAYSCALE);
    frame.seq = i;
    tracker.Track(frame);
    if (i == 0) continue;
    const auto& inl = tracker.last_stats().inliers;
    const int links = inl.empty() ? 0 : inl[0];
    std::printf("  link %s -> %s: %d inliers\n", views.at(order[i - 1] - 1).image_name.c_str(),
                views.at(order[i % n] - 1).image_name.c_str(), links);
    if (links < *weakest) {
      *weakest = links;
      best = i % n;
    }
  }
  std::vector<int> rotated;
  for (int i = 0; i < n; ++i) rotated.push_back(order[(best + i) % n]);
  return rotated;
}

// ring: 1-based view numbers (positions in the *_par.txt) in ring order (any start).
bool RunRing(const std::string& dir, const std::string& par_name, const std::vector<int>& ring, RingFigures* fig,
             std::string* why) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<MiddleburyView> views;
  if (!ReadMiddleburyPar(dir + "/" + par_name, &views, why)) return false;
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = views[0].K(0, 0);
  camera.fy = views[0].K(1, 1);
  camera.cx = views[0].K(0, 2);
  camera.cy = views[0].K(1, 2);
  camera.skew = views[0].K(0, 1);
  // Tracks: SIFT (AKAZE posed 13/16 temple views at 3.5 % / 2.9 deg, ORB initialized on neither set), a low
  // contrast threshold for the weakly textured objects, the 1500 strongest keypoints, the frame two back matched too.
  DescriptorTrackerOptions to;
  to.kind = DescriptorKind::kSift;
  to.sift_contrast_threshold = 0.005;
  to.max_features = 1500;
  to.history_frames = 2;
  // Poses: no odometry, no floor (scale free). Short tracks (2-4 views): every view is a keyframe, landmarks from 2
  // views, PnP accepted from 8 inliers, and a frame that sees too few landmarks is posed from the essential matrix
  // with the previous view (scale from >= 3 landmarks). No restart after a loss: without odometry a new map could
  // not be chained to the old one (and one Sim(3) could not evaluate both).
  PoseEstimatorOptions po;
  po.model = MotionModel::kSixDof;
  po.use_floor_for_scale = false;
  po.refine_scale_with_odometry = false;
  po.online_scale_frames = 0;
  po.keyframe_interval = 1;
  po.min_triangulation_views = 2;
  po.pnp.min_inliers = 8;
  po.two_view_min_matches = 20;
  po.two_view_min_landmarks = 3;
  po.relocalize_after_lost_frames = 1000;
  int weakest = 0;
  const std::vector<int> order = StartAfterWeakestLink(dir, views, ring, to, &weakest);
  std::printf("  start at %s (weakest link %d inliers)\n", views.at(order[0] - 1).image_name.c_str(), weakest);
  DescriptorTracker tracker(to);
  PoseEstimator estimator(camera, po);
  std::vector<Eigen::Isometry3d> truth;
  std::vector<TrackFrame> all_tracks;
  for (size_t i = 0; i < order.size(); ++i) {
    const MiddleburyView& v = views.at(order[i] - 1);
    ImageFrame frame;
    frame.image = cv::imread(dir + "/" + v.image_name, cv::IMREAD_GRAYSCALE);
    if (frame.image.empty()) {
      *why = "cannot read " + v.image_name;
      return false;
    }
    frame.seq = static_cast<int64_t>(i);
    frame.utime = static_cast<int64_t>(i) * 1000000;
    const TrackFrame tracks = tracker.Track(frame);
    const DescriptorTrackStats& s = tracker.last_stats();
    std::printf("  %s: %d keypoints (%.0f + %.0f ms), continued %d (bridged %d), F inliers prev %d / two back %d, ",
                v.image_name.c_str(), s.keypoints, s.detect_ms, s.match_ms, s.continued, s.bridged,
                s.inliers.size() > 0 ? s.inliers[0] : -1, s.inliers.size() > 1 ? s.inliers[1] : -1);
    int known = 0;
    {
      std::set<int64_t> lm;
      for (const Landmark& l : estimator.Landmarks()) lm.insert(l.id);
      for (const auto& t : tracks.features) known += lm.count(t.id) ? 1 : 0;
    }
    all_tracks.push_back(tracks);
    const FrameResult r = estimator.AddFrame(tracks, nullptr);
    std::printf("landmarks seen %d, status %d, inliers %d\n", known, static_cast<int>(r.pose.status),
                r.pose.num_inliers);
    truth.push_back(v.WorldFromCamera(1000.0));
  }
  const std::vector<CameraPoseEstimate> final_poses = estimator.Finish();
  {
    // Tracks seen in >= 3 views triangulated with the true cameras (no gating): median per-track RMS.
    std::map<int64_t, std::vector<std::pair<int, Eigen::Vector2d>>> obs;
    for (size_t f = 0; f < all_tracks.size(); ++f)
      for (const auto& t : all_tracks[f].features)
        obs[t.id].emplace_back(static_cast<int>(f), Eigen::Vector2d(t.u, t.v));
    TriangulationOptions tr;
    tr.min_parallax_deg = 1.0;
    tr.max_reprojection_px = 1e9;
    std::vector<double> rms;
    for (const auto& [id, o] : obs) {
      if (o.size() < 3) continue;
      std::vector<Eigen::Isometry3d> poses;
      std::vector<Eigen::Vector2d> px;
      for (const auto& [f, p] : o) {
        poses.push_back(truth[f]);
        px.push_back(p);
      }
      TriangulatedPoint tp;
      if (TriangulatePoint(camera, poses, px, tr, &tp)) rms.push_back(tp.rms_px);
    }
    if (!rms.empty()) {
      std::nth_element(rms.begin(), rms.begin() + rms.size() / 2, rms.end());
      fig->truth_rms_px = rms[rms.size() / 2];
    }
    std::printf("  %zu tracks of >= 3 views triangulated with the given calibration: median RMS %.3f px\n", rms.size(),
                fig->truth_rms_px);
  }
  fig->message = estimator.last_message();
  fig->views = static_cast<int>(order.size());
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& t : truth) centroid += t.translation();
  centroid /= static_cast<double>(truth.size());
  for (const auto& t : truth) fig->radius_mm += (t.translation() - centroid).norm() / truth.size();
  std::vector<Eigen::Isometry3d> est, tru;
  double sq = 0;
  int obs = 0;
  for (size_t f = 0; f < final_poses.size(); ++f) {
    const CameraPoseEstimate& p = final_poses[f];
    if (p.status != PoseStatus::kTracking && p.status != PoseStatus::kRelocalized) continue;
    est.push_back(p.world_from_camera);
    tru.push_back(truth[f]);
    sq += p.reprojection_rms_px * p.reprojection_rms_px * p.num_inliers;
    obs += p.num_inliers;
  }
  fig->posed = static_cast<int>(est.size());
  fig->reprojection_rms_px = obs > 0 ? std::sqrt(sq / obs) : 0;
  TrajectoryError err;
  if (!EvaluateTrajectory(est, tru, true, &err)) {
    *why = "fewer than 3 posed frames (" + std::to_string(est.size()) + "): " + fig->message;
    return false;
  }
  for (size_t i = 0; i < est.size(); ++i) {
    const Eigen::Isometry3d a = err.alignment.Apply(est[i]);
    std::printf("    posed %zu: centre error %.3f %%, rotation error %.3f deg\n", i,
                100 * (a.translation() - tru[i].translation()).norm() / fig->radius_mm,
                RotationAngle(a.linear().transpose() * tru[i].linear()) * 180 / M_PI);
  }
  fig->centre_rmse_pct = 100 * err.ate_rmse / fig->radius_mm;
  fig->centre_max_pct = 100 * err.ate_max / fig->radius_mm;
  fig->rot_mean_deg = err.rotation_mean_rad * 180 / M_PI;
  fig->rot_max_deg = err.rotation_max_rad * 180 / M_PI;
  fig->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "%s: posed %d/%d, ring radius %.1f mm, camera centre error RMSE %.3f %% max %.3f %% of the radius, "
      "rotation error mean %.3f deg max %.3f deg, reprojection RMS %.3f px, %.1f s\n  %s\n",
      par_name.c_str(), fig->posed, fig->views, fig->radius_mm, fig->centre_rmse_pct, fig->centre_max_pct,
      fig->rot_mean_deg, fig->rot_max_deg, fig->reprojection_rms_px, fig->seconds, fig->message.c_str());
  return true;
}

TEST(MiddleburyRing, TempleSparseRing) {
  const std::string dir = DataDir("middlebury_templeSparseRing");
  if (!cv::haveImageReader(dir + "/templeSR0001.png")) GTEST_SKIP() << "no data at " << dir;
  // Azimuth order from SOURCE.txt (views 1 and 11 are the same viewpoint).
  const std::vector<int> order = {9, 8, 7, 6, 15, 16, 12, 13, 5, 4, 3, 14, 2, 1, 11, 10};
  RingFigures fig;
  std::string why;
  ASSERT_TRUE(RunRing(dir, "templeSR_par.txt", order, &fig, &why)) << why;
  // Measured: 16/16 posed, centre RMSE 0.41 % (max 0.90 %) of the 561 mm radius, rotation 0.22 deg mean (max 0.59),
  // reprojection RMS 0.21 px (the given calibration reprojects the same tracks at a median 0.19 px). The residual
  // error is the bas-relief-like rotation / centre trade-off of short tracks on a small object (no loop closure).
  EXPECT_EQ(fig.posed, 16);
  EXPECT_LE(fig.centre_rmse_pct, 0.5);
  EXPECT_LE(fig.centre_max_pct, 1.1);
  EXPECT_LE(fig.rot_mean_deg, 0.3);
  EXPECT_LE(fig.rot_max_deg, 0.75);
  EXPECT_LE(fig.reprojection_rms_px, 0.3);
}

TEST(MiddleburyRing, DinoSparseRing) {
  const std::string dir = DataDir("middlebury_dinoSparseRing");
  if (!cv::haveImageReader(dir + "/dinoSR0001.png")) GTEST_SKIP() << "no data at " << dir;
  std::vector<int> order;
  for (int i = 1; i <= 16; ++i) order.push_back(i);
  RingFigures fig;
  std::string why;
  ASSERT_TRUE(RunRing(dir, "dinoSR_par.txt", order, &fig, &why)) << why;
  // Measured: 7/16 posed (views 7..13): the untextured dino gives no F-RANSAC-consistent matches between views 5-6
  // and 6-7 (the ring is started after that break) and 20-30 between 12-13-14-15, too few landmarks seen in 14 to
  // fix the step's scale. Of the posed views: centre RMSE 0.45 % (max 0.84 %) of the 632 mm radius, rotation 0.29 deg
  // mean (max 0.69), reprojection RMS 0.43 px (the given calibration: median 0.47 px on the same tracks).
  EXPECT_GE(fig.posed, 7);
  EXPECT_LE(fig.centre_rmse_pct, 0.6);
  EXPECT_LE(fig.centre_max_pct, 1.0);
  EXPECT_LE(fig.rot_mean_deg, 0.4);
  EXPECT_LE(fig.rot_max_deg, 0.85);
  EXPECT_LE(fig.reprojection_rms_px, 0.55);
}

}  // namespace
}  // namespace objscan
