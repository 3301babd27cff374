#pragma once
// ORB features on a scale pyramid, spread over a grid: per level, FAST corners
// are bucketed into cells and the strongest of each cell kept (strong corners
// first, weak ones fill low-texture cells), so that the whole image is covered.
// Shared by the front (tracking) and the back (ORB keypoints on back keyframes,
// so that the manager can find front map points in them).
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "common/option_spec.h"

namespace rumi {

struct OrbExtractorOptions {
  int num_features = 0;       // per frame; 0: auto (1000 up to 640x480, 2000 above)
  int num_levels = 8;
  double scale_factor = 1.2;
  int fast_threshold = 20;    // preferred corner strength
  int fast_min_threshold = 7; // fallback in low-texture cells
  int cell_size = 32;         // grid bucket side in pixels (level 0)
  static const OptionSpec<OrbExtractorOptions>& Spec();  // section front.orb
  bool Check(std::string* why = nullptr) const;
};

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbExtractorOptions& o);
  // keypoints: level-0 pixel coordinates, octave = level, angle in degrees.
  void Extract(const cv::Mat& grey, std::vector<cv::KeyPoint>* keypoints,
               cv::Mat* descriptors);
  const std::vector<double>& scales() const { return scales_; }        // s^l
  const std::vector<double>& sigma2() const { return sigma2_; }        // s^2l
  const OrbExtractorOptions& options() const { return o_; }

 private:
  OrbExtractorOptions o_;
  std::vector<double> scales_, sigma2_;
  std::vector<int> per_level_;
  std::vector<cv::Mat> pyramid_;
  cv::Ptr<cv::ORB> orb_;
  std::vector<int> umax_;  // circular patch bounds for the orientation
};

int DescriptorDistance(const cv::Mat& a, const cv::Mat& b);  // Hamming, 32-byte rows
// Hamming distance of two 32-byte descriptors (hot loops: no Mat headers).
inline int DescriptorDistance(const uint8_t* a, const uint8_t* b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a, 32);
  std::memcpy(y, b, 32);
  return __builtin_popcountll(x[0] ^ y[0]) + __builtin_popcountll(x[1] ^ y[1]) +
         __builtin_popcountll(x[2] ^ y[2]) + __builtin_popcountll(x[3] ^ y[3]);
}

// False for an all-zero row: keypoints without a descriptor (SIFT keypoints
// of back keyframes, back/keyframe_orb.h).
inline bool HasDescriptor(const uint8_t* d) {
  uint64_t x[4];
  std::memcpy(x, d, 32);
  return (x[0] | x[1] | x[2] | x[3]) != 0;
}

}  // namespace rumi
