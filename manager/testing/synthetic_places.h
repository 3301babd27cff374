#pragma once
// Views of synthetic places for place-recognition tests and benchmarks:
// each place has its own ORB-like corners; a view sees a random subset of
// them, each with some bits flipped (another viewpoint), plus clutter.
// Corners are drawn around 2,000 shared prototypes (32 bits off one), as
// real ORB descriptors cluster (corners look alike from place to place); a
// vocabulary of uniformly random 256-bit strings would be noise.
#include <cstdint>
#include <random>
#include <vector>

namespace rumi {

class SyntheticPlaces {
 public:
  SyntheticPlaces(int num_places, int corners_per_place, uint32_t seed)
      : corners_(size_t(num_places) * size_t(corners_per_place) * 32), per_place_(corners_per_place), seed_(seed) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> prototypes(2000 * 32);
    for (auto& b : prototypes) b = uint8_t(rng());
    for (size_t c = 0; c < corners_.size() / 32; ++c) {
      const uint8_t* p = &prototypes[(rng() % 2000) * 32];
      for (int i = 0; i < 32; ++i) corners_[c * 32 + size_t(i)] = p[i];
      for (int f = 0; f < 32; ++f) {
        const int bit = int(rng() % 256);
        corners_[c * 32 + size_t(bit >> 3)] ^= uint8_t(1 << (bit & 7));
      }
    }
  }
  // 3/4 of the place's corners with `flips` bits flipped each, and 1/10 as
  // many random descriptors; packed 32-byte rows.
  std::vector<uint8_t> View(int place, int view, int flips) const {
    std::mt19937 rng(seed_ * 7919u + uint32_t(place) * 104729u + uint32_t(view) * 13u + 1u);
    std::vector<uint8_t> out;
    for (int c = 0; c < per_place_; ++c) {
      if (rng() % 4 == 0) continue;
      const uint8_t* src = &corners_[(size_t(place) * size_t(per_place_) + size_t(c)) * 32];
      uint8_t d[32];
      for (int i = 0; i < 32; ++i) d[i] = src[i];
      for (int f = 0; f < flips; ++f) {
        const int bit = int(rng() % 256);
        d[bit >> 3] ^= uint8_t(1 << (bit & 7));
      }
      out.insert(out.end(), d, d + 32);
    }
    for (int c = 0; c < per_place_ / 10; ++c)
      for (int i = 0; i < 32; ++i) out.push_back(uint8_t(rng()));
    return out;
  }

 private:
  std::vector<uint8_t> corners_;
  int per_place_;
  uint32_t seed_;
};

}  // namespace rumi
