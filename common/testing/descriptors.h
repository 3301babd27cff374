#pragma once
// For tests only: hand-made ORB descriptors at chosen Hamming distances.
#include <opencv2/core.hpp>

#include <cstdint>
#include <random>
#include <vector>

namespace rumi::test {

// A random 32-byte ORB-like descriptor (1 x 32 CV_8U): two random ones are
// about 128 bits apart, far beyond every gate.
inline cv::Mat RandomDescriptor(std::mt19937* rng) {
  cv::Mat d(1, 32, CV_8U);
  for (int i = 0; i < 32; ++i) d.at<uint8_t>(0, i) = static_cast<uint8_t>((*rng)() & 0xff);
  return d;
}

// `d` with its first `bits` bits flipped: exactly `bits` away from it.
inline cv::Mat Flipped(const cv::Mat& d, int bits) {
  cv::Mat out = d.clone();
  for (int b = 0; b < bits; ++b) out.at<uint8_t>(0, b / 8) ^= static_cast<uint8_t>(1u << (b % 8));
  return out;
}

// Rows stacked into one descriptor matrix.
inline cv::Mat Rows(const std::vector<cv::Mat>& rows) {
  cv::Mat m;
  cv::vconcat(rows, m);
  return m;
}

}  // namespace rumi::test
