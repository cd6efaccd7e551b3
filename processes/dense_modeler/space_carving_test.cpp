#include "processes/dense_modeler/space_carving.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <set>
#include <tuple>

#include "processes/dense_modeler/dense_model.h"
#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

using testing_scene::SphereScene;
using Ijk = std::tuple<int, int, int>;

TEST(SpaceCarving, RemovesInconsistentVoxelsKeepsSurfaceAndOccluded) {
  SphereScene scene;
  scene.center = Eigen::Vector3d(0, 0, 40);
  scene.radius = 30;
  const double size = 2.0;
  std::vector<CarvingView> views;
  const int n_views = 16;
  for (int i = 0; i < n_views; ++i) {
    const double height = i % 2 ? 140 : 40;  // two rings
    const Eigen::Isometry3d pose = scene.RingPose(i, n_views, 350, height);
    views.push_back(MakeCarvingView(scene.camera, pose, scene.Render(pose), 2));
  }
  // Solid ball of voxels (truth), coloured grey (carving recolours the surface).
  std::vector<VoxelRecord> seeds;
  std::set<Ijk> truth_surface, interior, spurious;
  auto inside = [&](const Eigen::Vector3i& v) {
    return ((v.cast<double>() + Eigen::Vector3d::Constant(0.5)) * size - scene.center).norm() <= scene.radius;
  };
  for (int k = -5; k < 45; ++k)
    for (int j = -20; j < 20; ++j)
      for (int i = -20; i < 20; ++i) {
        const Eigen::Vector3i v(i, j, k);
        if (!inside(v)) continue;
        VoxelRecord r;
        r.ijk = v;
        r.votes = 20;
        seeds.push_back(r);
        bool surface = false;
        for (int a = 0; a < 3; ++a)
          for (int s : {-1, 1}) {
            Eigen::Vector3i n = v;
            n[a] += s;
            surface = surface || !inside(n);
          }
        (surface ? truth_surface : interior).insert({i, j, k});
      }
  // Spurious voxels: small blobs floating 4-8 mm outside the surface (they project onto textured sphere parts
  // that differ from view to view).
  for (const Eigen::Vector3d& dir : {Eigen::Vector3d(1, 0, 0.2), Eigen::Vector3d(-0.3, 1, 0.1),
                                     Eigen::Vector3d(0.5, -0.7, 0.6), Eigen::Vector3d(-0.8, -0.4, -0.1)}) {
    const Eigen::Vector3d c = scene.center + (scene.radius + 6) * dir.normalized();
    const Eigen::Vector3i base((c / size).array().floor().cast<int>());
    for (int dz = 0; dz < 2; ++dz)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          VoxelRecord r;
          r.ijk = base + Eigen::Vector3i(dx, dy, dz);
          r.votes = 20;
          seeds.push_back(r);
          spurious.insert({r.ijk.x(), r.ijk.y(), r.ijk.z()});
        }
  }
  SpaceCarvingOptions o;
  SpaceCarvingStats st;
  const auto kept = CarveVoxels(seeds, size, views, o, &st);
  std::set<Ijk> kept_set;
  for (const auto& v : kept) kept_set.insert({v.ijk.x(), v.ijk.y(), v.ijk.z()});
  int spurious_left = 0, surface_kept = 0, interior_kept = 0;
  for (const auto& v : kept)
    if (spurious.count({v.ijk.x(), v.ijk.y(), v.ijk.z()})) {
      ++spurious_left;
      std::printf("spurious voxel left: (%d %d %d) views %d stddev %.1f\n", v.ijk.x(), v.ijk.y(), v.ijk.z(), v.views,
                  v.color_stddev);
    }
  for (const auto& s : truth_surface) surface_kept += kept_set.count(s);
  for (const auto& s : interior) interior_kept += kept_set.count(s);
  std::printf(
      "carving: %lld seeds, %lld removed in %d passes; spurious left %d of %zu, surface kept %d of %zu, "
      "interior kept %d of %zu\n",
      static_cast<long long>(st.seeds), static_cast<long long>(st.removed), st.iterations, spurious_left,
      spurious.size(), surface_kept, truth_surface.size(), interior_kept, interior.size());
  EXPECT_EQ(spurious_left, 0);
  EXPECT_GE(surface_kept, 0.97 * truth_surface.size());
  EXPECT_EQ(interior_kept, static_cast<int>(interior.size()));  // occluded voxels untouched
  // Interior voxels were never seen: grey seed colour, no views.
  for (const auto& v : kept)
    if (interior.count({v.ijk.x(), v.ijk.y(), v.ijk.z()})) {
      EXPECT_EQ(v.views, 0);
      EXPECT_EQ(v.bgr[0], 128);
    }
  // Passes stop once one removes less than min_removed_fraction of the seeds; 0 runs until a pass removes nothing.
  o.min_removed_fraction = 0;
  SpaceCarvingStats until_none;
  CarveVoxels(seeds, size, views, o, &until_none);
  ASSERT_FALSE(until_none.removed_per_iteration.empty());
  EXPECT_EQ(until_none.removed_per_iteration.back(), 0);
  o.min_removed_fraction = 0.999;
  SpaceCarvingStats one_pass;
  CarveVoxels(seeds, size, views, o, &one_pass);
  EXPECT_EQ(one_pass.iterations, 1);
  EXPECT_EQ(one_pass.removed, until_none.removed_per_iteration.front());
}

TEST(SpaceCarving, NoViewsOrBadOptionsKeepEverything) {
  std::vector<VoxelRecord> seeds(3);
  for (int i = 0; i < 3; ++i) seeds[i].ijk = Eigen::Vector3i(i, 0, 0);
  SpaceCarvingStats st;
  EXPECT_EQ(CarveVoxels(seeds, 2.0, {}, SpaceCarvingOptions(), &st).size(), 3u);
  CarvingView broken;  // empty image: ignored
  SpaceCarvingOptions bad;
  bad.min_views = 1;
  EXPECT_FALSE(ValidateSpaceCarvingOptions(bad, nullptr));
  EXPECT_EQ(CarveVoxels(seeds, 2.0, {broken}, bad, &st).size(), 3u);
}

}  // namespace
}  // namespace objscan
