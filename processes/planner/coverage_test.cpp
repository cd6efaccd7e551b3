#include "processes/planner/coverage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "processes/planner/next_best_view.h"
#include "processes/planner/path_search.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A 160 x 140 x 100 mm box target at (2000, 1000) on the floor, rotated 20 deg.
TargetBox Box() { return {Eigen::Vector3d(2000, 1000, 50), Eigen::Vector3d(160, 140, 100), 20 * kDeg}; }

// Voxel centres (10 mm) on the box's sides (not the top): what a dense model of a plain circle gives.
VoxelCloud SideVoxels(const TargetBox& box) {
  VoxelCloud v;
  v.voxel_size_mm = 10;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(box.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d h = 0.5 * box.size_mm;
  for (double z = 15; z < box.size_mm.z(); z += 10) {
    for (double x = -h.x() + 5; x < h.x(); x += 10)
      for (double sy : {-1.0, 1.0}) v.centres_mm.push_back(box.centre_mm + r * Eigen::Vector3d(x, sy * h.y(), z - h.z()));
    for (double y = -h.y() + 5; y < h.y(); y += 10)
      for (double sx : {-1.0, 1.0}) v.centres_mm.push_back(box.centre_mm + r * Eigen::Vector3d(sx * h.x(), y, z - h.z()));
  }
  return v;
}

// Camera poses of a robot circling the target at `radius`, head on the box centre, every `step_deg`.
std::vector<Eigen::Isometry3d> Circle(const TargetBox& box, double radius, double step_deg) {
  std::vector<Eigen::Isometry3d> poses;
  for (double a = 0; a < 360; a += step_deg) {
    const BasePose base{box.centre_mm.x() + radius * std::cos(a * kDeg), box.centre_mm.y() + radius * std::sin(a * kDeg),
                        (a + 90) * kDeg};
    double pan, tilt;
    AimHead(RobotGeometry{}, base, box.centre_mm, &pan, &tilt);
    poses.push_back(WorldFromCamera(RobotGeometry{}, base, pan, tilt));
  }
  return poses;
}

TEST(CoverageModelTest, BoxSamplesStandForSurfaceNotModelledYet) {
  CoverageModel coverage;
  coverage.SetTarget(Box());
  coverage.Update();
  // Top 8 x 7 (20 mm), sides 2 x (8 + 7) x 5; the bottom is left out.
  EXPECT_EQ(coverage.num_samples(), 8 * 7 + 2 * (8 + 7) * 5);
  for (const SurfaceSample& s : coverage.samples()) EXPECT_TRUE(s.from_box);
  EXPECT_EQ(coverage.Fraction(), 0.0);
  // With the sides modelled, the side box samples give way to voxel samples with PCA normals.
  coverage.SetVoxels(SideVoxels(Box()));
  coverage.Update();
  int inner_top = 0, voxel = 0;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(Box().yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (const SurfaceSample& s : coverage.samples()) {
    const Eigen::Vector3d local = r.transpose() * (s.position_mm - Box().centre_mm);
    if (s.from_box) {
      EXPECT_NEAR(s.normal.z(), 1.0, 1e-12);  // only the top is left (its rim is within 30 mm of side voxels)
      inner_top += std::abs(local.x()) <= 80 - 35 && std::abs(local.y()) <= 70 - 35;
      continue;
    }
    ++voxel;
    // The normal is the face normal away from the edges, and points outward.
    if (std::abs(std::abs(local.x()) - 80) < 1 && std::abs(local.y()) < 40 && local.z() < 20) {
      EXPECT_GT(std::abs(s.normal.dot(r.col(0))), 0.99);
    }
    EXPECT_GT(s.normal.dot(s.position_mm - Box().centre_mm), 0.0);
  }
  EXPECT_EQ(inner_top, 4 * 3);  // top samples at x = -30..30, y = -20..20 are all kept: no voxel near them
  EXPECT_GT(voxel, 50);
}

TEST(CoverageModelTest, ACircleAtMastHeightCoversTheSidesButNotTheTop) {
  CoverageModel coverage;
  coverage.SetTarget(Box());
  coverage.SetVoxels(SideVoxels(Box()));
  for (const Eigen::Isometry3d& pose : Circle(Box(), 800, 2)) EXPECT_TRUE(coverage.AddView(pose));
  coverage.Update();
  int side = 0, side_covered = 0, top = 0, top_covered = 0;
  for (const SurfaceSample& s : coverage.samples()) {
    if (s.from_box) {
      ++top;
      top_covered += s.views >= 2;
    } else {
      ++side;
      side_covered += s.views >= 2;
    }
  }
  EXPECT_EQ(side_covered, side);  // every side sample seen at <= 60 deg from >= 2 views
  EXPECT_EQ(top_covered, 0);      // the top from 400 mm at 800 mm: ~68 deg incidence
  EXPECT_NEAR(coverage.Fraction(), static_cast<double>(side) / (side + top), 1e-12);
  // A pose 10 mm from the last one is not a new view.
  const Eigen::Isometry3d last = Circle(Box(), 800, 2).back();
  Eigen::Isometry3d near_last = last;
  near_last.translation().x() += 10;
  EXPECT_FALSE(coverage.AddView(near_last));
}

// A free, textured floor around the target, the target's own landmarks as obstacles.
OccupancyMap OpenMap(const TargetBox& box) {
  OccupancyMapOptions options;
  options.size_mm = 8000;
  OccupancyMap map(options);
  std::vector<MapLandmark> l;
  for (double x = -500; x <= 4000; x += 50)
    for (double y = -1500; y <= 3000; y += 50) {
      MapLandmark floor;
      floor.position_mm = Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), 0.f);
      floor.observations = 3;
      l.push_back(floor);
    }
  for (const Eigen::Vector3d& p : SideVoxels(box).centres_mm) {
    MapLandmark o;
    o.position_mm = p.cast<float>();
    o.observations = 3;
    l.push_back(o);
  }
  map.SetLandmarks(l);
  map.MarkFootprint({0, 0});
  map.Update();
  return map;
}

