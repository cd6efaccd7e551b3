#include "processes/dense_modeler/region_of_interest.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace objscan {
namespace {

// A scene like the sim's, in a world frame whose floor is tilted and offset (as the pose solver's can be): a sphere
// (radius 100 mm) resting on a textured floor, landmarks on both, and a few far outliers.
struct Scene {
  std::vector<int64_t> ids;
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> on_sphere;
  Eigen::Vector3d floor_normal;
  double floor_offset;
  Eigen::Vector3d centre;
};

Scene MakeScene() {
  Scene s;
  const double tilt = 0.5 * M_PI / 180.0;
  s.floor_normal = Eigen::Vector3d(0, std::sin(tilt), std::cos(tilt));
  s.floor_offset = -7.0;  // the floor passes 7 mm below the origin
  const Eigen::Vector3d foot(20, 800, 0);
  const Eigen::Vector3d foot_on_floor = foot + (s.floor_offset - s.floor_normal.dot(foot)) * s.floor_normal;
  s.centre = foot_on_floor + 100.0 * s.floor_normal;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> noise(0, 0.5);
  int64_t id = 1;
  for (int i = 0; i < 400; ++i) {  // sphere
    Eigen::Vector3d d(uni(rng), uni(rng), uni(rng));
    if (d.norm() < 0.1 || d.norm() > 1) continue;
    s.ids.push_back(id++);
    s.points.push_back(s.centre + 100.0 * d.normalized() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    s.on_sphere.push_back(true);
  }
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(), ey = s.floor_normal.cross(ex).normalized();
  for (int i = 0; i < 1500; ++i) {  // floor, 1.5 m around, not under the sphere
    const Eigen::Vector3d p = foot_on_floor + 1500 * uni(rng) * ex + 1500 * uni(rng) * ey + noise(rng) * s.floor_normal;
    if ((p - foot_on_floor).norm() < 60) continue;
    s.ids.push_back(id++);
    s.points.push_back(p);
    s.on_sphere.push_back(false);
  }
  return s;
}

// Central counts as a camera aimed at the sphere would give them: most sphere landmarks, plus a few floor ones
// near the silhouette and three wild points.
std::unordered_map<int64_t, int> CentralCounts(Scene* s) {
  std::unordered_map<int64_t, int> counts;
  for (size_t i = 0; i < s->ids.size(); ++i) {
    if (s->on_sphere[i] && i % 4 != 0) counts[s->ids[i]] = 3;
    if (!s->on_sphere[i] && (s->points[i] - s->centre).norm() < 200 && i % 5 == 0) counts[s->ids[i]] = 1;
  }
  for (int k = 0; k < 3; ++k) {
    s->ids.push_back(100000 + k);
    s->points.push_back(s->centre + Eigen::Vector3d(900 + 300 * k, -700, 400));
    counts[100000 + k] = 2;
  }
  return counts;
}

TEST(RegionOfInterestTest, AutoRegionHoldsTheSphereAndCutsTheTiltedFloor) {
  Scene s = MakeScene();
  const std::unordered_map<int64_t, int> counts = CentralCounts(&s);
  AutoRoiOptions o;
  RegionOfInterest roi;
  AutoRoiStats stats;
  ASSERT_TRUE(AutoRegionOfInterest(s.ids, s.points, counts, o, &roi, &stats));
  ASSERT_TRUE(roi.valid);
  ASSERT_TRUE(roi.has_floor);
  EXPECT_GT(stats.floor_inliers, 150);  // ~190 floor landmarks lie within floor_radius_mm
  // The measured floor is the true (tilted, offset) one.
  EXPECT_GT(roi.floor.normal.dot(s.floor_normal), std::cos(0.2 * M_PI / 180.0));
  EXPECT_NEAR(roi.floor.offset_mm, -s.floor_offset, 0.5);  // the scene's plane: normal.x = floor_offset
  // Every sphere point at least the clearance above the floor is inside; the box is not much larger than the
  // sphere (3 wild points were clustered away) and every floor landmark is outside.
  int sphere_inside = 0, sphere_high = 0;
  for (size_t i = 0; i < s.on_sphere.size(); ++i) {
    if (s.on_sphere[i]) {
      if (roi.HeightAboveFloor(s.points[i]) < o.floor_clearance_mm + 1) continue;
      ++sphere_high;
      sphere_inside += roi.Contains(s.points[i]);
    } else {
      EXPECT_FALSE(roi.Contains(s.points[i])) << s.points[i].transpose();
    }
  }
  EXPECT_EQ(sphere_inside, sphere_high);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(roi.box_max[k] - roi.box_min[k], 2 * 100 * 1.6 + 2) << "axis " << k;
    EXPECT_GT(roi.box_min[k], s.centre[k] - 100 * 1.8);
    EXPECT_LT(roi.box_max[k], s.centre[k] + 100 * 1.8);
  }
  // A point just under the floor inside the box is out; a point 15 mm above it is in.
  const Eigen::Vector3d foot = s.centre - 100.0 * s.floor_normal;
  const Eigen::Vector3d beside = foot + 70.0 * Eigen::Vector3d::UnitX();
  EXPECT_FALSE(roi.Contains(beside - 1.0 * s.floor_normal));
  EXPECT_TRUE(roi.Contains(beside + 15.0 * s.floor_normal));
}

TEST(RegionOfInterestTest, TooFewCentralLandmarksGiveNoRegion) {
  Scene s = MakeScene();
  std::unordered_map<int64_t, int> counts;
  for (int i = 0; i < 5; ++i) counts[s.ids[i]] = 1;
  RegionOfInterest roi;
  EXPECT_FALSE(AutoRegionOfInterest(s.ids, s.points, counts, AutoRoiOptions(), &roi));
  EXPECT_FALSE(roi.valid);
  EXPECT_TRUE(roi.Contains(Eigen::Vector3d(1e6, 0, -1e6)));  // invalid = no restriction
  // min_central_views: counts of 1 do not pass a threshold of 2.
  Scene t = MakeScene();
  std::unordered_map<int64_t, int> once = CentralCounts(&t);
  for (auto& [id, n] : once) n = 1;
  AutoRoiOptions o;
  o.min_central_views = 2;
  EXPECT_FALSE(AutoRegionOfInterest(t.ids, t.points, once, o, &roi));
}

TEST(RegionOfInterestTest, FloorPlaneRejectsSteepPlanesAndIsDeterministic) {
  std::vector<Eigen::Vector3d> wall, floor;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) {
      wall.emplace_back(10.0 * i, 500.0, 50.0 + 10.0 * j);    // vertical plane
      floor.emplace_back(10.0 * i, 10.0 * j, 3.0 + 0.1 * i);  // tilted floor: slope 0.01
    }
  PlaneSupport floor_fit;
  EXPECT_FALSE(FitFloorPlane(wall, 2.0, 20.0, 30, 200, &floor_fit));
  std::vector<Eigen::Vector3d> both = wall;
  both.insert(both.end(), floor.begin(), floor.end());
  ASSERT_TRUE(FitFloorPlane(both, 2.0, 20.0, 30, 200, &floor_fit));
  EXPECT_EQ(floor_fit.inliers, 400);
  EXPECT_NEAR(floor_fit.plane.normal.x(), -0.01, 1e-6);
  EXPECT_NEAR(-floor_fit.plane.offset_mm / floor_fit.plane.normal.z(), 3.0, 1e-6);  // z = 3 + 0.01 x
  PlaneSupport again;
  ASSERT_TRUE(FitFloorPlane(both, 2.0, 20.0, 30, 200, &again));
  EXPECT_EQ(again.plane.normal, floor_fit.plane.normal);
  EXPECT_EQ(again.plane.offset_mm, floor_fit.plane.offset_mm);
}

