#pragma once
// Versioned binary format of an ImageWindow (front sampler -> back). Image
// pixels are written once, straight from the cv::Mat into the destination, and
// can be read in place (cv::Mat headers onto the received bytes).
#include <cstdint>
#include <string>
#include <vector>

#include "common/window.h"

namespace rumi {

constexpr uint16_t kWindowFormatVersion = 1;

size_t EncodedWindowSize(const ImageWindow& w);
// Returns bytes written, 0 when capacity is too small.
size_t EncodeWindowInto(const ImageWindow& w, uint8_t* out, size_t capacity);
std::vector<uint8_t> EncodeWindow(const ImageWindow& w);

// in_place: frame images point into data (valid only while data is), else
// deep copies. Metadata is checksummed; pixels are only length-checked.
// False with *error on truncated, corrupt or foreign input.
bool DecodeWindow(const uint8_t* data, size_t size, ImageWindow* w, bool in_place,
                  std::string* error = nullptr);

}  // namespace rumi
