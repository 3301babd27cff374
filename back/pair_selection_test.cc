#include "back/pair_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <numeric>
#include <set>

namespace rumi {
namespace {

std::vector<SampleSet> Window(int s1, int s2, int s3) {
  std::vector<SampleSet> v(s1, SampleSet::kS1);
  v.insert(v.end(), s2, SampleSet::kS2);
  v.insert(v.end(), s3, SampleSet::kS3);
  return v;
}

bool Has(const std::vector<std::pair<int, int>>& pairs, int i, int j) {
  return std::binary_search(pairs.begin(), pairs.end(), std::make_pair(std::min(i, j), std::max(i, j)));
}

// Every frame reaches every other one through matched pairs.
bool Connected(int n, const std::vector<std::pair<int, int>>& pairs) {
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> root = [&](int i) { return parent[i] == i ? i : parent[i] = root(parent[i]); };
  for (const auto& [i, j] : pairs) parent[root(i)] = root(j);
  for (int i = 0; i < n; ++i)
    if (root(i) != root(0)) return false;
  return true;
}

TEST(PairSelection, PairsAreOrderedUniqueAndInRange) {
  const auto sets = Window(13, 36, 19);
  const auto pairs = SelectImagePairs(sets, PairSelectionOptions());
  ASSERT_FALSE(pairs.empty());
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
  const std::set<std::pair<int, int>> unique(pairs.begin(), pairs.end());
  EXPECT_EQ(unique.size(), pairs.size());
  for (const auto& [i, j] : pairs) {
    EXPECT_LT(i, j);
    EXPECT_GE(i, 0);
    EXPECT_LT(j, int(sets.size()));
  }
  EXPECT_TRUE(Connected(int(sets.size()), pairs));
}

TEST(PairSelection, AShortLostStretchIsMatchedExhaustively) {
  const PairSelectionOptions o;
  const int n = o.lost_overlap + 1;
  EXPECT_EQ(SelectImagePairs(Window(0, n, 0), o).size(), size_t(n * (n - 1) / 2));
}

TEST(PairSelection, NeighboursBridgesAndLongRange) {
  PairSelectionOptions o;
  const auto sets = Window(20, 60, 20);  // S2 is 20..79
  const auto pairs = SelectImagePairs(sets, o);
  // Temporal neighbours everywhere, across the set boundaries too.
  for (int i = 0; i + o.overlap < 100; ++i)
    for (int d = 1; d <= o.overlap; ++d) EXPECT_TRUE(Has(pairs, i, i + d)) << i << " " << i + d;
  // Inside the lost stretch, denser.
  EXPECT_TRUE(Has(pairs, 20, 20 + o.lost_overlap));
  EXPECT_FALSE(Has(pairs, 20, 20 + o.lost_overlap + 1));
  // The tracked frames next to the stretch see every lost frame ...
  for (int l = 20; l < 80; ++l) {
    for (int b = 0; b < o.bridge_frames; ++b) {
      EXPECT_TRUE(Has(pairs, 19 - b, l)) << l;
      EXPECT_TRUE(Has(pairs, 80 + b, l)) << l;
    }
    // ... frames further out only their neighbours and 2^k.
    EXPECT_EQ(Has(pairs, 19 - o.bridge_frames, l), l - (19 - o.bridge_frames) <= o.overlap ||
                                                       l - (19 - o.bridge_frames) == 16 ||
                                                       l - (19 - o.bridge_frames) == 32 ||
                                                       l - (19 - o.bridge_frames) == 64)
        << l;
  }
  // Long range: 2^k apart.
  EXPECT_TRUE(Has(pairs, 0, 64));
  EXPECT_TRUE(Has(pairs, 3, 35));
  EXPECT_FALSE(Has(pairs, 0, 63));
  // A 100-frame window: well under the 4,950 exhaustive pairs.
  EXPECT_LT(pairs.size(), 4950u / 3);
  EXPECT_TRUE(Connected(100, pairs));

  o.quadratic = false;
  EXPECT_FALSE(Has(SelectImagePairs(sets, o), 0, 64));
}

TEST(PairSelection, WindowsWithoutALostStretch) {
  PairSelectionOptions o;
  o.quadratic = false;
  // Only neighbours: n*overlap - overlap*(overlap+1)/2 pairs.
  const int n = 30;
  EXPECT_EQ(SelectImagePairs(Window(n, 0, 0), o).size(), size_t(n * o.overlap - o.overlap * (o.overlap + 1) / 2));
  EXPECT_TRUE(SelectImagePairs(Window(1, 0, 0), o).empty());
  EXPECT_TRUE(SelectImagePairs({}, o).empty());
}

TEST(PairSelection, StartUpWindowBridgesOnlyForward) {
  // A slow first initialisation: S2 from the first frame, S3 after.
  const PairSelectionOptions o;
  const auto pairs = SelectImagePairs(Window(0, 40, 10), o);
  for (int l = 0; l < 40; ++l)
    for (int b = 0; b < o.bridge_frames; ++b) EXPECT_TRUE(Has(pairs, 40 + b, l));
  EXPECT_TRUE(Connected(50, pairs));
}

TEST(PairSelection, OptionsAreCheckedThroughTheirSpec) {
  PairSelectionOptions o;
  std::string why;
  EXPECT_TRUE(PairSelectionOptions::Spec().Check(o, &why)) << why;
  o.overlap = 0;
  EXPECT_FALSE(PairSelectionOptions::Spec().Check(o, &why));
  EXPECT_NE(why.find("overlap"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