TEST(RegionOfInterestTest, CentralWindowCountsOnlyTracksNearThePrincipalPoint) {
  PinholeCamera camera;
  camera.width = 640, camera.height = 480, camera.fx = camera.fy = 800, camera.cx = 319.5, camera.cy = 239.5;
  std::unordered_map<int64_t, int> counts;
  const std::vector<std::pair<int64_t, Eigen::Vector2d>> tracks = {
      {1, {319.5, 239.5}}, {2, {319.5 + 95, 239.5 + 71}}, {3, {319.5 + 97, 239.5}}, {4, {10, 10}}};
  CountCentralTracks(camera, tracks, 0.3, &counts);  // window 192 x 144 px
  CountCentralTracks(camera, tracks, 0.3, &counts);
  EXPECT_EQ(counts[1], 2);
  EXPECT_EQ(counts[2], 2);
  EXPECT_EQ(counts.count(3), 0u);
  EXPECT_EQ(counts.count(4), 0u);
}

TEST(RegionOfInterestTest, ImageRectTriangleTestAndParsing) {
  RegionOfInterest roi;
  std::string why;
  ASSERT_TRUE(ParseRoiBox("-100, -100, 0, 100, 100, 200", &roi, &why)) << why;
  ASSERT_TRUE(roi.valid);
  EXPECT_EQ(roi.box_max, Eigen::Vector3d(100, 100, 200));
  EXPECT_FALSE(ParseRoiBox("1,2,3,4,5", &roi, &why));
  EXPECT_FALSE(ParseRoiBox("0,0,0,1,1,x", &roi, &why));
  EXPECT_FALSE(ParseRoiBox("0,0,5,1,1,5", &roi, &why));
  ASSERT_TRUE(ParseRoiBox("", &roi, &why));
  EXPECT_FALSE(roi.valid);
  ASSERT_TRUE(ParseRoiBox("-100,-100,0,100,100,200", &roi, &why));

  // Camera 800 mm in front of the box on -y, looking along +y at the box centre (x right, y down = -z).
  PinholeCamera camera;
  camera.width = 640, camera.height = 480, camera.fx = camera.fy = 800, camera.cx = 319.5, camera.cy = 239.5;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d::UnitX();
  r.col(1) = -Eigen::Vector3d::UnitZ();
  r.col(2) = Eigen::Vector3d::UnitY();
  world_from_camera.linear() = r;
  world_from_camera.translation() = Eigen::Vector3d(0, -800, 100);
  const cv::Rect rect = roi.ImageRect(camera, world_from_camera, 0.0);
  // Nearest face (y = -100, 700 mm away): half-width 100 mm -> 114.3 px; the rectangle spans it.
  EXPECT_NEAR(rect.x, 319.5 - 800.0 * 100 / 700, 2.0);
  EXPECT_NEAR(rect.x + rect.width - 1, 319.5 + 800.0 * 100 / 700, 2.0);
  EXPECT_NEAR(rect.y, 239.5 - 800.0 * 100 / 700, 2.0);
  // Looking away: box behind the camera -> empty.
  Eigen::Isometry3d away = world_from_camera;
  away.linear().col(2) = -Eigen::Vector3d::UnitY();
  away.linear().col(0) = -Eigen::Vector3d::UnitX();
  EXPECT_EQ(roi.ImageRect(camera, away, 0.0).area(), 0);

  EXPECT_TRUE(roi.TriangleOutside({150, 0, 10}, {130, 50, 10}, {200, -50, 100}, 10.0));   // all beyond x max
  EXPECT_FALSE(roi.TriangleOutside({150, 0, 10}, {90, 50, 10}, {200, -50, 100}, 10.0));   // one vertex inside
  EXPECT_FALSE(roi.TriangleOutside({150, 0, 10}, {-150, 0, 10}, {0, 150, 10}, 10.0));     // straddles the box
  EXPECT_FALSE(roi.TriangleOutside({105, 0, 10}, {108, 50, 10}, {109, -50, 100}, 10.0));  // within the slack
  roi.has_floor = true;
  roi.floor_clearance_mm = 4;
  EXPECT_TRUE(roi.TriangleOutside({0, 0, -20}, {10, 0, -20}, {0, 10, -30}, 10.0));  // under the floor
  EXPECT_FALSE(roi.Contains({0, 0, 3}));
  EXPECT_TRUE(roi.Contains({0, 0, 5}));
}

