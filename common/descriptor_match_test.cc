#include "common/descriptor_match.h"

#include <gtest/gtest.h>

#include <array>
#include <random>

#include <opencv2/core.hpp>

#include "common/testing/descriptors.h"

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

using test::Flipped;
using test::RandomDescriptor;
using test::Rows;

using Pairs = std::vector<std::pair<int, int>>;

// Relocalisation's use: mutual best within the distance and the ratio.
Pairs BruteForce(const cv::Mat& d1, const cv::Mat& d2, int max_distance, double ratio) {
  return MatchDescriptors(d1.ptr<uint8_t>(), size_t(d1.rows), d2.ptr<uint8_t>(), size_t(d2.rows),
                          {max_distance, ratio, /*mutual=*/true});
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

TEST(MatchDescriptorsMutual, KeepsMutualBestWithinTheDistanceAndRatio) {
  std::mt19937 rng(1);
  const cv::Mat a = RandomDescriptor(&rng), b = RandomDescriptor(&rng), c = RandomDescriptor(&rng);
  // a: 10 bits from its twin; b: 40 bits; c: nothing near.
  const cv::Mat d1 = Rows({a, b, c});
  const cv::Mat d2 = Rows({RandomDescriptor(&rng), Flipped(b, 40), Flipped(a, 10)});
  EXPECT_EQ(BruteForce(d1, d2, 50, 0.8), (Pairs{{0, 2}, {1, 1}}));
  // The distance gate is inclusive: 40 passes a gate of 40, not one of 39.
  EXPECT_EQ(BruteForce(d1, d2, 40, 0.8), (Pairs{{0, 2}, {1, 1}}));
  EXPECT_EQ(BruteForce(d1, d2, 39, 0.8), (Pairs{{0, 2}}));
}

TEST(MatchDescriptorsMutual, RatioTestDropsAmbiguousMatches) {
  std::mt19937 rng(2);
  const cv::Mat a = RandomDescriptor(&rng);
  // Two candidates 20 and 22 bits away: 20 < 0.8 * 22 fails, 20 < 0.95 * 22 holds.
  const cv::Mat d1 = Rows({a});
  const cv::Mat d2 = Rows({Flipped(a, 20), Flipped(a, 22)});
  EXPECT_TRUE(BruteForce(d1, d2, 100, 0.8).empty());
  EXPECT_EQ(BruteForce(d1, d2, 100, 0.95), (Pairs{{0, 0}}));
  // A clear winner (10 against 30 bits) passes the strict ratio.
  const cv::Mat d3 = Rows({Flipped(a, 30), Flipped(a, 10)});
  EXPECT_EQ(BruteForce(d1, d3, 100, 0.8), (Pairs{{0, 1}}));
}

TEST(MatchDescriptorsMutual, OnlyTheClosestOfTwoRivalsGetsTheShared) {
  std::mt19937 rng(3);
  const cv::Mat a = RandomDescriptor(&rng);
  // Rows 0 and 1 of d1 both have d2's row 0 as their best: row 1 (5 bits) wins.
  const cv::Mat d1 = Rows({Flipped(a, 15), Flipped(a, 5)});
  const cv::Mat d2 = Rows({a, RandomDescriptor(&rng)});
  EXPECT_EQ(BruteForce(d1, d2, 50, 0.8), (Pairs{{1, 0}}));
  EXPECT_TRUE(BruteForce(cv::Mat(0, 32, CV_8U), d2, 50, 0.8).empty());
}

}  // namespace
}  // namespace rumi
