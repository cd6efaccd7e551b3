#include "processes/dense_modeler/voxel_votes.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <tuple>

namespace objscan {
namespace {

VoxelVoteOptions Weights(int nb, int c, int f, int e, int k) {
  VoxelVoteOptions o;
  o.voxel_size_mm = 2.0;
  o.neighbourhood = nb;
  o.center_weight = c;
  o.face_weight = f;
  o.edge_weight = e;
  o.corner_weight = k;
  return o;
}

// Checks the exact 3x3x3 vote pattern around voxel c for `points` points with weights (c, f, e, k).
void ExpectPattern(const VoxelVoteGrid& g, const Eigen::Vector3i& c, int points, int wc, int wf, int we, int wk) {
  for (int dz = -2; dz <= 2; ++dz)
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const int ax = std::abs(dx), ay = std::abs(dy), az = std::abs(dz);
        int expected = 0;
        if (ax <= 1 && ay <= 1 && az <= 1) {
          const int order = ax + ay + az;
          expected = points * (order == 0 ? wc : order == 1 ? wf : order == 2 ? we : wk);
        }
        EXPECT_EQ(g.Votes(c + Eigen::Vector3i(dx, dy, dz)), expected) << dx << " " << dy << " " << dz;
      }
}

TEST(VoxelVotes, ExactCountsWith26NeighboursAcrossBlockBorders) {
  // Interior voxel, block-corner voxels on both sides of zero: the counts must be identical.
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(9.1, 9.3, 9.9), Eigen::Vector3d(15.5, 15.9, 14.1),
                                   Eigen::Vector3d(-0.5, -1.9, 0.2), Eigen::Vector3d(-16.1, 31.9, -2.0)}) {
    VoxelVoteGrid g(Weights(26, 5, 3, 2, 1));
    ASSERT_TRUE(g.AddPoint(p, {{10, 20, 30}}));
    ASSERT_TRUE(g.AddPoint(p + Eigen::Vector3d(0.01, 0.01, 0.01), {{30, 40, 50}}));
    const Eigen::Vector3i c = g.VoxelOf(p);
    ExpectPattern(g, c, 2, 5, 3, 2, 1);
    EXPECT_EQ(g.num_voxels(), 27);
    EXPECT_EQ(g.total_votes(), 2 * (5 + 6 * 3 + 12 * 2 + 8 * 1));
    const auto all = g.Extract(1);
    ASSERT_EQ(all.size(), 27u);
    const auto center = g.Extract(10);  // only the centre has 10 votes
    ASSERT_EQ(center.size(), 1u);
    EXPECT_EQ(center[0].ijk, c);
    EXPECT_EQ(center[0].color_count, 2);
    EXPECT_EQ(center[0].bgr[0], 20);
    EXPECT_EQ(center[0].bgr[2], 40);
  }
}

TEST(VoxelVotes, SixNeighbourhoodAndOwnVoxelOnly) {
  VoxelVoteGrid g6(Weights(6, 4, 1, 9, 9));
  g6.AddPoint(Eigen::Vector3d(1, 1, 1), {{0, 0, 0}});
  ExpectPattern(g6, Eigen::Vector3i(0, 0, 0), 1, 4, 1, 0, 0);
  EXPECT_EQ(g6.num_voxels(), 7);
  VoxelVoteGrid g0(Weights(0, 3, 9, 9, 9));
  g0.AddPoint(Eigen::Vector3d(1, 1, 1), {{0, 0, 0}});
  EXPECT_EQ(g0.num_voxels(), 1);
  EXPECT_EQ(g0.Votes(Eigen::Vector3i(0, 0, 0)), 3);
}

TEST(VoxelVotes, ExtractSortedAndRejectsBadPoints) {
  VoxelVoteGrid g(Weights(26, 4, 2, 1, 1));
  EXPECT_FALSE(g.AddPoint(Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0), {{0, 0, 0}}));
  EXPECT_FALSE(g.AddPoint(Eigen::Vector3d(1e12, 0, 0), {{0, 0, 0}}));
  EXPECT_EQ(g.total_votes(), 0);
  for (int i = 0; i < 50; ++i) g.AddPoint(Eigen::Vector3d(i * 7.3 - 100, i * 3.1, -i * 1.7), {{1, 2, 3}});
  const auto r = g.Extract(1);
  for (size_t i = 1; i < r.size(); ++i) {
    const auto& a = r[i - 1].ijk;
    const auto& b = r[i].ijk;
    EXPECT_TRUE(std::tie(a.z(), a.y(), a.x()) < std::tie(b.z(), b.y(), b.x()));
  }
  int64_t sum = 0;
  for (const auto& v : r) sum += v.votes;
  EXPECT_EQ(sum, g.total_votes());
  EXPECT_THROW(VoxelVoteGrid(Weights(7, 1, 1, 1, 1)), std::invalid_argument);
}