TEST(RegionOfInterestTest, FloorJunctionTriangles) {
  RegionOfInterest r;
  r.valid = true;
  r.box_min = Eigen::Vector3d(-200, -200, -50);
  r.box_max = Eigen::Vector3d(200, 200, 300);
  const Eigen::Vector3d floor(0, 0, 1), low(10, 0, 3), high(0, 10, 40), higher(5, 5, 60);
  EXPECT_FALSE(r.TriangleSpansFloorJunction(low, high, higher));  // no floor known
  r.has_floor = true;
  r.floor.normal = Eigen::Vector3d::UnitZ();
  r.floor.offset_mm = 0;
  r.floor_clearance_mm = 10;
  EXPECT_TRUE(r.TriangleSpansFloorJunction(floor, high, higher));  // floor vertex + object vertices
  EXPECT_TRUE(r.TriangleSpansFloorJunction(high, low, higher));    // order does not matter
  EXPECT_FALSE(r.TriangleSpansFloorJunction(high, higher, Eigen::Vector3d(1, 1, 12)));  // all on the object
  EXPECT_FALSE(r.TriangleSpansFloorJunction(floor, low, Eigen::Vector3d(1, 1, 8)));     // all low
  // On the floor: every vertex less than half the clearance (5 mm) above it.
  EXPECT_TRUE(r.TriangleOnFloor(floor, Eigen::Vector3d(10, 0, -1), Eigen::Vector3d(0, 10, 4.9)));
  EXPECT_FALSE(r.TriangleOnFloor(floor, low, Eigen::Vector3d(0, 10, 5.1)));  // one vertex higher
  EXPECT_FALSE(r.TriangleOnFloor(floor, high, higher));                     // a junction
  r.floor_clearance_mm = 0;
  EXPECT_FALSE(r.TriangleOnFloor(floor, Eigen::Vector3d(1, 0, -1), Eigen::Vector3d(0, 1, -1)));  // floor kept
  r.floor_clearance_mm = 10;
  r.has_floor = false;
  EXPECT_FALSE(r.TriangleOnFloor(floor, floor, floor));  // no floor known
  r.has_floor = true;
  r.valid = false;
  EXPECT_FALSE(r.TriangleOnFloor(floor, floor, floor));  // no region
}

