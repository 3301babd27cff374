#include "common/pose_buffer.h"

#include <algorithm>

#include <Eigen/Geometry>

namespace rumi {

bool PoseBuffer::Add(Timestamp t, const Se3& T) {
  if (!poses_.empty() && t <= poses_.back().first) return false;
  poses_.push_back({t, T});
  if (max_size_ > 0 && poses_.size() > max_size_) poses_.pop_front();
  return true;
}

std::optional<Se3> PoseBuffer::At(Timestamp t) const {
  if (poses_.empty() || t < poses_.front().first || t > poses_.back().first) return std::nullopt;
  auto it = std::lower_bound(poses_.begin(), poses_.end(), t,
                             [](const std::pair<Timestamp, Se3>& a, Timestamp b) { return a.first < b; });
  if (it->first == t || it == poses_.begin()) return it->second;
  const auto& a = *(it - 1);
  const auto& b = *it;
  const double s = double(t - a.first) / double(b.first - a.first);
  const Eigen::Quaterniond q = a.second.rotation().slerp(s, b.second.rotation());
  return Se3(q, (1 - s) * a.second.translation() + s * b.second.translation());
}

}  // namespace rumi
