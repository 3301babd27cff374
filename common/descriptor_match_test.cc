#include "common/descriptor_match.h"

#include <gtest/gtest.h>

#include <array>

namespace rumi {
namespace {

using Row = std::array<uint8_t, 32>;

// A descriptor with the first `bits` bits set: distance(Bits(a), Bits(b)) = |a - b|.
Row Bits(int bits) {
  Row r{};
  for (int i = 0; i < bits; ++i) r[size_t(i / 8)] |= uint8_t(1u << (i % 8));
  return r;
}

std::vector<uint8_t> Pack(const std::vector<Row>& rows) {
  std::vector<uint8_t> out;
  for (const Row& r : rows) out.insert(out.end(), r.begin(), r.end());
  return out;
}

std::vector<std::pair<int, int>> Match(const std::vector<Row>& a, const std::vector<Row>& b,
                                       const DescriptorMatchOptions& o) {
  const std::vector<uint8_t> pa = Pack(a), pb = Pack(b);
  return MatchDescriptors(pa.data(), a.size(), pb.data(), b.size(), o);
}

TEST(NearestTwo, KeepsTheTwoNearestAndTheEarlierOnATie) {
  NearestTwo n;
  EXPECT_EQ(n.best_index, -1);
  n.Add(40, 0);
  n.Add(30, 1);
  n.Add(30, 2);  // a tie with the best: the runner-up
  n.Add(50, 3);
  EXPECT_EQ(n.best, 30);
  EXPECT_EQ(n.best_index, 1);
  EXPECT_EQ(n.second, 30);
  EXPECT_EQ(n.second_index, 2);
  EXPECT_FALSE(n.Distinct(0.9));
  n.Add(10, 4);
  EXPECT_EQ(n.best_index, 4);
  EXPECT_EQ(n.second_index, 1);
  EXPECT_TRUE(n.Distinct(0.4));   // 10 < 12
  EXPECT_FALSE(n.Distinct(1.0 / 3.0));  // 10 is not < 10
}

TEST(MatchDescriptors, RatioAndDistanceGates) {
  const std::vector<Row> b = {Bits(0), Bits(100), Bits(200)};
  DescriptorMatchOptions o;
  o.max_distance = 64;
  o.ratio = 0.8;
  // Bits(10): 10 from row 0, 90 from row 1: distinct and near.
  EXPECT_EQ(Match({Bits(10)}, b, o), (std::vector<std::pair<int, int>>{{0, 0}}));
  // Bits(45): 45 vs 55: 45 < 0.8 * 55 = 44 fails the ratio test.
  EXPECT_TRUE(Match({Bits(45)}, b, o).empty());
  // Bits(170): 30 from row 2, 70 from row 1; too far with max_distance 20.
  o.max_distance = 20;
  EXPECT_TRUE(Match({Bits(170)}, b, o).empty());
  o.max_distance = 30;
  EXPECT_EQ(Match({Bits(170)}, b, o), (std::vector<std::pair<int, int>>{{0, 2}}));
  // One candidate row leaves no runner-up: no ratio test, no match.
  EXPECT_TRUE(Match({Bits(0)}, {Bits(0)}, o).empty());
  EXPECT_TRUE(Match({}, b, o).empty());
}

TEST(MatchDescriptors, MutualDropsAPairWhoseCandidateIsNearerToAnAmbiguousQuery) {
  // Query 0 is nearest to row 0 but ambiguous (row 1 is as near); query 1
  // passes and also chose row 0, from farther away.
  const std::vector<Row> b = {Bits(100), Bits(104), Bits(250)};
  const std::vector<Row> a = {Bits(102), Bits(90)};
  DescriptorMatchOptions o;
  o.max_distance = 64;
  o.ratio = 0.9;
  o.mutual = true;  // row 0's nearest query overall is query 0, which failed
  EXPECT_TRUE(Match(a, b, o).empty());
  o.mutual = false;  // among the passing queries, row 0's nearest is query 1
  EXPECT_EQ(Match(a, b, o), (std::vector<std::pair<int, int>>{{1, 0}}));
}

TEST(MatchDescriptors, OneToOneTheCloserClaimWins) {
  const std::vector<Row> b = {Bits(0), Bits(200)};
  const std::vector<Row> a = {Bits(20), Bits(5), Bits(195)};
  for (bool mutual : {true, false}) {
    DescriptorMatchOptions o;
    o.max_distance = 64;
    o.ratio = 0.8;
    o.mutual = mutual;
    EXPECT_EQ(Match(a, b, o), (std::vector<std::pair<int, int>>{{1, 0}, {2, 1}})) << mutual;
  }
}

}  // namespace
}  // namespace rumi
