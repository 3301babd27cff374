#pragma once
// Timed poses in time order and the pose between two of them (linear
// position, slerped rotation): the front's pose source (odometry) and the
// robot sim's IMU synthesis read poses at frame times this way.
#include <cstddef>
#include <deque>
#include <optional>
#include <utility>

#include "common/geometry.h"
#include "common/timestamp.h"

namespace rumi {

class PoseBuffer {
 public:
  // max_size: the oldest poses are dropped beyond it (0: unbounded).
  explicit PoseBuffer(size_t max_size = 0) : max_size_(max_size) {}
  // Appends a pose; one not after the newest is ignored (time order only).
  // Returns whether it was kept.
  bool Add(Timestamp t, const Se3& T);
  // The pose at t, interpolated; nullopt outside [oldest, newest].
  std::optional<Se3> At(Timestamp t) const;
  bool empty() const { return poses_.empty(); }
  size_t size() const { return poses_.size(); }
  Timestamp first_time() const { return poses_.front().first; }
  Timestamp last_time() const { return poses_.back().first; }

 private:
  std::deque<std::pair<Timestamp, Se3>> poses_;
  size_t max_size_ = 0;
};

}  // namespace rumi
