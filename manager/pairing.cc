#include "manager/pairing.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>

namespace rumi {
namespace {
int64_t AbsDiff(Timestamp a, Timestamp b) { return a > b ? a - b : b - a; }
}  // namespace

void SearchSet::Sort() const {
  if (sorted_) return;
  std::sort(times_.begin(), times_.end());
  sorted_ = true;
}

bool SearchSet::Contains(Timestamp t, int64_t max_dt_ns) const {
  if (all_) return true;
  Sort();
  const auto it = std::lower_bound(times_.begin(), times_.end(), t);
  if (it != times_.end() && AbsDiff(*it, t) < max_dt_ns) return true;
  return it != times_.begin() && AbsDiff(*(it - 1), t) < max_dt_ns;
}

SearchSet BuildSearchSet(const std::vector<const Submap*>& front_submaps,
                         const std::vector<const Submap*>& back_submaps, int n) {
  SearchSet set;
  if (n == 0) {
    set.set_all(true);
    return set;
  }
  for (const Submap* s : front_submaps) {
    for (const FrameRecord& r : s->frames) {
      if (r.state != TrackingState::kTracking && r.state != TrackingState::kCoarse) set.Add(r.timestamp);
    }
  }
  for (const Submap* s : back_submaps) {
    std::vector<Timestamp> t;
    for (const Keyframe& kf : s->keyframes) t.push_back(kf.timestamp);
    std::sort(t.begin(), t.end());
    const size_t k = std::min(t.size(), size_t(n));
    for (size_t i = 0; i < k; ++i) set.Add(t[i]);
    for (size_t i = t.size() - k; i < t.size(); ++i) set.Add(t[i]);
  }
  return set;
}

std::vector<KeyframePair> PairKeyframes(const Submap& front, const Submap& back,
                                        const SearchSet& search, int64_t max_dt_ns) {
  std::vector<int> order(front.keyframes.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return front.keyframes[a].timestamp < front.keyframes[b].timestamp;
  });
  std::vector<KeyframePair> pairs;
  std::vector<char> used(front.keyframes.size(), 0);
  for (size_t b = 0; b < back.keyframes.size(); ++b) {
    const Timestamp t = back.keyframes[b].timestamp;
    if (!search.Contains(t, max_dt_ns)) continue;
    const auto it = std::lower_bound(order.begin(), order.end(), t, [&](int i, Timestamp v) {
      return front.keyframes[i].timestamp < v;
    });
    int best = -1;
    int64_t best_dt = max_dt_ns;
    for (auto c : {it, it == order.begin() ? order.end() : it - 1}) {
      if (c == order.end()) continue;
      const int64_t d = AbsDiff(front.keyframes[*c].timestamp, t);
      if (d < best_dt && !used[*c]) {
        best = *c;
        best_dt = d;
      }
    }
    if (best < 0) continue;
    used[best] = 1;
    pairs.push_back({best, int(b), t - front.keyframes[best].timestamp});
  }
  return pairs;
}

std::vector<FramePair> PairTrackedFrames(const Submap& front, const Submap& back, const SearchSet& search,
                                         int64_t max_dt_ns, const std::vector<KeyframePair>& taken,
                                         int neighbours) {
  std::vector<FramePair> out;
  if (front.keyframes.empty() || neighbours < 1) return out;
  std::vector<int> frames;  // tracked frames of this submap, by time
  for (size_t i = 0; i < front.frames.size(); ++i) {
    const FrameRecord& r = front.frames[i];
    if (r.state == TrackingState::kTracking && (r.submap_id < 0 || r.submap_id == front.id)) frames.push_back(int(i));
  }
  std::sort(frames.begin(), frames.end(),
            [&](int a, int b) { return front.frames[a].timestamp < front.frames[b].timestamp; });
  std::vector<int> kfs(front.keyframes.size());
  std::iota(kfs.begin(), kfs.end(), 0);
  std::sort(kfs.begin(), kfs.end(),
            [&](int a, int b) { return front.keyframes[a].timestamp < front.keyframes[b].timestamp; });
  std::vector<char> paired(back.keyframes.size(), 0);
  for (const KeyframePair& p : taken)
    if (p.back_keyframe >= 0 && p.back_keyframe < int(paired.size())) paired[p.back_keyframe] = 1;
  for (size_t b = 0; b < back.keyframes.size(); ++b) {
    const Timestamp t = back.keyframes[b].timestamp;
    if (paired[b] || !search.Contains(t, max_dt_ns)) continue;
    const auto it =
        NearestInTime(frames.begin(), frames.end(), t, [&](int i) { return front.frames[size_t(i)].timestamp; });
    if (it == frames.end() || AbsDiff(front.frames[size_t(*it)].timestamp, t) >= max_dt_ns) continue;
    const int best = *it;
    FramePair fp{best, int(b), t - front.frames[best].timestamp, {}};
    const Timestamp tf = front.frames[best].timestamp;
    const auto k = std::lower_bound(kfs.begin(), kfs.end(), tf,
                                    [&](int i, Timestamp v) { return front.keyframes[i].timestamp < v; });
    const long pos = long(k - kfs.begin());
    for (long j = std::max(0L, pos - neighbours); j < std::min(long(kfs.size()), pos + neighbours); ++j)
      fp.front_keyframes.push_back(kfs[size_t(j)]);
    out.push_back(std::move(fp));
  }
  return out;
}

}  // namespace rumi
