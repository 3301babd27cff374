#include "manager/map_grid.h"

#include <algorithm>

#include "manager/submap_index.h"

namespace rumi {

std::vector<GridKeyframe> GridKeyframesOf(const GlobalMap& map, int component) {
  std::vector<GridKeyframe> out;
  for (int i : map.Members(component)) {
    const Submap& s = map.submap(i);
    const Sim3& S = map.ToGlobal(i);
    const SubmapIndex index(s);
    for (const Keyframe& k : s.keyframes) {
      GridKeyframe g;
      g.timestamp = k.timestamp;
      g.T_wc = S.TransformPose(k.T_wc());
      for (int64_t id : k.point_ids) {
        const int p = id < 0 ? -1 : index.Point(id);
        if (p >= 0) g.points.push_back(S * s.points[p].position);
      }
      out.push_back(std::move(g));
    }
  }
  std::sort(out.begin(), out.end(),
            [](const GridKeyframe& a, const GridKeyframe& b) { return a.timestamp < b.timestamp; });
  return out;
}

Trajectory OdometryOf(const GlobalMap& map, int component) {
  Trajectory out;
  for (int i : map.Members(component))
    for (const OdometryPose& o : map.submap(i).odometry) out.push_back({o.timestamp, o.T_wb});
  std::sort(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
  out.erase(std::unique(out.begin(), out.end(), [](const StampedPose& a, const StampedPose& b) { return a.t == b.t; }),
            out.end());
  return out;
}

}  // namespace rumi
