#include "processes/planner/occupancy_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "processes/planner/path_search.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

MapLandmark Landmark(double x, double y, double z, int observations = 3, float error = 0.5f) {
  MapLandmark l;
  l.position_mm = Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  l.observations = observations;
  l.error_px = error;
  return l;
}

// Floor landmarks every 50 mm over a rectangle (a textured floor seen everywhere there).
void AddFloor(std::vector<MapLandmark>* l, double x0, double y0, double x1, double y1) {
  for (double x = x0; x <= x1; x += 50)
    for (double y = y0; y <= y1; y += 50) l->push_back(Landmark(x, y, 2));
}

OccupancyMapOptions SmallMap() {
  OccupancyMapOptions o;
  o.size_mm = 6000;
  return o;
}

TEST(OccupancyMapTest, DistanceTransformIsExact) {
  const int w = 37, h = 23;
  std::mt19937 rng(5);
  std::vector<uint8_t> site(w * h, 0);
  for (int i = 0; i < 12; ++i) site[rng() % site.size()] = 1;
  std::vector<float> squared;
  SquaredDistanceToSites(site, w, h, &squared);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double best = 1e30;
      for (int j = 0; j < w * h; ++j)
        if (site[j]) best = std::min(best, static_cast<double>((j % w - x) * (j % w - x) + (j / w - y) * (j / w - y)));
      EXPECT_EQ(squared[y * w + x], static_cast<float>(best)) << x << "," << y;
    }
  std::vector<uint8_t> none(w * h, 0);
  SquaredDistanceToSites(none, w, h, &squared);
  EXPECT_GE(squared[0], 1e18f);
}

TEST(OccupancyMapTest, LandmarksBecomeObstaclesOrFloorByHeight) {
  OccupancyMap map(SmallMap());
  std::vector<MapLandmark> l = {Landmark(1000, 0, 200),         Landmark(1500, 0, 5),  Landmark(2000, 0, 2000),
                                Landmark(-1000, 0, 300, 1),     Landmark(-1500, 0, 300, 3, 9.f),
                                Landmark(NAN, 0, 100),          Landmark(0, 1000, -200)};
  map.SetLandmarks(l);
  map.Update();
  EXPECT_EQ(map.obstacle_landmarks(), 1);  // 200 mm high; 2 m is above the base, the others fail the filters
  EXPECT_EQ(map.floor_landmarks(), 1);
  int index;
  ASSERT_TRUE(map.IndexOf({1000, 0}, &index));
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kOccupied);
  ASSERT_TRUE(map.IndexOf({2000, 0}, &index));
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kUnknown);
  ASSERT_TRUE(map.IndexOf({1500, 0}, &index));  // a floor landmark: seen and supported
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kFree);
  // A new landmark set replaces the obstacles (the pose solver removed the point).
  map.SetLandmarks({});
  map.Update();
  ASSERT_TRUE(map.IndexOf({1000, 0}, &index));
  EXPECT_NE(map.StateOf(index), OccupancyMap::State::kOccupied);
}

TEST(OccupancyMapTest, ViewRaysMarkTheFloorInViewAndStopAtObstacles) {
  OccupancyMapOptions options = SmallMap();
  options.free_support_mm = 0;  // view rays alone mark free space
  OccupancyMap map(options);
  std::vector<MapLandmark> l;
  for (double y = -300; y <= 300; y += 50) l.push_back(Landmark(1500, y, 150));  // a low wall ahead
  map.SetLandmarks(l);
  // Robot at the origin facing +x, head straight, tilted 20 deg down.
  map.MarkView(WorldFromCamera(RobotGeometry{}, BasePose{}, 0, 20 * kDeg), CameraIntrinsics{});
  map.Update();
  auto state = [&](double x, double y) {
    int index;
    EXPECT_TRUE(map.IndexOf({x, y}, &index));
    return map.StateOf(index);
  };
  EXPECT_EQ(state(1000, 0), OccupancyMap::State::kFree);     // in view
  EXPECT_EQ(state(2000, 200), OccupancyMap::State::kUnknown);  // behind the wall
  EXPECT_EQ(state(2000, -700), OccupancyMap::State::kFree);  // in view beside the wall
  EXPECT_EQ(state(-1000, 0), OccupancyMap::State::kUnknown);   // behind the camera
  EXPECT_EQ(state(1000, 1500), OccupancyMap::State::kUnknown); // outside the horizontal field of view
  EXPECT_EQ(state(300, 0), OccupancyMap::State::kUnknown);     // below the image's lower edge (~0.62 m)
  EXPECT_EQ(state(2800, 700), OccupancyMap::State::kUnknown);  // beyond the 2.5 m view range
}

