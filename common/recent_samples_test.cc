#include "common/recent_samples.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

TEST(Percentile, NearestRank) {
  EXPECT_EQ(Percentile({}, 0.5), 0);
  const std::vector<double> v = {5, 1, 4, 2, 3};
  EXPECT_EQ(Percentile(v, 0.0), 1);
  EXPECT_EQ(Percentile(v, 0.5), 3);
  EXPECT_EQ(Percentile(v, 0.8), 4);
  EXPECT_EQ(Percentile(v, 0.81), 5);
  EXPECT_EQ(Percentile(v, 1.0), 5);
  EXPECT_EQ(Percentile(v, 7.0), 5);  // clamped
}

TEST(RecentSamples, StaysBoundedAndKeepsTheMaxOfAll) {
  RecentSamples s(100);
  EXPECT_EQ(s.max(), 0);
  EXPECT_EQ(s.Percentile(0.5), 0);
  s.Add(1000);  // an early spike: out of the window later, still the max
  for (int i = 0; i < 100000; ++i) s.Add(i % 10);
  EXPECT_EQ(s.count(), 100001u);
  EXPECT_LE(s.held(), 200u);
  EXPECT_GE(s.held(), 100u);
  EXPECT_EQ(s.max(), 1000);
  EXPECT_EQ(s.Percentile(1.0), 9);  // the window holds only the recent values
  EXPECT_EQ(s.Percentile(0.0), 0);
  RecentSamples neg;
  neg.Add(-3);
  EXPECT_EQ(neg.max(), -3);  // not the 0 it started from
}

}  // namespace
}  // namespace rumi
