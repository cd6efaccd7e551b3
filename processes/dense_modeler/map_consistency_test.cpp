#include "processes/dense_modeler/map_consistency.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace objscan {
namespace {

FloorPlane Plane(const Eigen::Vector3d& normal) {  // through the origin
  FloorPlane plane;
  plane.normal = normal;
  return plane;
}

// Floor landmarks on a disc of 800 mm around centre: height = layer offset + N(0, sigma) above the plane z = 0
// tilted by the given normal; plus the target's own points (a 100 mm-radius column up to 200 mm) that must not count.
std::vector<Eigen::Vector3d> Floor(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double sigma_mm,
                                   const std::vector<double>& layers_mm, int points, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, sigma_mm);
  std::vector<Eigen::Vector3d> out;
  while (static_cast<int>(out.size()) < points) {
    const Eigen::Vector2d xy(800 * unit(rng), 800 * unit(rng));
    if (xy.norm() > 800) continue;
    const double layer = layers_mm[out.size() % layers_mm.size()];
    Eigen::Vector3d p(centre.x() + xy.x(), centre.y() + xy.y(), 0);
    // On the plane normal . x = 0 through the origin, then up along the normal.
    p.z() = -(normal.x() * p.x() + normal.y() * p.y()) / normal.z();
    out.push_back(p + (layer + noise(rng)) * normal);
  }
  for (int i = 0; i < 500; ++i) out.push_back(centre + Eigen::Vector3d(100 * unit(rng), 100 * unit(rng), 100 + 100 * unit(rng)));
  return out;
}

TEST(FloorThickness, AThinFloorIsThinAndTwoLayersAreThick) {
  const Eigen::Vector3d centre(-1600, 2300, 0);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.01, -0.003, 1).normalized();  // a floor tilted 0.6 deg
  const FloorThicknessOptions options;
  // One layer, 0.5 mm noise: p90 - p10 = 2 x 1.28 sigma = 1.3 mm.
  const FloorThickness thin =
      MeasureFloorThickness(Floor(centre, normal, 0.5, {0.0}, 4000, 1), centre, Plane(normal), 0.0, options);
  ASSERT_TRUE(thin.measured);
  EXPECT_NEAR(thin.thickness_mm(), 1.28, 0.2);
  EXPECT_NEAR(thin.p50_mm, 0.0, 0.1);
  EXPECT_LT(thin.thickness_mm(), options.max_thickness_mm);
  // Two passes 8 mm apart (room_09's rerun: 9.0 mm): thick.
  const FloorThickness two =
      MeasureFloorThickness(Floor(centre, normal, 0.5, {0.0, 8.0}, 4000, 2), centre, Plane(normal), 0.0, options);
  ASSERT_TRUE(two.measured);
  EXPECT_NEAR(two.thickness_mm(), 8.0 + 2 * 0.84 * 0.5, 0.3);  // p10 and p90: the 20th / 80th of each layer
  EXPECT_GT(two.thickness_mm(), options.max_thickness_mm);
  // The target's points (inside the inner radius) and landmarks far off the floor never count.
  EXPECT_LT(thin.points, 4000);
  EXPECT_GT(thin.points, 4000 * (0.6 * 0.6 - 0.15 * 0.15) / (0.8 * 0.8) * 0.9);
}

TEST(FloorThickness, TheRingStartsOutsideTheTargetAndFewPointsAreNotJudged) {
  const Eigen::Vector3d centre(0, 0, 0);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  FloorThicknessOptions options;
  const std::vector<Eigen::Vector3d> floor = Floor(centre, up, 0.5, {0.0}, 4000, 3);
  const FloorThickness wide = MeasureFloorThickness(floor, centre, Plane(up), 300.0, options);  // a big target
  EXPECT_DOUBLE_EQ(wide.inner_radius_mm, 300.0);
  const FloorThickness narrow = MeasureFloorThickness(floor, centre, Plane(up), 0.0, options);
  EXPECT_DOUBLE_EQ(narrow.inner_radius_mm, 150.0);
  EXPECT_NE(wide.points, narrow.points);
  options.min_points = 100000;
  const FloorThickness few = MeasureFloorThickness(floor, centre, Plane(up), 0.0, options);
  EXPECT_FALSE(few.measured);
  EXPECT_GT(few.points, 0);
  // Bad input: nothing measured, no crash.
  std::vector<Eigen::Vector3d> with_nan = floor;
  with_nan.push_back(Eigen::Vector3d::Constant(std::nan("")));
  EXPECT_TRUE(MeasureFloorThickness(with_nan, centre, Plane(up), 0.0, FloorThicknessOptions()).measured);
  EXPECT_FALSE(
      MeasureFloorThickness(floor, Eigen::Vector3d::Constant(std::nan("")), Plane(up), 0.0, FloorThicknessOptions())
          .measured);
  EXPECT_FALSE(MeasureFloorThickness({}, centre, Plane(up), 0.0, FloorThicknessOptions()).measured);
}

}  // namespace
}  // namespace objscan