TEST(OccupancyMapTest, FreeSpaceNeedsFloorLandmarksNearby) {
  OccupancyMap map(SmallMap());  // free_support_mm = 400
  map.MarkView(WorldFromCamera(RobotGeometry{}, BasePose{}, 0, 20 * kDeg), CameraIntrinsics{});
  map.Update();
  int index;
  ASSERT_TRUE(map.IndexOf({1000, 0}, &index));
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kUnknown);  // seen, but no floor landmark near
  std::vector<MapLandmark> l = {Landmark(1300, 0, 0)};
  map.SetLandmarks(l);
  map.Update();
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kFree);  // 300 mm from a floor landmark
  ASSERT_TRUE(map.IndexOf({1900, 0}, &index));
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kUnknown);  // 600 mm away
  // The robot's own footprint is free.
  map.MarkFootprint({-1000, -1000});
  map.Update();
  ASSERT_TRUE(map.IndexOf({-1000, -1000}, &index));
  EXPECT_EQ(map.StateOf(index), OccupancyMap::State::kFree);
}

TEST(OccupancyMapTest, InflationAndFootprintCheck) {
  OccupancyMap map(SmallMap());
  std::vector<MapLandmark> l;
  AddFloor(&l, -1500, -1500, 1500, 1500);
  l.push_back(Landmark(25, 25, 100));  // one obstacle point in the cell at (25, 25)
  map.SetLandmarks(l);
  map.Update();
  int index;
  ASSERT_TRUE(map.IndexOf({325, 25}, &index));  // cell centres 300 mm apart
  EXPECT_NEAR(map.ObstacleDistanceMm(index), 300.0, 1e-3);
  EXPECT_TRUE(map.Traversable(index));  // footprint 200 + margin 100
  EXPECT_TRUE(map.FootprintSafe({325, 25}));
  ASSERT_TRUE(map.IndexOf({225, 225}, &index));  // 282.8 mm: safe (>= 200 + cell diagonal 70.7), not planned
  EXPECT_FALSE(map.Traversable(index));
  EXPECT_TRUE(map.Passable(index));
  EXPECT_FALSE(map.FootprintSafe({275, 25}));  // 250 mm: the footprint could touch the landmark
  EXPECT_FALSE(map.FootprintSafe({175, 25}));
  EXPECT_FALSE(map.FootprintSafe({1480, 0}));  // 200 mm footprint reaches unknown cells beyond 1.5 m
  EXPECT_FALSE(map.FootprintSafe({1e9, 0}));   // outside the map
}

TEST(OccupancyMapTest, ShortestPathGoesAroundTheInflatedWall) {
  OccupancyMap map(SmallMap());
  std::vector<MapLandmark> l;
  AddFloor(&l, -2000, -2000, 2000, 2000);
  for (double y = -2000; y <= 800; y += 40) l.push_back(Landmark(0, y, 300));  // a wall from the south
  map.SetLandmarks(l);
  map.Update();
  std::vector<Eigen::Vector2d> path;
  double cost = 0;
  ASSERT_TRUE(PlanPath(map, {-1000, -1000}, {1000, -1000}, &path, &cost));
  EXPECT_GT(PathLength(path), 2 * std::hypot(1000.0, 1800.0) - 100);  // over the wall's end at y = 800 + 300
  for (size_t i = 1; i < path.size(); ++i) {
    int index;
    ASSERT_TRUE(map.IndexOf(path[i], &index));
    EXPECT_TRUE(map.Passable(index));
    EXPECT_GE(map.ObstacleDistanceMm(index), 300.0 - 1e-3);
  }
  EXPECT_GE(cost, PathLength(path) - 1.0);
  // A goal inside the inflated zone or in unknown space is refused.
  EXPECT_FALSE(PlanPath(map, {-1000, -1000}, {100, -1000}, &path));
  EXPECT_FALSE(PlanPath(map, {-1000, -1000}, {2700, 0}, &path));
  // The cost field reaches the same goal at the same cost.
  CostField field;
  field.Compute(map, {-1000, -1000});
  int goal;
  ASSERT_TRUE(map.IndexOf({1000, -1000}, &goal));
  EXPECT_NEAR(field.CostMm(goal), cost, 1e-6);
  EXPECT_EQ(field.PathTo(map, goal).size(), path.size());
}

