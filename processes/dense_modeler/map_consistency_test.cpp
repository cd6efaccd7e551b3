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
  EXPECT_TRUE(two.Inconsistent(options));
  EXPECT_FALSE(thin.Inconsistent(options));
  // The layers overlap in space: every cell holds both. (Cells of 8-12 points: their p10 / p90 lie closer in than
  // the whole ring's.)
  EXPECT_GE(two.cells, options.min_cells);
  EXPECT_GT(two.local_thickness_mm, 7.5);
  EXPECT_LT(two.local_thickness_mm, 9.5);
  EXPECT_GT(thin.local_thickness_mm, 0.3);
  EXPECT_LT(thin.local_thickness_mm, 1.5);
  // The target's points (inside the inner radius) never count.
  EXPECT_LT(thin.points, 4000);
  EXPECT_GT(thin.points, 4000 * (0.6 * 0.6 - 0.15 * 0.15) / (0.8 * 0.8) * 0.9);
}

// Landmarks in the ring but off the floor (an obstacle's, 30-300 mm up) change nothing: only the floor band counts.
TEST(FloorThickness, PointsAboveTheFloorBandDoNotCount) {
  const Eigen::Vector3d centre(0, 0, 0);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> floor = Floor(centre, up, 0.5, {0.0}, 4000, 4);
  const FloorThickness before = MeasureFloorThickness(floor, centre, Plane(up), 0.0, FloorThicknessOptions());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> height(30.0, 300.0), along(200.0, 550.0);
  for (int i = 0; i < 1000; ++i) floor.emplace_back(along(rng), 0.2 * along(rng), height(rng));
  const FloorThickness after = MeasureFloorThickness(floor, centre, Plane(up), 0.0, FloorThicknessOptions());
  EXPECT_EQ(after.points, before.points);
  EXPECT_DOUBLE_EQ(after.thickness_mm(), before.thickness_mm());
  EXPECT_DOUBLE_EQ(after.local_thickness_mm, before.local_thickness_mm);
}

// A real step in the floor (a 8 mm rug under half the ring) makes the ring thick but leaves the cells thin: not
// inconsistent. The same 8 mm between two overlapping layers is.
TEST(FloorThickness, AStepInTheFloorIsNotAnInconsistentMap) {
  const Eigen::Vector3d centre(0, 0, 0);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> floor = Floor(centre, up, 0.5, {0.0}, 4000, 6);
  for (Eigen::Vector3d& p : floor)
    if (p.x() > 0 && std::abs(p.z()) < 5) p.z() += 8.0;  // the rug's top, east of the target
  const FloorThicknessOptions options;
  const FloorThickness step = MeasureFloorThickness(floor, centre, Plane(up), 0.0, options);
  ASSERT_TRUE(step.measured);
  EXPECT_GT(step.thickness_mm(), options.max_thickness_mm);  // the ring alone would call it inconsistent
  EXPECT_LT(step.local_thickness_mm, 2.0);
  EXPECT_FALSE(step.Inconsistent(options));
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

// Frames 0-99 in the first map, 100-199 in a restart never joined: the model keeps the map with the most matches in
// its own pairs, drops the other map's pairs and the pair across the restart, and keeps pairs without final poses.
TEST(ChooseModelMap, KeepsTheMapWithTheMostMatchesAndDropsTheOthers) {
  std::unordered_map<int64_t, int64_t> map_of;
  for (int64_t s = 0; s < 200; ++s) map_of[s] = s < 100 ? 0 : 100;
  std::vector<PairFrames> pairs;
  for (int64_t s = 0; s + 5 < 200; s += 5) pairs.push_back({s, s + 5, s < 100 ? 300 : 500});
  pairs.push_back({400, 405, 999});  // no final poses: kept with its live poses
  pairs.push_back({20, 405, 7});     // one frame in the first map, one without a final pose: dropped
  const ModelMapChoice choice = ChooseModelMap(pairs, map_of);
  EXPECT_EQ(choice.maps, 2);
  EXPECT_EQ(choice.map_start_seq, 100);  // 19 pairs x 500 against 19 x 300 (the pair 95-100 crosses)
  EXPECT_EQ(choice.pairs_across_maps, 1);
  EXPECT_EQ(choice.pairs_other_map, 20);
  ASSERT_EQ(choice.keep.size(), pairs.size());
  for (size_t i = 0; i + 2 < pairs.size(); ++i) EXPECT_EQ(choice.keep[i], pairs[i].seq_a >= 100) << i;
  EXPECT_TRUE(choice.keep[pairs.size() - 2]);
  EXPECT_FALSE(choice.keep.back());
  EXPECT_EQ(choice.matches_kept, 19 * 500 + 999);
  EXPECT_EQ(choice.matches_dropped, 19 * 300 + 300 + 7);
  // The other way round: the first map holds more.
  for (PairFrames& p : pairs)
    if (p.seq_a < 100) p.matches = 700;
  EXPECT_EQ(ChooseModelMap(pairs, map_of).map_start_seq, 0);
}

// One map: it is the model's, every pair kept; poses that do not say (map_start_seq -1): every pair kept, no map.
TEST(ChooseModelMap, OneMapOrUnknownMapsKeepEveryPair) {
  std::vector<PairFrames> pairs = {{0, 5, 10}, {5, 10, 10}, {10, 15, 10}};
  std::unordered_map<int64_t, int64_t> one, unknown;
  for (int64_t s = 0; s <= 15; ++s) {
    one[s] = 0;
    unknown[s] = -1;
  }
  for (const auto* map_of : {&one, &unknown}) {
    const ModelMapChoice choice = ChooseModelMap(pairs, *map_of);
    EXPECT_EQ(choice.map_start_seq, map_of == &one ? 0 : -1);
    EXPECT_EQ(choice.pairs_other_map + choice.pairs_across_maps, 0);
    EXPECT_EQ(choice.matches_kept, 30);
    for (bool k : choice.keep) EXPECT_TRUE(k);
  }
  EXPECT_EQ(ChooseModelMap(pairs, one).maps, 1);
  EXPECT_EQ(ChooseModelMap(pairs, unknown).maps, 0);
  EXPECT_EQ(ChooseModelMap({}, one).maps, 0);
}

}  // namespace
}  // namespace objscan
