#include "common/descriptor_match.h"

#include "common/orb_extractor.h"

namespace rumi {

std::vector<std::pair<int, int>> MatchDescriptors(const uint8_t* a, size_t na, const uint8_t* b, size_t nb,
                                                  const DescriptorMatchOptions& options) {
  if (na == 0 || nb < 2) return {};
  // Brute force with the popcount kernel: two submaps of ~10^4 points each are
  // ~10^8 distances, and cv::BFMatcher's per-row overhead doubled that cost.
  std::vector<int> chosen(na, -1);                    // a row -> its b row
  std::vector<int> claim_distance(nb, 257), claim_row(nb, -1);  // b row -> its nearest a row
  for (size_t r = 0; r < na; ++r) {
    const uint8_t* q = a + r * 32;
    NearestTwo n;
    for (size_t c = 0; c < nb; ++c) {
      const int d = DescriptorDistance(q, b + c * 32);
      n.Add(d, int(c));
      if (options.mutual && d < claim_distance[c]) {
        claim_distance[c] = d;
        claim_row[c] = int(r);
      }
    }
    if (n.best_index < 0 || n.best > options.max_distance || !n.Distinct(options.ratio)) continue;
    chosen[r] = n.best_index;
    if (!options.mutual && n.best < claim_distance[size_t(n.best_index)]) {
      claim_distance[size_t(n.best_index)] = n.best;
      claim_row[size_t(n.best_index)] = int(r);
    }
  }
  std::vector<std::pair<int, int>> out;
  for (size_t r = 0; r < na; ++r)
    if (chosen[r] >= 0 && claim_row[size_t(chosen[r])] == int(r)) out.push_back({int(r), chosen[r]});
  return out;
}

}  // namespace rumi
