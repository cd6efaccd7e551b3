#include "common/kd_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace objscan {
namespace {

double BruteForce(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& p : points)
    if (p.allFinite()) best = std::min(best, (p - q).norm());
  return best;
}

// Exact against brute force near the points, far from them (a misaligned model) and on a thin surface.
TEST(KdTree, NearestDistanceMatchesBruteForceAtAnyDistance) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-50, 50), far(-2000, 2000);
  std::vector<Eigen::Vector3d> cloud, shell;
  for (int i = 0; i < 3000; ++i) cloud.emplace_back(u(rng), u(rng), u(rng));
  for (int i = 0; i < 3000; ++i) shell.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 100.0);
  for (const auto* points : {&cloud, &shell}) {
    const KdTree tree(*points);
    for (int q = 0; q < 300; ++q) {
      const Eigen::Vector3d near(u(rng), u(rng), u(rng)), away(far(rng), far(rng), far(rng));
      EXPECT_DOUBLE_EQ(tree.NearestDistance(near), BruteForce(*points, near)) << "query " << q;
      EXPECT_DOUBLE_EQ(tree.NearestDistance(away), BruteForce(*points, away)) << "query " << q;
    }
    EXPECT_DOUBLE_EQ(tree.NearestDistance((*points)[17]), 0.0);
  }
}

TEST(KdTree, DuplicatesEmptyAndNonFinite) {
  std::vector<Eigen::Vector3d> same(100, Eigen::Vector3d(1, 2, 3));
  same.emplace_back(std::nan(""), 0, 0);
  const KdTree tree(same);
  EXPECT_DOUBLE_EQ(tree.NearestDistance({1, 2, 7}), 4.0);
  EXPECT_TRUE(std::isinf(tree.NearestDistance({std::nan(""), 0, 0})));
  const KdTree empty({});
  EXPECT_TRUE(empty.empty());
  EXPECT_TRUE(std::isinf(empty.NearestDistance({0, 0, 0})));
}

}  // namespace
}  // namespace objscan
