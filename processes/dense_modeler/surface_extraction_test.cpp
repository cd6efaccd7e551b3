#include "processes/dense_modeler/surface_extraction.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace objscan {
namespace {

constexpr double kRadius = 40.0;  // mm
const Eigen::Vector3d kCentre(3.3, -2.1, 50.7);

// Noisy samples of a sphere voted into a 2 mm grid, as the dense pairs would: each point scattered along the normal
// (sigma 0.8 mm) and tagged with the direction towards a camera outside.
VoxelVoteGrid NoisySphereVotes(int points, uint32_t seed) {
  VoxelVoteGrid grid;
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int i = 0; i < points; ++i) {
    Eigen::Vector3d n(gauss(rng), gauss(rng), gauss(rng));
    n.normalize();
    const Eigen::Vector3d p = kCentre + (kRadius + 0.8 * gauss(rng)) * n;
    grid.AddPoint(p, {{100, 150, 200}}, n.cast<float>());
  }
  return grid;
}

TEST(SurfaceExtractionTest, RidgeIsThinAccurateAndOutward) {
  const VoxelVoteGrid grid = NoisySphereVotes(400000, 1);
  const std::vector<VoxelRecord> seeds = grid.Extract(16);
  RidgeOptions options;
  RidgeStats stats;
  const std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, seeds, options, &stats);
  ASSERT_GT(ridge.size(), 1000u);
  EXPECT_EQ(stats.seeds, static_cast<int64_t>(seeds.size()));
  // The shell of seeds is several voxels thick; the ridge about one (sphere area / voxel face ~ 5000 voxels).
  const double sphere_voxels = 4 * M_PI * kRadius * kRadius / (2.0 * 2.0);
  EXPECT_GT(static_cast<double>(seeds.size()), 2.0 * sphere_voxels);
  EXPECT_LT(static_cast<double>(ridge.size()), 1.6 * sphere_voxels);
  EXPECT_GT(static_cast<double>(ridge.size()), 0.8 * sphere_voxels);
  std::vector<double> centre_error, point_error;
  int outward = 0;
  for (const SurfaceVoxel& s : ridge) {
    const Eigen::Vector3d radial = (grid.CenterOf(s.voxel.ijk) - kCentre).normalized();
    centre_error.push_back(std::abs((grid.CenterOf(s.voxel.ijk) - kCentre).norm() - kRadius));
    point_error.push_back(std::abs((s.point_in_world - kCentre).norm() - kRadius));
    outward += s.normal.dot(radial) > 0.9;
  }
  std::sort(centre_error.begin(), centre_error.end());
  std::sort(point_error.begin(), point_error.end());
  const size_t p90 = centre_error.size() * 9 / 10;
  EXPECT_LT(centre_error[p90], 1.5);  // voxel centres: within the voxel that the surface crosses
  EXPECT_LT(point_error[p90], 0.6);   // sub-voxel points: much closer
  EXPECT_GT(outward, static_cast<int>(0.98 * ridge.size()));
}

TEST(SurfaceExtractionTest, SmallFragmentsAreDropped) {
  VoxelVoteGrid grid = NoisySphereVotes(200000, 2);
  // A stray blob far from the sphere.
  for (int i = 0; i < 200; ++i) grid.AddPoint(Eigen::Vector3d(200, 200, 200), {{0, 0, 0}});
  RidgeOptions options;
  options.min_component_voxels = 30;
  RidgeStats stats;
  const std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, grid.Extract(16), options, &stats);
  for (const SurfaceVoxel& s : ridge) EXPECT_LT((s.point_in_world - kCentre).norm(), kRadius + 5);
  EXPECT_GT(stats.fragments_dropped, 0);
  options.min_component_voxels = 0;
  options.min_component_fraction = 0;
  const std::vector<SurfaceVoxel> all = ExtractVoteRidge(grid, grid.Extract(16), options);
  EXPECT_GT(all.size(), ridge.size());
  // The blob is also small relative to the sphere's ridge: the relative criterion alone drops it.
  options.min_component_fraction = 0.01;
  RidgeStats relative;
  const std::vector<SurfaceVoxel> kept = ExtractVoteRidge(grid, grid.Extract(16), options, &relative);
  EXPECT_EQ(kept.size(), ridge.size());
  EXPECT_GT(relative.fragments_dropped, 0);
}

TEST(SurfaceExtractionTest, SmoothingPullsWeakBiasedPointsOntoTheSurface) {
  const VoxelVoteGrid grid = NoisySphereVotes(400000, 5);
  std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions());
  ASSERT_GT(ridge.size(), 1000u);
  // Every 10th point: few votes and 3 mm inside (a chord of a weak match), as in the shadowed part of a scene.
  for (size_t i = 0; i < ridge.size(); i += 10) {
    ridge[i].voxel.votes = 20;
    ridge[i].point_in_world -= 3.0 * ridge[i].normal;
  }
  auto radial_error = [](const SurfaceVoxel& s) { return std::abs((s.point_in_world - kCentre).norm() - kRadius); };
  const std::vector<SurfaceVoxel> smooth = SmoothSurfacePoints(ridge, grid.voxel_size(), 4.0);
  ASSERT_EQ(smooth.size(), ridge.size());
  std::vector<double> biased, others;
  int outward = 0;
  for (size_t i = 0; i < smooth.size(); ++i) {
    EXPECT_EQ(smooth[i].voxel.ijk, ridge[i].voxel.ijk);
    (i % 10 == 0 ? biased : others).push_back(radial_error(smooth[i]));
    outward += smooth[i].normal.dot((smooth[i].point_in_world - kCentre).normalized()) > 0.98;
  }
  std::sort(biased.begin(), biased.end());
  std::sort(others.begin(), others.end());
  EXPECT_LT(biased[biased.size() * 9 / 10], 0.8);  // was 3 mm
  EXPECT_LT(others[others.size() * 9 / 10], 0.6);  // plane fit on a 40 mm sphere: small inward bias only
  EXPECT_GT(outward, static_cast<int>(0.97 * smooth.size()));
  // Radius 0: unchanged.
  const std::vector<SurfaceVoxel> same = SmoothSurfacePoints(ridge, grid.voxel_size(), 0.0);
  ASSERT_EQ(same.size(), ridge.size());
  EXPECT_EQ(same[0].point_in_world, ridge[0].point_in_world);
}

