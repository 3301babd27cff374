#pragma once
// Versioned binary format of an ImageWindow (front sampler -> back). Image
// pixels are written once, straight from the cv::Mat into the destination, and
// can be read in place (cv::Mat headers onto the received bytes). Off shared
// memory (the back's spool on disk, the wire to remote workers) frames may be
// PNG instead: lossless, a copy on each side, a fraction of the bytes.
#include <cstdint>
#include <string>
#include <vector>

#include "common/window.h"

namespace rumi {

// Version 2 gives each frame a pixel encoding (version 1 frames are raw; both
// are read).
constexpr uint16_t kWindowFormatVersion = 2;

enum class WindowPixels : uint16_t {
  kRaw = 0,  // rows x cols x element bytes, 64-aligned, readable in place
  kPng = 1,  // one PNG per frame; a frame PNG cannot hold (e.g. float) stays raw
};

size_t EncodedWindowSize(const ImageWindow& w);
// Returns bytes written, 0 when capacity is too small. Raw pixels.
size_t EncodeWindowInto(const ImageWindow& w, uint8_t* out, size_t capacity);
std::vector<uint8_t> EncodeWindow(const ImageWindow& w, WindowPixels pixels = WindowPixels::kRaw);

// in_place: raw frame images point into data (valid only while data is), PNG
// frames are decoded into their own memory. Metadata is checksummed; raw
// pixels are only length-checked, a PNG must decode to its recorded size and
// type. False with *error on truncated, corrupt or foreign input.
bool DecodeWindow(const uint8_t* data, size_t size, ImageWindow* w, bool in_place,
                  std::string* error = nullptr);

}  // namespace rumi
