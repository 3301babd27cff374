#include "common/stats.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

TEST(Stats, MedianIsNumpysAndUpperMedianAValueOfTheSample) {
  EXPECT_FALSE(Median({}).has_value());
  EXPECT_DOUBLE_EQ(*Median({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(*Median({4, 1, 3, 2}), 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(UpperMedian({4, 1, 3, 2}), 3.0);
  EXPECT_DOUBLE_EQ(UpperMedian({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(UpperMedian({}), 0.0);
}

TEST(Stats, PercentileIsTheNearestRank) {
  const std::vector<double> v{15, 20, 35, 40, 50};
  EXPECT_DOUBLE_EQ(*PercentileNearestRank(v, 30), 20.0);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank(v, 40), 20.0);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank(v, 50), 35.0);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank(v, 100), 50.0);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank(v, 0), 15.0);
  EXPECT_FALSE(PercentileNearestRank({}, 50).has_value());
}

}  // namespace
}  // namespace rumi