TEST(NextBestViewTest, PicksAViewOfTheUncoveredTopInsteadOfRepeatingTheCircle) {
  const TargetBox box = Box();
  CoverageModel coverage;
  coverage.SetTarget(box);
  coverage.SetVoxels(SideVoxels(box));
  for (const Eigen::Isometry3d& pose : Circle(box, 800, 2)) coverage.AddView(pose);
  coverage.Update();
  const double before = coverage.Fraction();
  const OccupancyMap map = OpenMap(box);
  CostField field;
  field.Compute(map, {0, 0});
  const NextViewResult result =
      ChooseNextView(coverage, map, field, RobotGeometry{}, RobotLimits{}, NextViewOptions{}, {});
  ASSERT_TRUE(result.found);
  const ViewCandidate& v = result.best;
  EXPECT_LT(v.radius_mm, 800.0);        // closer than the circle ...
  EXPECT_GT(v.tilt_rad, 25 * kDeg);     // ... and looking down more steeply (circle: ~21 deg)
  EXPECT_GE(v.gain, 10);
  EXPECT_GT(result.candidates, 100);
  // The candidate's gain is top samples: after its capture (views along 10 deg of its ring) coverage rises.
  const double pan = v.pan_rad, tilt = v.tilt_rad;
  for (double d = 0; d <= 10; d += 2) {
    const double a = v.azimuth_rad + d * kDeg;
    const BasePose base{box.centre_mm.x() + v.radius_mm * std::cos(a), box.centre_mm.y() + v.radius_mm * std::sin(a),
                        a + M_PI / 2};
    double p, t;
    AimHead(RobotGeometry{}, base, v.aim_mm, &p, &t);
    coverage.AddView(WorldFromCamera(RobotGeometry{}, base, p, t));
  }
  (void)pan;
  (void)tilt;
  coverage.Update();
  int top_covered = 0;
  for (const SurfaceSample& s : coverage.samples()) top_covered += s.from_box && s.views >= 2;
  EXPECT_GE(top_covered, v.gain / 2);
  EXPECT_GT(coverage.Fraction(), before);
  // The same candidate is not offered again once used.
  const NextViewResult again =
      ChooseNextView(coverage, map, field, RobotGeometry{}, RobotLimits{}, NextViewOptions{}, {v.key});
  ASSERT_TRUE(again.found);
  EXPECT_NE(again.best.key, v.key);
}

TEST(NextBestViewTest, NothingToGainOrNowhereToGoFindsNothing) {
  const TargetBox box = Box();
  CoverageModel coverage;  // no target
  const OccupancyMap map = OpenMap(box);
  CostField field;
  field.Compute(map, {0, 0});
  EXPECT_FALSE(ChooseNextView(coverage, map, field, RobotGeometry{}, RobotLimits{}, NextViewOptions{}, {}).found);
  // A target but a map where nothing is known: no candidate is reachable.
  coverage.SetTarget(box);
  coverage.Update();
  OccupancyMapOptions options;
  options.size_mm = 8000;
  OccupancyMap unknown(options);
  unknown.MarkFootprint({0, 0});
  unknown.Update();
  field.Compute(unknown, {0, 0});
  const NextViewResult r = ChooseNextView(coverage, unknown, field, RobotGeometry{}, RobotLimits{}, NextViewOptions{}, {});
  EXPECT_FALSE(r.found);
  EXPECT_EQ(r.candidates, 0);
}

}  // namespace
}  // namespace objscan
