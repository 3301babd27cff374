#pragma once
// Frame identity: capture time as int64 nanoseconds (design contract). Seconds
// appear only at the edges (TUM files, COLMAP image names).
#include <chrono>
#include <cstdint>
#include <string>

namespace rumi {

using Timestamp = int64_t;  // nanoseconds

constexpr int64_t kNsPerSecond = 1000000000LL;

inline double NsToSeconds(Timestamp ns) { return static_cast<double>(ns) * 1e-9; }

// Wall time for stats and timeouts (steady clock), not frame time.
inline double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
// The wall clock now (stamps of published state, not frame identity).
inline Timestamp WallNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}
Timestamp SecondsToNs(double seconds);

// Parses a decimal seconds string ("1305031102.175304", "-1.5e-3") to ns
// exactly when it has at most 9 decimals, without going through double.
// Returns false on malformed input.
bool ParseSecondsToNs(const std::string& text, Timestamp* ns);

// Formats ns as seconds with 9 decimals ("1305031102.175304000") so that a
// round trip through text is exact.
std::string FormatSeconds(Timestamp ns);

// Zero-padded name for files handed to COLMAP: name order is time order.
std::string TimestampFileStem(Timestamp ns);  // 20 digits
bool ParseTimestampFileStem(const std::string& stem, Timestamp* ns);

}  // namespace rumi
