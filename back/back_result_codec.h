#pragma once
// Versioned binary format of a BackResult: what a remote worker sends back
// for one window (back/remote/). Submaps are the shared submap codec
// (ipc/submap_codec.h), so a remote window arrives at the manager exactly as
// a local one; the rest is the outcome back_stats.json reports.
#include <cstdint>
#include <string>
#include <vector>

#include "back/back_submap_builder.h"

namespace rumi {

constexpr uint16_t kBackResultFormatVersion = 1;

std::vector<uint8_t> EncodeBackResult(const BackResult& r);

// False with *error on truncated, corrupt or foreign input (never throws).
// The workspace path is not carried (it is the worker's).
bool DecodeBackResult(const uint8_t* data, size_t size, BackResult* r, std::string* error = nullptr);

}  // namespace rumi
