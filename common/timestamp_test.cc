#include "common/timestamp.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

namespace rumi {
namespace {

Timestamp Parse(const std::string& s) {
  Timestamp ns = -12345;
  EXPECT_TRUE(ParseSecondsToNs(s, &ns)) << s;
  return ns;
}

TEST(Timestamp, ParsesDecimalSecondsExactly) {
  // Through double this would be 1305031102175303936 or similar.
  EXPECT_EQ(Parse("1305031102.175304"), 1305031102175304000LL);
  EXPECT_EQ(Parse("1403715524.907143168"), 1403715524907143168LL);
  EXPECT_EQ(Parse("0"), 0);
  EXPECT_EQ(Parse("0.000000001"), 1);
  EXPECT_EQ(Parse("12"), 12 * kNsPerSecond);
  EXPECT_EQ(Parse("12."), 12 * kNsPerSecond);
  EXPECT_EQ(Parse(".5"), 500000000);
  EXPECT_EQ(Parse("+3.25"), 3250000000LL);
  EXPECT_EQ(Parse("-1.5"), -1500000000LL);
  EXPECT_EQ(Parse("  7.1 \t"), 7100000000LL);
  EXPECT_EQ(Parse("-1.5e-3"), -1500000);
  EXPECT_EQ(Parse("1.037359e-01"), 103735900);
  // Exponent notation is exact too (the point is shifted in the text).
  EXPECT_EQ(Parse("1.403715278862139940e+09"), 1403715278862139940LL);
  EXPECT_EQ(Parse("1305031102175304e-6"), 1305031102175304000LL);
  EXPECT_EQ(Parse("-2.5E+0"), -2500000000LL);
  EXPECT_EQ(Parse("0.0e-400"), 0);
  EXPECT_EQ(Parse("1e-400"), 0);
  EXPECT_EQ(Parse("1.5e-9"), 2);  // 1.5 ns rounds half away from zero
}

TEST(Timestamp, RoundsBeyondNineDecimalsToNearest) {
  EXPECT_EQ(Parse("1.0000000004"), 1000000000);
  EXPECT_EQ(Parse("1.0000000005"), 1000000001);
  EXPECT_EQ(Parse("1.00000000049999"), 1000000000);
  EXPECT_EQ(Parse("1.9999999999"), 2000000000);  // carries into the seconds
  EXPECT_EQ(Parse("-1.0000000006"), -1000000001);
}

TEST(Timestamp, RejectsMalformed) {
  Timestamp ns = 0;
  for (const char* s : {"", "  ", ".", "-", "+", "abc", "1.2.3", "1,5", "1.5s", "--1", "1e",
                        "nan", "inf", "1e999", "0x10", "1 2", "99999999999999999999",
                        "9223372037", "9223372036.854775808", "1e300", "-1e300", "0x1e",
                        "1e5.5", "1.2.3e4", "e5", ".e5", "1e+", "1ee5"}) {
    EXPECT_FALSE(ParseSecondsToNs(s, &ns)) << "'" << s << "'";
  }
  // Largest representable value still parses.
  EXPECT_TRUE(ParseSecondsToNs("9223372036.854775807", &ns));
  EXPECT_EQ(ns, INT64_MAX);
}

TEST(Timestamp, FormatRoundTripsExactly) {
  EXPECT_EQ(FormatSeconds(1305031102175304000LL), "1305031102.175304000");
  EXPECT_EQ(FormatSeconds(1), "0.000000001");
  EXPECT_EQ(FormatSeconds(-1500000000LL), "-1.500000000");
  EXPECT_EQ(FormatSeconds(-1), "-0.000000001");
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int64_t> any(-4000000000000000000LL, 4000000000000000000LL);
  for (int i = 0; i < 1000; ++i) {
    const Timestamp t = any(rng);
    EXPECT_EQ(Parse(FormatSeconds(t)), t);
  }
  EXPECT_EQ(Parse(FormatSeconds(INT64_MAX)), INT64_MAX);
}

TEST(Timestamp, SecondsConversions) {
  EXPECT_EQ(SecondsToNs(1.5), 1500000000);
  EXPECT_EQ(SecondsToNs(-0.02), -20000000);
  EXPECT_DOUBLE_EQ(NsToSeconds(20000000), 0.02);
}

TEST(Timestamp, FileStemOrderIsTimeOrder) {
  std::vector<Timestamp> times = {1305031102175304000LL, 5, 999999999, 1000000000, 0,
                                  1403715524907143168LL, 42};
  std::vector<std::string> stems;
  for (Timestamp t : times) {
    stems.push_back(TimestampFileStem(t));
    EXPECT_EQ(stems.back().size(), 20u);
    Timestamp back = -1;
    ASSERT_TRUE(ParseTimestampFileStem(stems.back(), &back));
    EXPECT_EQ(back, t);
  }
  std::sort(times.begin(), times.end());
  std::sort(stems.begin(), stems.end());
  for (size_t i = 0; i < times.size(); ++i) EXPECT_EQ(stems[i], TimestampFileStem(times[i]));
}

TEST(Timestamp, FileStemRejectsMalformed) {
  Timestamp ns = 0;
  for (const char* s : {"", "12a", "-5", "+5", "1.5", "000000000000000000001", "99999999999999999999"}) {
    EXPECT_FALSE(ParseTimestampFileStem(s, &ns)) << "'" << s << "'";
  }
}

TEST(Timestamp, NearestInTime) {
  const std::vector<Timestamp> v = {10, 20, 40};
  const auto id = [](Timestamp x) { return x; };
  const auto at = [&](Timestamp t) { return NearestInTime(v.begin(), v.end(), t, id) - v.begin(); };
  EXPECT_EQ(at(0), 0);    // before the first
  EXPECT_EQ(at(14), 0);
  EXPECT_EQ(at(15), 0);   // as near as 20: the earlier
  EXPECT_EQ(at(16), 1);
  EXPECT_EQ(at(20), 1);   // exact
  EXPECT_EQ(at(31), 2);
  EXPECT_EQ(at(99), 2);   // after the last
  const std::vector<Timestamp> none;
  EXPECT_TRUE(NearestInTime(none.begin(), none.end(), 5, id) == none.end());
  // Indices sorted by another array's times (how keyframes are looked up).
  const std::vector<Timestamp> times = {40, 10, 20};
  const std::vector<int> order = {1, 2, 0};
  EXPECT_EQ(*NearestInTime(order.begin(), order.end(), 37, [&](int i) { return times[size_t(i)]; }), 0);
}

}  // namespace
}  // namespace rumi
