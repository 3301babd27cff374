#pragma once
// Versioned binary format of a Submap: the payload of the submap channels and
// the record of the map file (see docs/ipc.md for the layout). Every field of
// Submap round-trips bit-exactly (poses, descriptors, frame records).
#include <cstdint>
#include <string>
#include <vector>

#include "common/submap.h"

namespace rumi {

constexpr uint16_t kSubmapFormatVersion = 1;

// Exact encoded size of s.
size_t EncodedSubmapSize(const Submap& s);
// Writes s into out[0, capacity); returns the bytes written or 0 when
// capacity < EncodedSubmapSize(s).
size_t EncodeSubmapInto(const Submap& s, uint8_t* out, size_t capacity);
std::vector<uint8_t> EncodeSubmap(const Submap& s);

// Parses a record written by EncodeSubmap. On truncated, corrupt or foreign
// input returns false and says why in *error (never throws, never crashes).
bool DecodeSubmap(const uint8_t* data, size_t size, Submap* s, std::string* error = nullptr);

}  // namespace rumi
