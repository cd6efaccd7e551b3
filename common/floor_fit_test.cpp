#include "common/floor_fit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "common/plane_test_support.h"

namespace objscan {
namespace {

using testing_support::AddPlane;
using testing_support::AngleDeg;

// RANSAC, then two refits (the shared steps of every floor fitter).
PlaneSupport FitAndRefit(const std::vector<Eigen::Vector3d>& points, const PlaneSampling& sampling, double inlier_mm) {
  PlaneSupport best = MostSupportedPlane(points, sampling, inlier_mm);
  for (int pass = 0; pass < 2; ++pass) EXPECT_TRUE(RefitPlaneToInliers(points, inlier_mm, sampling.up, &best.plane));
  best.inliers = CountPlaneInliers(points, best.plane, inlier_mm);
  return best;
}

TEST(FloorFitTest, NoisyLevelFloorAmongWallsAndClutter) {
  std::mt19937 rng(3);
  std::vector<Eigen::Vector3d> points;
  AddPlane(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d::UnitZ(), 2500, 800, 3.0, &rng, &points);
  AddPlane(Eigen::Vector3d(2500, 0, 600), Eigen::Vector3d::UnitX(), 600, 900, 1.0, &rng, &points);  // wall
  std::uniform_real_distribution<double> u(-2000, 2000), z(20, 1500);
  for (int i = 0; i < 300; ++i) points.emplace_back(u(rng), u(rng), z(rng));  // clutter above the floor
  const PlaneSupport fit = FitAndRefit(points, PlaneSampling{}, 15.0);
  EXPECT_LT(AngleDeg(fit.plane.normal, Eigen::Vector3d::UnitZ()), 0.3);
  EXPECT_GT(fit.plane.normal.z(), 0);
  EXPECT_NEAR(fit.plane.offset_mm, 0.0, 1.5);
  EXPECT_GE(fit.inliers, 780);  // 15 mm = 5 sigma: all floor points
  EXPECT_LE(fit.inliers, 830);
}

TEST(FloorFitTest, TiltedOffsetFloorAndFloorFromWorld) {
  std::mt19937 rng(4);
  const Eigen::Vector3d normal =
      Eigen::AngleAxisd(6.0 * M_PI / 180.0, Eigen::Vector3d(1, 2, 0).normalized()) * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d origin(300, -200, 250);
  std::vector<Eigen::Vector3d> points;
  AddPlane(origin, normal, 2000, 1000, 2.0, &rng, &points);
  const PlaneSupport fit = FitAndRefit(points, PlaneSampling{}, 15.0);
  EXPECT_LT(AngleDeg(fit.plane.normal, normal), 0.2);
  EXPECT_NEAR(fit.plane.Height(origin), 0.0, 1.0);
  EXPECT_NEAR(fit.plane.Height(origin + 100 * normal), 100.0, 1.0);  // sign: positive above
  EXPECT_TRUE(NormalWithinTilt(fit.plane, Eigen::Vector3d::UnitZ(), 6.5));
  EXPECT_FALSE(NormalWithinTilt(fit.plane, Eigen::Vector3d::UnitZ(), 5.5));
  // floor_from_world maps the floor to z = 0 and the normal to +z
  const Eigen::Isometry3d f = fit.plane.FloorFromWorld();
  EXPECT_NEAR((f * origin).z(), 0.0, 1.0);
  EXPECT_NEAR((f * (origin + 100 * normal)).z(), 100.0, 1.0);
}

TEST(FloorFitTest, HeightSignConvention) {
  FloorPlane floor;  // z = 0
  EXPECT_EQ(floor.Height(Eigen::Vector3d(5, 7, 30)), 30.0);
  floor.offset_mm = -100;  // the plane z = 100
  EXPECT_EQ(floor.Height(Eigen::Vector3d(5, 7, 30)), -70.0);
  EXPECT_EQ(
      CountPointsBelow({Eigen::Vector3d(0, 0, 30), Eigen::Vector3d(0, 0, 95), Eigen::Vector3d(0, 0, 150)}, floor, 10.0),
      1);
}

TEST(FloorFitTest, SkipsSteepPlanesAndHandlesTooFewPoints) {
  std::mt19937 rng(6);
  std::vector<Eigen::Vector3d> points;
  const Eigen::Vector3d steep =
      Eigen::AngleAxisd(25.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ();
  AddPlane(Eigen::Vector3d::Zero(), steep, 1000, 500, 1.0, &rng, &points);
  EXPECT_EQ(MostSupportedPlane(points, PlaneSampling{}, 15.0).inliers, 0);  // every hypothesis is > 10 deg tilted
  PlaneSampling wide;
  wide.max_tilt_deg = 30;
  const PlaneSupport found = MostSupportedPlane(points, wide, 15.0);
  EXPECT_EQ(found.inliers, 500);
  EXPECT_LT(AngleDeg(found.plane.normal, steep), 0.5);
  EXPECT_EQ(MostSupportedPlane({}, PlaneSampling{}, 15.0).inliers, 0);
  FloorPlane plane;
  EXPECT_FALSE(RefitPlaneToInliers({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)}, 15.0, Eigen::Vector3d::UnitZ(),
                                   &plane));
}

TEST(FloorFitTest, StartHypothesisAdmissibilityAndUp) {
  std::mt19937 rng(9);
  std::vector<Eigen::Vector3d> points;
  AddPlane(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d::UnitZ(), 2000, 300, 1.0, &rng, &points);
  AddPlane(Eigen::Vector3d(0, 0, 700), Eigen::Vector3d::UnitZ(), 450, 600, 1.0, &rng, &points);  // a table top
  const PlaneSupport table = MostSupportedPlane(points, PlaneSampling{}, 10.0);
  EXPECT_NEAR(table.plane.Height(Eigen::Vector3d::Zero()), -700.0, 10.0);
  // Nothing beneath: the floor.
  const PlaneSupport floor = MostSupportedPlane(points, PlaneSampling{}, 10.0, nullptr, [&](const FloorPlane& plane) {
    return CountPointsBelow(points, plane, 30.0) == 0;
  });
  EXPECT_NEAR(floor.plane.Height(Eigen::Vector3d::Zero()), 0.0, 10.0);
  EXPECT_NEAR(floor.inliers, 300, 5);
  // A start hypothesis no sample beats stays.
  FloorPlane exact;
  exact.offset_mm = -700;
  const PlaneSupport kept = MostSupportedPlane(points, PlaneSampling{}, 10.0, &exact);
  EXPECT_EQ(kept.plane.offset_mm, -700.0);
  EXPECT_EQ(kept.inliers, 600);
  // Up along -z: normals turn down.
  PlaneSampling down;
  down.up = -Eigen::Vector3d::UnitZ();
  EXPECT_LT(MostSupportedPlane(points, down, 10.0).plane.normal.z(), 0);
}

TEST(FloorFitTest, Deterministic) {
  std::mt19937 rng(8);
  std::vector<Eigen::Vector3d> points;
  AddPlane(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 2000, 3000, 3.0, &rng, &points);
  const PlaneSupport a = FitAndRefit(points, PlaneSampling{}, 15.0), b = FitAndRefit(points, PlaneSampling{}, 15.0);
  EXPECT_EQ(a.plane.normal, b.plane.normal);
  EXPECT_EQ(a.plane.offset_mm, b.plane.offset_mm);
  EXPECT_EQ(a.inliers, b.inliers);
}

}  // namespace
}  // namespace objscan

