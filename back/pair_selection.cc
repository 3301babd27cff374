#include "back/pair_selection.h"

#include <algorithm>

namespace rumi {

const OptionSpec<PairSelectionOptions>& PairSelectionOptions::Spec() {
  using O = PairSelectionOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("pairs");
    s->Number("overlap", &O::overlap, AtLeast(1), AtMost(1000), "frames at most this far apart are matched");
    s->Number("lost_overlap", &O::lost_overlap, AtLeast(0), AtMost(1000),
              "S2 (lost) frames at most this far apart in the lost stretch are matched");
    s->Number("bridge_frames", &O::bridge_frames, AtLeast(0), AtMost(1000),
              "tracked frames on each side of the lost stretch matched with every lost frame");
    s->Flag("quadratic", &O::quadratic, "also match frames 2^k apart");
    return s;
  }();
  return *spec;
}

std::vector<std::pair<int, int>> SelectImagePairs(const std::vector<SampleSet>& sets,
                                                  const PairSelectionOptions& options) {
  const int n = int(sets.size());
  std::vector<std::pair<int, int>> pairs;
  auto add = [&](int i, int j) {
    if (i == j || i < 0 || j < 0 || i >= n || j >= n) return;
    pairs.emplace_back(std::min(i, j), std::max(i, j));
  };
  std::vector<int> lost;
  for (int i = 0; i < n; ++i)
    if (sets[i] == SampleSet::kS2) lost.push_back(i);

  for (int i = 0; i < n; ++i) {
    for (int d = 1; d <= options.overlap; ++d) add(i, i + d);
    if (options.quadratic)
      for (int d = 2; d < n; d *= 2)
        if (d > options.overlap) add(i, i + d);
  }
  for (size_t a = 0; a < lost.size(); ++a)
    for (size_t b = a + 1; b < lost.size() && b - a <= size_t(options.lost_overlap); ++b) add(lost[a], lost[b]);
  if (!lost.empty()) {
    // The tracked frames next to the lost stretch, before and after it.
    std::vector<int> bridge;
    for (int i = lost.front() - 1, k = 0; i >= 0 && k < options.bridge_frames; --i)
      if (sets[i] != SampleSet::kS2) bridge.push_back(i), ++k;
    for (int i = lost.back() + 1, k = 0; i < n && k < options.bridge_frames; ++i)
      if (sets[i] != SampleSet::kS2) bridge.push_back(i), ++k;
    for (int b : bridge)
      for (int l : lost) add(b, l);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

}  // namespace rumi