// A region carried by a Sim(3): points inside stay inside, heights above the floor scale, the box grows to hold the
// rotated corners; an invalid region stays invalid.
TEST(RegionOfInterestTest, TransformRegionCarriesBoxAndFloor) {
  RegionOfInterest r;
  r.valid = true;
  r.box_min = Eigen::Vector3d(-100, -50, -10);
  r.box_max = Eigen::Vector3d(100, 50, 200);
  r.has_floor = true;
  r.floor.normal = Eigen::Vector3d(0.05, 0, 1).normalized();
  r.floor.offset_mm = -4;
  r.floor_clearance_mm = 3;
  Sim3 sim;
  sim.scale = 1.2;
  sim.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.1, 0.2, 1).normalized()).toRotationMatrix();
  sim.translation = Eigen::Vector3d(300, -200, 50);
  const RegionOfInterest t = TransformRegion(r, sim);
  ASSERT_TRUE(t.valid);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 100), Eigen::Vector3d(90, -40, 150), Eigen::Vector3d(-95, 45, 30)}) {
    EXPECT_TRUE(t.Contains(sim * p)) << p.transpose();
    EXPECT_NEAR(t.HeightAboveFloor(sim * p), sim.scale * r.HeightAboveFloor(p), 1e-9);
  }
  EXPECT_FALSE(t.Contains(sim * Eigen::Vector3d(0, 0, 1)));  // under the clearance (1.2 * 3 mm) after the move
  EXPECT_DOUBLE_EQ(t.floor_clearance_mm, 3.6);
  RegionOfInterest none;
  EXPECT_FALSE(TransformRegion(none, sim).valid);
}

}  // namespace
}  // namespace objscan
