#include "common/submap.h"

#include <unordered_set>

namespace rumi {

const char* ToString(TrackingState s) {
  switch (s) {
    case TrackingState::kInitializing: return "initializing";
    case TrackingState::kTracking: return "tracking";
    case TrackingState::kLost: return "lost";
    case TrackingState::kCoarse: return "coarse";
  }
  return "unknown";
}

int DropWeakPoints(Submap* submap, int min_observations) {
  std::unordered_set<int64_t> weak;
  std::vector<MapPoint> kept;
  kept.reserve(submap->points.size());
  for (MapPoint& p : submap->points) {
    if (static_cast<int>(p.observations.size()) < min_observations) weak.insert(p.id);
    else kept.push_back(std::move(p));
  }
  submap->points = std::move(kept);
  if (weak.empty()) return 0;
  for (Keyframe& kf : submap->keyframes)
    for (int64_t& id : kf.point_ids)
      if (id >= 0 && weak.count(id)) id = -1;
  return static_cast<int>(weak.size());
}

}  // namespace rumi
