#include "common/pose_jumps.h"

#include <algorithm>
#include <vector>
#include <unordered_set>

#include "common/timestamp.h"
#include "common/stats.h"

namespace rumi {
namespace {


}  // namespace

std::vector<size_t> PoseJumps(const Submap& s, double max_ratio) {
  const size_t n = s.keyframes.size();
  if (n < 3 || !(max_ratio > 0)) return {};
  std::vector<Eigen::Vector3d> c(n);
  std::vector<double> t(n);
  for (size_t i = 0; i < n; ++i) {
    c[i] = s.keyframes[i].T_wc().translation();
    t[i] = NsToSeconds(s.keyframes[i].timestamp);
  }
  std::vector<double> steps(n - 1), speeds(n - 1);
  for (size_t k = 0; k + 1 < n; ++k) {
    steps[k] = (c[k + 1] - c[k]).norm();
    speeds[k] = t[k + 1] > t[k] ? steps[k] / (t[k + 1] - t[k]) : 0.0;
  }
  std::vector<size_t> out;
  for (size_t i = 0; i < n; ++i) {
    // The medians leave out the two steps that touch i: in a short model the
    // jump's own two steps would be half of them.
    std::vector<double> st, sp;
    for (size_t k = 0; k + 1 < n; ++k)
      if (k + 1 != i && k != i) {
        st.push_back(steps[k]);
        sp.push_back(speeds[k]);
      }
    const double step = UpperMedian(st), speed = UpperMedian(sp);
    const auto reach = [&](size_t a, size_t b) {
      return (c[a] - c[b]).norm() <= max_ratio * std::max(speed * std::abs(t[a] - t[b]), step);
    };
    bool jump;
    if (i == 0)
      jump = !reach(0, 1) && !reach(0, 2) && reach(1, 2);
    else if (i == n - 1)
      jump = !reach(i, i - 1) && !reach(i, i - 2) && reach(i - 1, i - 2);
    else
      jump = !reach(i, i - 1) && !reach(i, i + 1) && reach(i - 1, i + 1);
    if (jump) out.push_back(i);
  }
  return out;
}

int DropKeyframesAt(Submap* s, const std::vector<size_t>& indices) {
  std::unordered_set<int64_t> gone;
  for (size_t i : indices)
    if (i < s->keyframes.size()) gone.insert(s->keyframes[i].id);
  if (gone.empty()) return 0;
  std::vector<Keyframe> kept;
  for (Keyframe& k : s->keyframes)
    if (!gone.count(k.id)) kept.push_back(std::move(k));
  s->keyframes = std::move(kept);
  std::vector<MapPoint> points;
  std::unordered_set<int64_t> orphans;
  for (MapPoint& p : s->points) {
    auto& obs = p.observations;
    obs.erase(std::remove_if(obs.begin(), obs.end(),
                             [&](const MapPoint::Observation& o) { return gone.count(o.keyframe_id) > 0; }),
              obs.end());
    if (p.observations.empty()) orphans.insert(p.id);
    else points.push_back(std::move(p));
  }
  s->points = std::move(points);
  for (Keyframe& k : s->keyframes)
    for (int64_t& id : k.point_ids)
      if (id >= 0 && orphans.count(id)) id = -1;
  return int(gone.size());
}

}  // namespace rumi
