#include "processes/dense_modeler/image_point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace objscan {
namespace {

// Points inside and outside a 640 x 480 image, queries inside it: the ring searches give what sorting every point
// gives, and AnyNear finds every point within the cell size.
TEST(ImagePointGrid, RingSearchesMatchBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-100, 740), y(-100, 580), qx(-0.5, 639.5), qy(-0.5, 479.5);
  for (const int n : {0, 1, 5, 300}) {
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i < n; ++i) points.emplace_back(x(rng), y(rng));
    if (n > 7) points[7] = points[3];  // a tie: the lower index comes first
    ImagePointGrid grid(640, 480, 16);
    for (int i = 0; i < n; ++i) grid.Insert(points[i], i);
    std::vector<std::pair<double, size_t>> near, all;
    for (int q = 0; q < 200; ++q) {
      const Eigen::Vector2d p(qx(rng), qy(rng));
      all.clear();
      for (size_t i = 0; i < points.size(); ++i) all.emplace_back((points[i] - p).squaredNorm(), i);
      std::sort(all.begin(), all.end());
      const double nearest = grid.NearestDistance(points, p);
      if (n == 0) {
        EXPECT_TRUE(std::isinf(nearest));
      } else {
        EXPECT_DOUBLE_EQ(nearest, std::sqrt(all[0].first));
      }
      for (const size_t k : {1, 4, 10}) {
        grid.NearestK(points, p, k, &near);
        const size_t expected = std::min(k, all.size());
        ASSERT_EQ(near.size(), expected);
        for (size_t j = 0; j < expected; ++j) {
          EXPECT_EQ(near[j].second, all[j].second) << "n " << n << " k " << k << " j " << j;
          EXPECT_EQ(near[j].first, all[j].first);
        }
      }
      int within = 0, found = 0;
      for (const auto& [d2, i] : all) within += d2 <= 16.0 * 16.0;
      for (const auto& [d2, i] : all)
        if (d2 <= 16.0 * 16.0) found += grid.AnyNear(p, [&](int j) { return static_cast<size_t>(j) == i; });
      EXPECT_EQ(found, within);
    }
  }
}

}  // namespace
}  // namespace objscan
