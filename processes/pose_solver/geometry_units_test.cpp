// Unit tests of bundle_adjustment, pnp and triangulation on the synthetic orbit (known truth).
#include <gtest/gtest.h>

#include <random>

#include "common/geometry.h"
#include "processes/pose_solver/bundle_adjustment.h"
#include "processes/pose_solver/pnp.h"
#include "processes/pose_solver/synthetic_orbit.h"
#include "processes/pose_solver/triangulation.h"

namespace objscan {
namespace {

SyntheticOrbit Scene(double noise = 0.3, double outliers = 0.0) {
  SyntheticOrbitOptions o;
  o.num_frames = 60;
  o.orbit_fraction = 0.3;
  o.noise_px = noise;
  o.dropout_per_frame = 0;
  o.outlier_fraction = outliers;
  return MakeSyntheticOrbit(o);
}

// Correspondences of frame f: truth points <-> measured pixels.
void Correspondences(const SyntheticOrbit& s, int f, std::vector<Eigen::Vector3d>* pts,
                     std::vector<Eigen::Vector2d>* px) {
  // Ids are assigned in point order when first seen; recover the point by projecting and matching nearest.
  const Eigen::Isometry3d cw = s.world_from_camera[f].inverse();
  for (const auto& t : s.frames[f].features) {
    double best = 1e9;
    int best_i = -1;
    for (size_t i = 0; i < s.points.size(); ++i) {
      Eigen::Vector2d uv;
      if (!s.camera.Project(cw * s.points[i], &uv)) continue;
      const double d = (uv - Eigen::Vector2d(t.u, t.v)).norm();
      if (d < best) best = d, best_i = static_cast<int>(i);
    }
    if (best_i >= 0 && best < 1.5) {
      pts->push_back(s.points[best_i]);
      px->push_back(Eigen::Vector2d(t.u, t.v));
    }
  }
}

TEST(FloorPose, RoundTripsRobotPoses) {
  RobotGeometry robot;
  robot.mast_offset_x_mm = 30;
  const Eigen::Isometry3d w = WorldFromCamera(robot, 100, -50, 0.7, 0.4, 0.3);
  const FloorPose p = FloorPoseFromWorldFromCamera(robot, w);
  EXPECT_NEAR(p.yaw_rad, 1.1, 1e-9);
  EXPECT_NEAR(p.tilt_rad, 0.3, 1e-9);
  EXPECT_TRUE(WorldFromCameraFloor(robot, p).isApprox(w, 1e-9));
}

TEST(Triangulation, MultiViewPointAndRejections) {
  const SyntheticOrbit s = Scene(0.3);
  const Eigen::Vector3d x(20, -30, 120);
  std::vector<Eigen::Isometry3d> poses;
  std::vector<Eigen::Vector2d> px;
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0, 0.3);
  for (int f = 0; f < 60; f += 6) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(s.camera.Project(s.world_from_camera[f].inverse() * x, &uv));
    poses.push_back(s.world_from_camera[f]);
    px.push_back(uv + Eigen::Vector2d(g(rng), g(rng)));
  }
  TriangulationOptions o;
  TriangulatedPoint tp;
  std::string why;
  ASSERT_TRUE(TriangulatePoint(s.camera, poses, px, o, &tp, &why)) << why;
  EXPECT_LT((tp.point_in_world - x).norm(), 1.0);
  EXPECT_LT(tp.rms_px, 0.6);
  // Low parallax: two adjacent frames (1.6 deg apart < 5 deg required).
  o.min_parallax_deg = 5;
  EXPECT_FALSE(
      TriangulatePoint(s.camera, {s.world_from_camera[0], s.world_from_camera[1]}, {px[0], px[0]}, o, &tp, &why));
  EXPECT_EQ(why, "low parallax");
  // An outlier view breaks the every-view threshold.
  o.min_parallax_deg = 2;
  px[3] += Eigen::Vector2d(15, -10);
  EXPECT_FALSE(TriangulatePoint(s.camera, poses, px, o, &tp, &why));
  EXPECT_EQ(why, "reprojection");
}

