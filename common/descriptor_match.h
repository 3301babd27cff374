#pragma once
// The one ratio-test matcher of ORB descriptors: the nearest-two search every
// matching loop runs (the front's guided searches, relocalisation, the
// manager's place and loop matching) and the brute-force matcher over two
// descriptor sets.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace rumi {

// The nearest and second-nearest candidates of one query descriptor: the
// input of Lowe's ratio test. Distances are Hamming bits of 32-byte ORB rows
// (at most 256); 256 with index -1 means no candidate yet.
struct NearestTwo {
  int best = 256, second = 256;
  int best_index = -1, second_index = -1;

  // Ties keep the earlier candidate.
  void Add(int distance, int index) {
    if (distance >= second) return;
    if (distance < best) {
      second = best;
      second_index = best_index;
      best = distance;
      best_index = index;
    } else {
      second = distance;
      second_index = index;
    }
  }
  // Distinct from the runner-up: best < ratio * second.
  bool Distinct(double ratio) const { return best < ratio * second; }
};

struct DescriptorMatchOptions {
  int max_distance = 64;  // Hamming bits
  double ratio = 0.8;     // Lowe's ratio test (strict)
  // True: a pair stands only if the query row is also the candidate's nearest
  // over all query rows (cross-check). False: among the query rows that pass,
  // each candidate row keeps its nearest (the closer claim wins).
  bool mutual = true;
};

// Brute-force matches of the rows of `a` (na packed 32-byte descriptors) in
// the rows of `b` (nb), as (row in a, row in b) sorted by the first, one-to-one.
// Fewer than two rows in b leave no ratio test to pass: no matches.
std::vector<std::pair<int, int>> MatchDescriptors(const uint8_t* a, size_t na, const uint8_t* b, size_t nb,
                                                  const DescriptorMatchOptions& options);

}  // namespace rumi