namespace objscan {
namespace {

// The three sample sequences are pinned: a fitter's results were measured with its sequence, and a change of draws
// is a new random draw (issue 27: with one shared sequence the pose solver lost its floor on a test run). Five
// samples on a noisy plane with outliers: which hypothesis wins depends on the indices drawn.
TEST(FloorFitTest, SampleSequencesArePinned) {
  std::mt19937 rng(11);
  std::vector<Eigen::Vector3d> points;
  AddPlane(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1000, 300, 3.0, &rng, &points);
  std::uniform_real_distribution<double> box(-500.0, 500.0);
  for (int i = 0; i < 300; ++i) points.emplace_back(box(rng), box(rng), 50 + 0.2 * box(rng));
  struct Case {
    SampleIndexSequence sequence;
    uint64_t seed;
    int inliers;       // measured on 7 Dec (Debian 12, libstdc++ 12)
    double offset_mm;
  };
  for (const Case c : {Case{SampleIndexSequence::kMt19937Modulo, 24, 106, 11.480306589},
                       Case{SampleIndexSequence::kMt19937Uniform, 7, 72, 17.438370067},
                       Case{SampleIndexSequence::kLcg, 0x5eed0f100dULL, 189, 4.780880262}}) {
    PlaneSampling sampling;
    sampling.iterations = 5;
    sampling.sequence = c.sequence;
    sampling.seed = c.seed;
    const PlaneSupport s = MostSupportedPlane(points, sampling, 6.0);
    std::printf("sequence %d: inliers %d, offset %.9f mm\n", static_cast<int>(c.sequence), s.inliers, s.plane.offset_mm);
    EXPECT_EQ(s.inliers, c.inliers) << static_cast<int>(c.sequence);
    EXPECT_NEAR(s.plane.offset_mm, c.offset_mm, 1e-6) << static_cast<int>(c.sequence);
  }
}

}  // namespace
}  // namespace objscan
