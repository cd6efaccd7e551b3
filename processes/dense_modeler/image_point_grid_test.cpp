#include "processes/dense_modeler/image_point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

namespace objscan {
namespace {

struct GridCase {
  int width, height;
  double cell_px;
};

// Points inside and outside the image, queries inside and outside it, cells of a power-of-two width, of a width that
// is not, and a single cell: the ring searches give exactly what sorting every point gives (ties: the lower index
// first), and AnyNear finds every point within the cell width.
TEST(ImagePointGrid, RingSearchesMatchBruteForce) {
  std::mt19937 rng(7);
  for (const GridCase& g : {GridCase{640, 480, 16}, GridCase{640, 480, 13.7}, GridCase{100, 50, 200}}) {
    std::uniform_real_distribution<double> x(-100, g.width + 100), y(-100, g.height + 100);
    for (const int n : {0, 1, 5, 300}) {
      std::vector<Eigen::Vector2d> points;
      for (int i = 0; i < n; ++i) points.emplace_back(x(rng), y(rng));
      if (n > 7) points[7] = points[3];  // a tie wherever they are among the nearest
      ImagePointGrid grid(g.width, g.height, g.cell_px);
      for (int i = 0; i < n; ++i) grid.Insert(points[i], i);
      std::vector<std::pair<double, size_t>> near, all;
      for (int q = 0; q < 200; ++q) {
        // Every fourth query on the tied pair: both at distance 0, the lower index first.
        const bool at_tie = n > 7 && q % 4 == 0;
        const Eigen::Vector2d p = at_tie ? points[3] : Eigen::Vector2d(x(rng), y(rng));
        all.clear();
        for (size_t i = 0; i < points.size(); ++i) all.emplace_back((points[i] - p).squaredNorm(), i);
        std::sort(all.begin(), all.end());
        const double nearest = grid.NearestDistance(points, p);
        if (n == 0) {
          EXPECT_TRUE(std::isinf(nearest));
        } else {
          EXPECT_EQ(nearest, std::sqrt(all[0].first)) << "cell " << g.cell_px << " n " << n;
        }
        for (const size_t k : {1, 4, 10}) {
          grid.NearestK(points, p, k, &near);
          const size_t expected = std::min(k, all.size());
          ASSERT_EQ(near.size(), expected);
          for (size_t j = 0; j < expected; ++j) {
            EXPECT_EQ(near[j].second, all[j].second) << "cell " << g.cell_px << " n " << n << " k " << k;
            EXPECT_EQ(near[j].first, all[j].first);
          }
        }
        if (at_tie) {
          grid.NearestK(points, p, 4, &near);
          ASSERT_GE(near.size(), 2u);
          EXPECT_EQ(near[0].second, 3u);
          EXPECT_EQ(near[1].second, 7u);
        }
        const double r2 = g.cell_px * g.cell_px;
        for (const auto& [d2, i] : all)
          if (d2 <= r2) {
            EXPECT_TRUE(grid.AnyNear(p, [&](int j) { return static_cast<size_t>(j) == i; }));
          }
      }
    }
  }
}

}  // namespace
}  // namespace objscan