TEST(Pnp, RansacSixAndFourDofWithOutliers) {
  const SyntheticOrbit s = Scene(0.3, 0.0);
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector2d> px;
  Correspondences(s, 30, &pts, &px);
  ASSERT_GT(pts.size(), 200u);
  // 20 % gross outliers.
  std::mt19937 rng(2);
  for (size_t i = 0; i < px.size(); i += 5) px[i] += Eigen::Vector2d(30 + i % 17, -25);
  for (MotionModel model : {MotionModel::kSixDof, MotionModel::kFourDof}) {
    PnpOptions o;
    o.model = model;
    PnpResult r;
    std::string why;
    ASSERT_TRUE(SolvePnp(s.camera, s.robot, pts, px, nullptr, o, &r, &why)) << why;
    EXPECT_TRUE(r.used_ransac);
    EXPECT_LT((r.world_from_camera.translation() - s.world_from_camera[30].translation()).norm(), 1.0);
    EXPECT_LT(RotationAngle(r.world_from_camera.linear().transpose() * s.world_from_camera[30].linear()), 1e-3);
    EXPECT_NEAR(static_cast<double>(r.inliers.size()), 0.8 * pts.size(), 0.02 * pts.size());
    EXPECT_LT(r.rms_px, 0.6);
    // Same answer twice (seeded).
    PnpResult r2;
    ASSERT_TRUE(SolvePnp(s.camera, s.robot, pts, px, nullptr, o, &r2, &why));
    EXPECT_TRUE(r2.world_from_camera.isApprox(r.world_from_camera, 0));
  }
  // Too few correspondences.
  PnpResult r;
  std::vector<Eigen::Vector3d> few(pts.begin(), pts.begin() + 5);
  std::vector<Eigen::Vector2d> fewpx(px.begin(), px.begin() + 5);
  EXPECT_FALSE(SolvePnp(s.camera, s.robot, few, fewpx, nullptr, PnpOptions(), &r));
}

// Perturbed cameras and points: BA must bring the reprojection error down to the noise and the poses back near truth.
TEST(BundleAdjustment, ReducesErrorSixAndFourDof) {
  const SyntheticOrbit s = Scene(0.3);
  for (MotionModel model : {MotionModel::kSixDof, MotionModel::kFourDof}) {
    BaProblem p;
    std::mt19937 rng(4);
    std::normal_distribution<double> g(0, 1);
    std::vector<int> frames;
    for (int f = 0; f < 60; f += 4) frames.push_back(f);
    for (int f : frames) {
      Eigen::Isometry3d w = s.world_from_camera[f];
      if (f != 0) {
        w.translation() += 3.0 * Eigen::Vector3d(g(rng), g(rng), model == MotionModel::kFourDof ? 0 : g(rng));
        w.linear() = w.linear() * Eigen::AngleAxisd(0.005, Eigen::Vector3d::UnitY()).toRotationMatrix();
      }
      p.world_from_camera.push_back(w);
    }
    for (const auto& x : s.points) p.points.push_back(x + 2.0 * Eigen::Vector3d(g(rng), g(rng), g(rng)));
    for (size_t k = 0; k < frames.size(); ++k) {
      const Eigen::Isometry3d cw = s.world_from_camera[frames[k]].inverse();
      for (size_t i = 0; i < s.points.size(); ++i) {
        Eigen::Vector2d uv;
        if (!s.camera.Project(cw * s.points[i], &uv) || !s.camera.InImage(uv)) continue;
        p.observations.push_back(
            {static_cast<int>(k), static_cast<int>(i), uv + 0.3 * Eigen::Vector2d(g(rng), g(rng))});
      }
    }
    p.frame_fix.assign(frames.size(), FrameFix::kFree);
    p.frame_fix[0] = model == MotionModel::kSixDof ? FrameFix::kFixed : FrameFix::kFixedFloor;
    if (model == MotionModel::kSixDof) {  // scale gauge: true baseline to the last frame
      p.distance_frame_a = 0;
      p.distance_frame_b = static_cast<int>(frames.size()) - 1;
      p.distance_mm = (s.world_from_camera[frames.back()].translation() - s.world_from_camera[0].translation()).norm();
    } else {  // floor points hold the scale
      p.point_on_floor.assign(p.points.size(), 0);
      for (size_t i = 450; i < p.points.size(); ++i) p.point_on_floor[i] = 1;
    }
    BaOptions o;
    o.model = model;
    const BaSummary sum = RunBundleAdjustment(s.camera, s.robot, o, &p);
    ASSERT_TRUE(sum.ok) << sum.message;
    EXPECT_GT(sum.initial_rms_px, 2.0);
    EXPECT_LT(sum.final_rms_px, 0.45);  // 2-D noise norm RMS = sqrt(2) * 0.3 = 0.42 px
    double pos = 0;
    for (size_t k = 0; k < frames.size(); ++k)
      pos = std::max(pos, (p.world_from_camera[k].translation() - s.world_from_camera[frames[k]].translation()).norm());
    EXPECT_LT(pos, 1.0) << "model " << static_cast<int>(model);
  }
}

