#include "processes/dense_modeler/surface_extraction.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

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

// Oriented points of a crease along y: the solid {x <= 0, z <= 0} (convex edge), its edge rounded by a fillet of
// radius fillet_mm (up to 0.41 x fillet_mm inside both faces) and its top face running on past the edge by 3 mm
// as a flap 1 mm thick (a lip, its top 0.3 mm high, a few points of its underside facing down). flip = outward normals
// reversed: the same surface as the concave crease of the complement.
std::vector<SurfaceVoxel> BevelledCrease(double fillet_mm, bool flip) {
  std::vector<SurfaceVoxel> pts;
  auto add = [&](double x, double y, double z, const Eigen::Vector3d& n) {
    SurfaceVoxel s;
    s.point_in_world = Eigen::Vector3d(x, y, z);
    s.normal = flip ? Eigen::Vector3d(-n) : n;
    s.voxel.votes = 20;
    pts.push_back(s);
  };
  for (double y = -20; y <= 20; y += 1.0) {
    for (double x = -24; x <= -fillet_mm; x += 1.0) add(x, y, 0, Eigen::Vector3d::UnitZ());
    for (double z = -24; z <= -fillet_mm; z += 1.0) add(0, y, z, Eigen::Vector3d::UnitX());
    for (double deg = 7.5; deg < 90; deg += 7.5) {
      const double t = deg * M_PI / 180;
      add(-fillet_mm + fillet_mm * std::sin(t), y, -fillet_mm + fillet_mm * std::cos(t),
          Eigen::Vector3d(std::sin(t), 0, std::cos(t)));
    }
    for (double x = 1; x <= 3; x += 1.0) add(x, y, 0.3, Eigen::Vector3d::UnitZ());
    // A few points of the lip's underside (every 4 mm along the edge): too few for a face, and not the wall's.
    if (std::fmod(y + 20, 4.0) == 0) add(2, y, -0.7, -Eigen::Vector3d::UnitZ());
  }
  return pts;
}

// Distance of p (in the x-z plane) to the boundary of the wedge {x <= 0, z <= 0}.
double DistanceToWedge(const Eigen::Vector3d& p) {
  if (p.x() <= 0 && p.z() <= 0) return std::min(-p.x(), -p.z());
  return std::hypot(std::max(p.x(), 0.0), std::max(p.z(), 0.0));
}

double MaxDistanceToWedge(const std::vector<SurfaceVoxel>& pts) {
  double worst = 0;
  for (const SurfaceVoxel& s : pts) worst = std::max(worst, DistanceToWedge(s.point_in_world));
  return worst;
}

TEST(SurfaceExtractionTest, SharpenCreasesRestoresConvexAndConcaveEdges) {
  CreaseOptions o;
  std::string why;
  ASSERT_TRUE(ValidateCreaseOptions(o, &why)) << why;
  for (const bool flip : {false, true}) {
    SCOPED_TRACE(flip ? "concave" : "convex");
    const std::vector<SurfaceVoxel> bevelled = BevelledCrease(6.0, flip);
    const double before = MaxDistanceToWedge(bevelled);
    int64_t moved = 0;
    const std::vector<SurfaceVoxel> sharp = SharpenCreases(bevelled, 2.0, o, &moved);
    ASSERT_EQ(sharp.size(), bevelled.size());
    // The underside's few points are too few for a face of their own: they stay (2 mm beyond the wall); every
    // other point lies on a face and takes its normal (up or out; reversed for the concave crease).
    double after = 0, worst_normal_deg = 0;
    int underside = 0;
    for (size_t i = 0; i < sharp.size(); ++i) {
      EXPECT_EQ(sharp[i].voxel.ijk, bevelled[i].voxel.ijk);
      if ((flip ? -1 : 1) * bevelled[i].normal.z() < -0.9) {
        ++underside;
        EXPECT_EQ(sharp[i].point_in_world, bevelled[i].point_in_world);
        continue;
      }
      after = std::max(after, DistanceToWedge(sharp[i].point_in_world));
      const Eigen::Vector3d n = flip ? Eigen::Vector3d(-sharp[i].normal) : sharp[i].normal;
      worst_normal_deg = std::max(worst_normal_deg, std::acos(std::min(1.0, std::max(n.z(), n.x()))) * 180 / M_PI);
    }
    std::printf("%s crease: max distance to the true faces %.2f mm -> %.3f mm, %lld of %zu points moved\n",
                flip ? "concave" : "convex", before, after, static_cast<long long>(moved), sharp.size());
    EXPECT_EQ(underside, 11);
    EXPECT_GT(before, 2.4);  // the fillet's middle: 6 x (sqrt(2) - 1) mm inside; the lip 3 mm beyond the wall
    EXPECT_LT(after, 0.2);   // the faces' planes lean a little towards the bevel points within 10 deg of them
    std::printf("  normals at most %.2f deg off their face's\n", worst_normal_deg);
    EXPECT_LT(worst_normal_deg, 1.5);
  }
}

TEST(SurfaceExtractionTest, SharpenCreasesLeavesSmoothSurfacesAlone) {
  // A 100 mm sphere (normals spread by ~10 deg over the neighbourhood) and a 30 mm one (~35 deg): one face each.
  for (const double radius : {100.0, 30.0}) {
    std::vector<SurfaceVoxel> pts;
    const int n = static_cast<int>(4 * M_PI * radius * radius / 2.0);  // ~one point per 2 mm^2
    const double golden = M_PI * (3 - std::sqrt(5.0));
    for (int i = 0; i < n; ++i) {
      const double z = 1 - 2 * (i + 0.5) / n, rr = std::sqrt(1 - z * z);
      SurfaceVoxel s;
      s.normal = Eigen::Vector3d(rr * std::cos(golden * i), rr * std::sin(golden * i), z);
      s.point_in_world = kCentre + radius * s.normal;
      s.voxel.votes = 20;
      pts.push_back(s);
    }
    int64_t moved = -1;
    const std::vector<SurfaceVoxel> out = SharpenCreases(pts, 2.0, CreaseOptions(), &moved);
    EXPECT_EQ(moved, 0) << radius;
    ASSERT_EQ(out.size(), pts.size());
    for (size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i].point_in_world, pts[i].point_in_world);
  }
  // Off, empty input and bad options.
  CreaseOptions off;
  off.radius_voxels = 0;
  const std::vector<SurfaceVoxel> bevelled = BevelledCrease(6.0, false);
  int64_t moved = -1;
  const std::vector<SurfaceVoxel> same = SharpenCreases(bevelled, 2.0, off, &moved);
  EXPECT_EQ(moved, 0);
  EXPECT_EQ(MaxDistanceToWedge(same), MaxDistanceToWedge(bevelled));
  EXPECT_TRUE(SharpenCreases({}, 2.0, CreaseOptions()).empty());
  CreaseOptions bad;
  bad.radius_voxels = 1;
  bad.min_angle_deg = 180;
  bad.core_angle_deg = 0;
  bad.min_face_points = 2;
  bad.max_move_voxels = 0;
  std::string why;
  EXPECT_FALSE(ValidateCreaseOptions(bad, &why));
  for (const char* field : {"radius_voxels", "min_angle_deg", "core_angle_deg", "min_face_points", "max_move_voxels"})
    EXPECT_NE(why.find(field), std::string::npos) << field;
  RidgeOptions ridge;
  ridge.creases = bad;
  EXPECT_FALSE(ValidateRidgeOptions(ridge, &why));
}

}  // namespace
}  // namespace objscan