// Points exactly on a curved surface stay on it: a plane through the weighted centroid of a neighbourhood of radius r
// on a sphere of radius R lies inside by about (r/2)^2 / R (0.32 mm for r = 16 mm on R = 100 mm); the quadratic height
// field removes that bias.
TEST(SurfaceExtractionTest, SmoothingHasNoCurvatureBias) {
  constexpr double kSphereRadius = 100.0, kVoxel = 2.0;
  std::vector<SurfaceVoxel> points;
  const Eigen::Vector3d centre(0, 0, 100);
  for (int i = 0; i < 20000; ++i) {  // Fibonacci sphere: ~2.5 mm spacing, like ridge points of 2 mm voxels
    const double z = 1.0 - 2.0 * (i + 0.5) / 20000, r = std::sqrt(1.0 - z * z), phi = i * 2.39996322972865332;
    SurfaceVoxel s;
    s.normal = Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
    s.point_in_world = centre + kSphereRadius * s.normal;
    s.voxel.votes = 100 + i % 50;
    points.push_back(s);
  }
  const std::vector<SurfaceVoxel> smooth = SmoothSurfacePoints(points, kVoxel, 8.0);
  ASSERT_EQ(smooth.size(), points.size());
  double mean_signed = 0, worst = 0, worst_normal_deg = 0;
  for (const SurfaceVoxel& s : smooth) {
    const double e = (s.point_in_world - centre).norm() - kSphereRadius;
    mean_signed += e / smooth.size();
    worst = std::max(worst, std::abs(e));
    const double c = std::clamp(s.normal.dot((s.point_in_world - centre).normalized()), -1.0, 1.0);
    worst_normal_deg = std::max(worst_normal_deg, std::acos(c) * 180 / M_PI);
  }
  EXPECT_LT(std::abs(mean_signed), 0.02);  // mm (a plane fit: about -0.3)
  EXPECT_LT(worst, 0.05);                  // mm
  EXPECT_LT(worst_normal_deg, 1.0);
}

TEST(SurfaceExtractionTest, MeshThroughSurfacePointsLiesOnTheSphere) {
  const VoxelVoteGrid grid = NoisySphereVotes(400000, 3);
  const std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions());
  const TriangleMesh mesh = MeshFromSurfacePoints(ridge, grid.voxel_size());
  ASSERT_GT(mesh.triangles.size(), 1000u);
  std::vector<double> error;
  for (const Eigen::Vector3f& v : mesh.vertices)
    error.push_back(std::abs((v.cast<double>() - kCentre).norm() - kRadius));
  std::sort(error.begin(), error.end());
  EXPECT_LT(error[error.size() * 9 / 10], 0.5);
  EXPECT_LT(error.back(), 2.0);
  // Colour of the points.
  EXPECT_EQ(mesh.bgr[0][2], 200);
}

TEST(SurfaceExtractionTest, MeshLeavesUnseenPartsOpen) {
  const VoxelVoteGrid grid = NoisySphereVotes(400000, 4);
  std::vector<SurfaceVoxel> ridge = ExtractVoteRidge(grid, grid.Extract(16), RidgeOptions());
  // Nothing seen below the equator.
  ridge.erase(std::remove_if(ridge.begin(), ridge.end(),
                             [](const SurfaceVoxel& s) { return s.point_in_world.z() < kCentre.z(); }),
              ridge.end());
  const TriangleMesh mesh = MeshFromSurfacePoints(ridge, grid.voxel_size());
  ASSERT_GT(mesh.triangles.size(), 500u);
  for (const Eigen::Vector3f& v : mesh.vertices) EXPECT_GT(v.z(), kCentre.z() - 5);  // no invented bottom
  EXPECT_FALSE(IsClosedOrientedMesh(mesh));
}

TEST(SurfaceExtractionTest, EmptyInputAndOptions) {
  VoxelVoteGrid grid;
  EXPECT_TRUE(ExtractVoteRidge(grid, {}, RidgeOptions()).empty());
  EXPECT_TRUE(MeshFromSurfacePoints({}, 2.0).triangles.empty());
  RidgeOptions bad;
  bad.normal_radius = 0;
  std::string why;
  EXPECT_FALSE(ValidateRidgeOptions(bad, &why));
  EXPECT_NE(why.find("normal_radius"), std::string::npos);
  EXPECT_TRUE(ValidateRidgeOptions(RidgeOptions(), &why));
  RidgeOptions bad_smoothing;
  bad_smoothing.smoothing_radius = 0.5;
  EXPECT_FALSE(ValidateRidgeOptions(bad_smoothing, &why));
  EXPECT_NE(why.find("smoothing_radius"), std::string::npos);
  RidgeOptions bad_curl;
  bad_curl.curled_borders.max_angle_deg = 0;
  EXPECT_FALSE(ValidateRidgeOptions(bad_curl, &why));
  EXPECT_NE(why.find("curl max_angle_deg"), std::string::npos);
  EXPECT_TRUE(SmoothSurfacePoints({}, 2.0, 4.0).empty());
}

}  // namespace
}  // namespace objscan
