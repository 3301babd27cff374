#include "manager/global_trajectory.h"

#include <algorithm>

#include "manager/submap_index.h"

namespace rumi {
namespace {
// Higher wins when one frame has several sources.
enum Priority { kBackRecord = 0, kBackKeyframe = 1, kFrontRecord = 2, kFrontKeyframe = 3 };
struct Candidate {
  GlobalPose pose;
  int priority;
};
}  // namespace

std::vector<GlobalPose> ComputeGlobalTrajectory(const GlobalMap& map, int component, int64_t max_dt_ns) {
  if (component < 0) component = map.LargestComponent();
  std::vector<Candidate> c;
  for (int s : map.Members(component)) {
    const Submap& m = map.submap(s);
    const Sim3& S = map.ToGlobal(s);
    const bool back = m.source == SubmapSource::kBack;
    for (const Keyframe& kf : m.keyframes)
      c.push_back({{kf.timestamp, S.TransformPose(kf.T_wc()), s, back}, back ? kBackKeyframe : kFrontKeyframe});
    for (const FrameRecord& f : m.frames) {
      if (f.state != TrackingState::kTracking && f.state != TrackingState::kCoarse) continue;
      c.push_back({{f.timestamp, S.TransformPose(f.T_wc), s, back}, back ? kBackRecord : kFrontRecord});
    }
  }
  std::stable_sort(c.begin(), c.end(),
                   [](const Candidate& a, const Candidate& b) { return a.pose.timestamp < b.pose.timestamp; });
  std::vector<GlobalPose> out;
  for (size_t i = 0; i < c.size();) {
    size_t j = i, best = i;
    while (j < c.size() && c[j].pose.timestamp - c[i].pose.timestamp < max_dt_ns) {
      if (c[j].priority > c[best].priority) best = j;
      ++j;
    }
    out.push_back(c[best].pose);
    i = j;
  }
  return out;
}

Trajectory ToTrajectory(const std::vector<GlobalPose>& poses) {
  Trajectory t;
  t.reserve(poses.size());
  for (const GlobalPose& p : poses) t.push_back({p.timestamp, p.T_wc});
  return t;
}

}  // namespace rumi
