#include "manager/global_trajectory.h"

#include <algorithm>
#include <cstdio>
#include <fstream>

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

bool WriteTumTrajectory(const std::string& path, const std::vector<GlobalPose>& poses, std::string* why) {
  std::ofstream f(path);
  if (!f) {
    if (why) *why = "cannot open '" + path + "' for writing";
    return false;
  }
  char buf[256];
  for (const GlobalPose& p : poses) {
    const Eigen::Vector3d& t = p.T_wc.translation();
    const Eigen::Quaterniond& q = p.T_wc.rotation();
    std::snprintf(buf, sizeof(buf), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t.x(), t.y(), t.z(), q.x(), q.y(),
                  q.z(), q.w());
    f << FormatSeconds(p.timestamp) << buf;
  }
  f.flush();
  if (!f) {
    if (why) *why = "write to '" + path + "' failed";
    return false;
  }
  return true;
}

}  // namespace rumi