TEST(OccupancyMapTest, UnexploredCellsNearCountsTheSquare) {
  OccupancyMap map(SmallMap());
  std::vector<MapLandmark> l;
  AddFloor(&l, 0, 0, 1000, 1000);
  map.SetLandmarks(l);
  map.Update();
  int index;
  ASSERT_TRUE(map.IndexOf({525, 525}, &index));
  EXPECT_EQ(map.UnexploredCellsNear(index, 200), 0);  // 9 x 9 cells, all seen
  // Left edge: floor landmarks from x = 0 make the cells from x = -50 on seen; columns -325 ... -75 stay unknown.
  ASSERT_TRUE(map.IndexOf({-125, 525}, &index));
  EXPECT_EQ(map.UnexploredCellsNear(index, 200), 6 * 9);
}

// A restarted map (RememberOldMap, then the new map's landmarks without the box): the box's cells stay
// obstacles; a floor landmark of a later set in one of them clears that cell only.
TEST(OccupancyMapTest, RememberedObstaclesStayUntilTheFloorShowsThere) {
  OccupancyMapOptions o;
  o.size_mm = 4000;
  OccupancyMap map(o);
  std::vector<MapLandmark> old_map;
  auto add = [](std::vector<MapLandmark>* set, float x, float y, float z) {
    MapLandmark l;
    l.position_mm = Eigen::Vector3f(x, y, z);
    l.observations = 5;
    l.error_px = 0.5f;
    set->push_back(l);
  };
  for (int i = 0; i < 5; ++i) add(&old_map, 1000 + 10 * i, 25, 100);  // a box side at x 1000-1040, y 25
  for (int x = -500; x <= 1500; x += 50)
    for (int y = -500; y <= 500; y += 50) add(&old_map, x + 5, y + 5, 0);  // floor around
  map.SetLandmarks(old_map);
  map.Update();
  int box;
  ASSERT_TRUE(map.IndexOf({1020, 25}, &box));
  EXPECT_EQ(map.StateOf(box), OccupancyMap::State::kOccupied);
  map.RememberOldMap();
  std::vector<MapLandmark> new_map;  // the new map: some floor, the box not seen yet
  for (int x = -500; x <= 500; x += 50) add(&new_map, x + 5, 5, 0);
  map.SetLandmarks(new_map);
  map.Update();
  EXPECT_EQ(map.StateOf(box), OccupancyMap::State::kOccupied);
  EXPECT_GT(map.remembered_cells(), 0);
  add(&new_map, 1020, 30, 0);  // the floor seen in the box's cell: not an obstacle after all
  map.SetLandmarks(new_map);
  map.Update();
  EXPECT_NE(map.StateOf(box), OccupancyMap::State::kOccupied);
  // The old map's floor far from the new one's points (x 1400, y 400) is still free to drive through, but
  // unexplored (the search goes there again); an object the new map shows there makes it an obstacle.
  int far_floor, new_floor;
  ASSERT_TRUE(map.IndexOf({1405, 405}, &far_floor));
  ASSERT_TRUE(map.IndexOf({5, 5}, &new_floor));
  EXPECT_EQ(map.StateOf(far_floor), OccupancyMap::State::kFree);
  EXPECT_EQ(map.UnexploredDistanceMm(far_floor), 0.0);
  EXPECT_GT(map.UnexploredDistanceMm(new_floor), 300.0);
  for (int i = 0; i < 5; ++i) add(&new_map, 1400 + 5 * i, 405, 120);  // a new object there
  map.SetLandmarks(new_map);
  map.Update();
  EXPECT_EQ(map.StateOf(far_floor), OccupancyMap::State::kOccupied);
}

}  // namespace
}  // namespace objscan