TEST(VoxelVotes, SnapshotRoundTripAndCorruptFiles) {
  VoxelVoteGrid g(Weights(26, 6, 2, 1, 1));
  for (int i = 0; i < 200; ++i)
    g.AddPoint(Eigen::Vector3d(std::sin(i) * 50, std::cos(i) * 50, i * 0.3), {{static_cast<uint8_t>(i), 7, 9}});
  const std::string path =
      (std::filesystem::temp_directory_path() / ("votes_test_" + std::to_string(::getpid()) + ".bin")).string();
  std::string error;
  ASSERT_TRUE(g.SaveSnapshot(path, &error)) << error;
  VoxelVoteGrid h;
  ASSERT_TRUE(h.LoadSnapshot(path, &error)) << error;
  EXPECT_EQ(h.options().center_weight, 6);
  EXPECT_EQ(h.total_votes(), g.total_votes());
  EXPECT_EQ(h.num_voxels(), g.num_voxels());
  const auto a = g.Extract(1), b = h.Extract(1);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].ijk, b[i].ijk);
    EXPECT_EQ(a[i].votes, b[i].votes);
    EXPECT_EQ(a[i].bgr, b[i].bgr);
  }
  // Truncated file: rejected, content unchanged.
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 10);
  EXPECT_FALSE(h.LoadSnapshot(path, &error));
  EXPECT_EQ(h.total_votes(), g.total_votes());
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << "not a snapshot at all, just text";
  }
  EXPECT_FALSE(h.LoadSnapshot(path, &error));
  EXPECT_FALSE(h.LoadSnapshot("/nonexistent/file.bin", &error));
  std::filesystem::remove(path);
}

TEST(VoxelVotes, AddPointsMatchesPointByPointAndBruteForce) {
  // Points clustered around block corners on both sides of zero (every place in a block, every border), some
  // repeated in the same voxel (their float direction sums must match exactly), plus rejected ones.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> offset(-9.0, 9.0);
  std::uniform_int_distribution<int> corner(-3, 3), colour(0, 255);
  std::vector<DensePoint> pts;
  for (int i = 0; i < 3000; ++i) {
    DensePoint p;
    p.point_in_world = Eigen::Vector3d(16.0 * corner(rng), 16.0 * corner(rng), 16.0 * corner(rng)) +
                       Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
    p.bgr = {{static_cast<uint8_t>(colour(rng)), static_cast<uint8_t>(colour(rng)), 7}};
    p.toward_camera = Eigen::Vector3f(offset(rng), offset(rng), offset(rng)).normalized();
    pts.push_back(p);
    if (i % 7 == 0) {
      p.point_in_world += Eigen::Vector3d(0.01, 0.01, 0.01);
      p.toward_camera = Eigen::Vector3f(0.3f, -0.1f, 0.7f);
      pts.push_back(p);
    }
  }
  pts[10].point_in_world.x() = std::numeric_limits<double>::quiet_NaN();
  pts[20].point_in_world.y() = 1e12;
  pts[30].toward_camera.z() = std::numeric_limits<float>::infinity();
  for (const VoxelVoteOptions& o :
       {Weights(26, 10, 2, 1, 1), Weights(26, 5, 0, 2, 0), Weights(6, 4, 3, 9, 9), Weights(0, 3, 9, 9, 9)}) {
    VoxelVoteGrid batch(o), single(o);
    EXPECT_EQ(batch.AddPoints(pts), static_cast<int>(pts.size()) - 2);
    for (const DensePoint& p : pts) single.AddPoint(p.point_in_world, p.bgr, p.toward_camera);
    // Brute force: the weight of every offset added to a map of voxels.
    std::map<std::tuple<int, int, int>, int64_t> expected;
    for (const DensePoint& p : pts) {
      if (!p.point_in_world.allFinite() || p.point_in_world.cwiseAbs().maxCoeff() > 1e6) continue;
      const Eigen::Vector3i c = batch.VoxelOf(p.point_in_world);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int order = std::abs(dx) + std::abs(dy) + std::abs(dz);
            const int w = order == 0             ? o.center_weight
                          : o.neighbourhood == 0 ? 0
                          : order == 1           ? o.face_weight
                          : o.neighbourhood == 6 ? 0
                          : order == 2           ? o.edge_weight
                                                 : o.corner_weight;
            if (w > 0) expected[{c.z() + dz, c.y() + dy, c.x() + dx}] += w;
          }
    }
    const auto a = batch.Extract(1), b = single.Extract(1);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.size(), expected.size());
    auto it = expected.begin();
    for (size_t i = 0; i < a.size(); ++i, ++it) {
      EXPECT_EQ(a[i].ijk, b[i].ijk);
      EXPECT_EQ(a[i].votes, b[i].votes);
      EXPECT_EQ(a[i].bgr, b[i].bgr);
      EXPECT_EQ(a[i].color_count, b[i].color_count);
      EXPECT_EQ(a[i].toward_camera, b[i].toward_camera);  // exact: same summation order per voxel
      EXPECT_EQ(std::make_tuple(a[i].ijk.z(), a[i].ijk.y(), a[i].ijk.x()), it->first);
      EXPECT_EQ(a[i].votes, it->second);
    }
    EXPECT_EQ(batch.num_voxels(), single.num_voxels());
    EXPECT_EQ(batch.total_votes(), single.total_votes());
    EXPECT_EQ(batch.points_added(), single.points_added());
  }
}

}  // namespace
}  // namespace objscan
