#include "common/statistics.h"

#include <gtest/gtest.h>

#include <cmath>

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
  EXPECT_EQ(Percentile(v, std::nan("")), 0.0);  // not an index
}

TEST(Statistics, RecentValuesKeepTheLastCapacityAndTheMaxOfAll) {
  RecentValues r(3);
  EXPECT_TRUE(r.empty());
  EXPECT_EQ(r.max(), 0.0);
  for (double v : {9.0, 1.0, 2.0}) r.Add(v);
  EXPECT_EQ(r.values().size(), 3u);
  EXPECT_EQ(Percentile(r.values(), 1.0), 9.0);
  r.Add(3.0);  // overwrites the oldest (9)
  r.Add(4.0);  // then 1
  EXPECT_EQ(r.total(), 5u);
  EXPECT_EQ(r.values().size(), 3u);
  EXPECT_EQ(Percentile(r.values(), 0.0), 2.0);
  EXPECT_EQ(Percentile(r.values(), 1.0), 4.0);
  EXPECT_EQ(r.max(), 9.0);  // of every value, not only the kept ones
  RecentValues one(0);      // taken as 1
  one.Add(-5.0);
  one.Add(-7.0);
  EXPECT_EQ(one.capacity(), 1u);
  EXPECT_EQ(one.values().size(), 1u);
  EXPECT_EQ(one.values()[0], -7.0);
  EXPECT_EQ(one.max(), -5.0);  // negative values: the first sets the max
}

}  // namespace
}  // namespace objscan
