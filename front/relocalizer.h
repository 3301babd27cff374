#pragma once
// Relocalisation inside the current submap after a tracking failure: a few
// of the newest keyframes, two per lost frame in turn (a bounded cost per
// frame), each matched by descriptor, located by PnP RANSAC and refined.
// The caller holds the map mutex and confirms a pose against the local map.
#include <cstddef>
#include <vector>

#include "common/camera.h"
#include "front/map.h"

namespace rumi {

class Relocalizer {
 public:
  // The next two candidates among the 6 newest good keyframes.
  std::vector<KeyFrame*> NextCandidates(const Map& map);
  // cur's pose and point matches against kf (outliers dropped); false when
  // fewer than min_inliers / 2 survive (cur then holds what was tried).
  bool Localize(TrackFrame* cur, KeyFrame* kf, int min_inliers, const PinholeCamera& cam,
                const ScalePyramid& pyr) const;

 private:
  size_t cursor_ = 0;
};

}  // namespace rumi
