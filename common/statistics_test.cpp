#include "common/statistics.h"

#include <gtest/gtest.h>

namespace objscan {
namespace {

TEST(Statistics, PercentileByNearestRank) {
  EXPECT_EQ(Percentile({}, 0.5), 0.0);
  EXPECT_EQ(Percentile({7.0}, 0.9), 7.0);
  const std::vector<double> v = {5, 1, 4, 2, 3, 10, 9, 8, 7, 6, 11};  // 1..11, shuffled
  EXPECT_EQ(Percentile(v, 0.0), 1.0);
  EXPECT_EQ(Percentile(v, 0.5), 6.0);
  EXPECT_EQ(Percentile(v, 0.9), 10.0);
  EXPECT_EQ(Percentile(v, 1.0), 11.0);
  EXPECT_EQ(Percentile(v, 0.96), 11.0);  // round(0.96 * 10) = 10
  EXPECT_EQ(Percentile(v, 2.0), 11.0);   // clamped
  EXPECT_EQ(Percentile(v, -1.0), 1.0);
}

}  // namespace
}  // namespace objscan
