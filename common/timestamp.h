#pragma once
// Frame identity: capture time as int64 nanoseconds (design contract). Seconds
// appear only at the edges (TUM files, COLMAP image names).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iterator>
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
// The local wall clock now, ISO 8601 with the zone ("2026-11-29T16:40:00+0000"),
// for people reading status files.
std::string LocalWallClockText();
Timestamp SecondsToNs(double seconds);

// Parses a decimal seconds string ("1305031102.175304", "-1.5e-3") to ns
// exactly when it has at most 9 decimals, without going through double.
// Returns false on malformed input.
bool ParseSecondsToNs(const std::string& text, Timestamp* ns);

// Formats ns as seconds with 9 decimals ("1305031102.175304000") so that a
// round trip through text is exact.
std::string FormatSeconds(Timestamp ns);

// The element of [first, last), sorted by time_of(element), nearest in time
// to t (the earlier of two as near); last when the range is empty. The one
// "keyframe/frame/pose nearest a time" lookup.
template <typename It, typename TimeOf>
It NearestInTime(It first, It last, Timestamp t, TimeOf time_of) {
  if (first == last) return last;
  const It it = std::lower_bound(first, last, t, [&](const auto& e, Timestamp x) { return time_of(e) < x; });
  if (it == first) return it;
  const It before = std::prev(it);
  if (it == last) return before;
  return t - time_of(*before) <= time_of(*it) - t ? before : it;
}

// Zero-padded name for files handed to COLMAP: name order is time order.
std::string TimestampFileStem(Timestamp ns);  // 20 digits
bool ParseTimestampFileStem(const std::string& stem, Timestamp* ns);

}  // namespace rumi
