#pragma once
// Id -> index lookups of one submap (keyframe and point ids are unique within
// a submap but not dense).
#include <cstdint>
#include <unordered_map>

#include "common/submap.h"

namespace rumi {

class SubmapIndex {
 public:
  SubmapIndex() = default;
  explicit SubmapIndex(const Submap& s) { Build(s); }
  void Build(const Submap& s);
  // -1 when absent.
  int Keyframe(int64_t id) const { return Find(kf_, id); }
  int Point(int64_t id) const { return Find(pt_, id); }
  // First keyframe index with this exact timestamp, -1 when absent.
  int KeyframeAt(Timestamp t) const { return Find(ts_, t); }

 private:
  static int Find(const std::unordered_map<int64_t, int>& m, int64_t k) {
    const auto it = m.find(k);
    return it == m.end() ? -1 : it->second;
  }
  std::unordered_map<int64_t, int> kf_, pt_, ts_;
};

// Projects a camera-frame point with the submap's pinhole intrinsics; false
// when behind (or too close to) the camera.
bool ProjectPinhole(const CameraIntrinsics& cam, const Eigen::Vector3d& p_c, Eigen::Vector2d* px);

}  // namespace rumi
