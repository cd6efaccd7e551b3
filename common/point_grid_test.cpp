#include "common/point_grid.h"

#include <gtest/gtest.h>

#include <random>

namespace objscan {
namespace {

// Neighbour queries agree with brute force, for radii smaller and larger than a cell.
TEST(PointGrid, QueriesMatchBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 2000; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  const PointGrid grid(points, 5.0);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d x(u(rng), u(rng), u(rng));
    for (double radius : {2.0, 5.0, 12.0}) {
      std::vector<int> found, expected;
      grid.ForEachWithin(x, radius, [&](int i) { found.push_back(i); });
      for (int i = 0; i < static_cast<int>(points.size()); ++i)
        if ((points[i] - x).norm() <= radius) expected.push_back(i);
      std::sort(found.begin(), found.end());
      EXPECT_EQ(found, expected) << "query " << q << " radius " << radius;
    }
  }
}

}  // namespace
}  // namespace objscan