TEST(BundleAdjustment, IgnoresPointsSeenByOneFrame) {
  // Points with a single observation carry no depth: they must come back unchanged and not disturb the solve.
  const SyntheticOrbit s = Scene(0.3);
  BaProblem p;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  const std::vector<int> frames = {0, 10, 20, 30};
  for (int f : frames) {
    Eigen::Isometry3d w = s.world_from_camera[f];
    if (f != 0) w.translation() += 2.0 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    p.world_from_camera.push_back(w);
  }
  for (const auto& x : s.points) p.points.push_back(x + 1.0 * Eigen::Vector3d(g(rng), g(rng), g(rng)));
  for (size_t k = 0; k < frames.size(); ++k) {
    const Eigen::Isometry3d cw = s.world_from_camera[frames[k]].inverse();
    for (size_t i = 0; i < s.points.size(); ++i) {
      Eigen::Vector2d uv;
      if (!s.camera.Project(cw * s.points[i], &uv) || !s.camera.InImage(uv)) continue;
      p.observations.push_back({static_cast<int>(k), static_cast<int>(i), uv + 0.3 * Eigen::Vector2d(g(rng), g(rng))});
    }
  }
  // 50 single-view points, 20 mm off their rays' true point, seen by frame 2 only.
  const size_t first_single = p.points.size();
  const Eigen::Isometry3d cw2 = s.world_from_camera[frames[2]].inverse();
  for (size_t i = 0; i < s.points.size() && p.points.size() < first_single + 50; i += 7) {
    Eigen::Vector2d uv;
    if (!s.camera.Project(cw2 * s.points[i], &uv) || !s.camera.InImage(uv)) continue;
    p.points.push_back(s.points[i] + Eigen::Vector3d(20, 0, 0));
    p.observations.push_back({2, static_cast<int>(p.points.size() - 1), uv});
  }
  const std::vector<Eigen::Vector3d> before(p.points.begin() + first_single, p.points.end());
  p.frame_fix.assign(frames.size(), FrameFix::kFree);
  p.frame_fix[0] = FrameFix::kFixed;
  p.distance_frame_a = 0;
  p.distance_frame_b = 3;
  p.distance_mm = (s.world_from_camera[frames[3]].translation() - s.world_from_camera[0].translation()).norm();
  const BaSummary sum = RunBundleAdjustment(s.camera, s.robot, BaOptions(), &p);
  ASSERT_TRUE(sum.ok) << sum.message;
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(p.points[first_single + i], before[i]);
  double pos = 0;
  for (size_t k = 0; k < frames.size(); ++k)
    pos = std::max(pos, (p.world_from_camera[k].translation() - s.world_from_camera[frames[k]].translation()).norm());
  EXPECT_LT(pos, 1.0);
}

TEST(BundleAdjustment, RejectsNonFiniteInput) {
  const SyntheticOrbit s = Scene();
  BaProblem p;
  p.world_from_camera.push_back(s.world_from_camera[0]);
  p.points.push_back(Eigen::Vector3d(NAN, 0, 0));
  p.observations.push_back({0, 0, Eigen::Vector2d(1, 1)});
  EXPECT_FALSE(RunBundleAdjustment(s.camera, s.robot, BaOptions(), &p).ok);
}

}  // namespace
}  // namespace objscan
