#include "common/geometry.h"

#include <gtest/gtest.h>

#include <random>

namespace objscan {
namespace {

TEST(GeometryTest, UmeyamaRecoversKnownSimilarity) {
  Sim3 truth;
  truth.scale = 2.5;
  truth.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -1, 0.4).normalized()).toRotationMatrix();
  truth.translation = Eigen::Vector3d(10, -20, 30);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-100, 100);
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 50; ++i) {
    src.emplace_back(u(rng), u(rng), u(rng));
    dst.push_back(truth * src.back());
  }
  Sim3 est;
  ASSERT_TRUE(AlignUmeyama(src, dst, true, &est));
  EXPECT_NEAR(est.scale, 2.5, 1e-9);
  EXPECT_TRUE(est.rotation.isApprox(truth.rotation, 1e-9));
  EXPECT_TRUE(est.translation.isApprox(truth.translation, 1e-9));
  // Collinear points have no unique rotation.
  std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  EXPECT_FALSE(AlignUmeyama(line, line, true, &est));
}

TEST(GeometryTest, TrajectoryErrorOfScaledNoisyCircle) {
  std::vector<Eigen::Isometry3d> truth, est;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 1.0);  // mm
  Sim3 gauge;
  gauge.scale = 0.01;
  gauge.rotation = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  gauge.translation = Eigen::Vector3d(5, 5, 5);
  for (int i = 0; i < 200; ++i) {
    const double a = 2 * M_PI * i / 200;
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.translation() = Eigen::Vector3d(800 * std::cos(a), 800 * std::sin(a), 400);
    p.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    truth.push_back(p);
    Eigen::Isometry3d q = p;
    q.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    est.push_back(gauge.Apply(q));
  }
  TrajectoryError e;
  ASSERT_TRUE(EvaluateTrajectory(est, truth, true, &e));
  EXPECT_NEAR(e.ate_rmse, std::sqrt(3.0), 0.3);  // 1 mm per axis
  EXPECT_NEAR(e.scale, 100.0, 0.5);
  // The alignment comes from noisy centres (1 mm on an 800 mm ring): ~1e-4 rad of rotation error remains.
  EXPECT_LT(e.rotation_mean_rad, 1e-3);
}

TEST(GeometryTest, PoseArraysRoundTrip) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(2.9, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  p.translation() = Eigen::Vector3d(1, 2, 3);
  double t[3], q[4];
  PoseToArrays(p, t, q);
  EXPECT_GE(q[0], 0);
  EXPECT_TRUE(PoseFromArrays(t, q).isApprox(p, 1e-12));
}

}  // namespace
}  // namespace objscan
