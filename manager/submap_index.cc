#include "manager/submap_index.h"

namespace rumi {

void SubmapIndex::Build(const Submap& s) {
  kf_.clear();
  pt_.clear();
  ts_.clear();
  for (size_t i = 0; i < s.keyframes.size(); ++i) {
    kf_.emplace(s.keyframes[i].id, int(i));
    ts_.emplace(s.keyframes[i].timestamp, int(i));
  }
  for (size_t i = 0; i < s.points.size(); ++i) pt_.emplace(s.points[i].id, int(i));
}

bool ProjectPinhole(const CameraIntrinsics& cam, const Eigen::Vector3d& p_c, Eigen::Vector2d* px) {
  if (p_c.z() < 1e-6) return false;
  px->x() = cam.fx * p_c.x() / p_c.z() + cam.cx;
  px->y() = cam.fy * p_c.y() / p_c.z() + cam.cy;
  return true;
}

}  // namespace rumi
