#include "manager/global_map.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>

namespace rumi {

std::string ToString(const SubmapKey& k) {
  const char* s = k.source == SubmapSource::kFront ? "front" : k.source == SubmapSource::kBack ? "back" : "merged";
  return std::string(s) + "#" + std::to_string(k.id);
}

int GlobalMap::AddSubmap(Submap s, std::string* why) {
  const SubmapKey key{s.source, s.id};
  if (Find(key) >= 0) {
    if (why) *why = "submap " + ToString(key) + " is already in the global map";
    return -1;
  }
  entries_.push_back({std::move(s), Sim3()});
  parent_.push_back(int(entries_.size()) - 1);
  return int(entries_.size()) - 1;
}

int GlobalMap::Find(const SubmapKey& key) const {
  for (size_t i = 0; i < entries_.size(); ++i)
    if (Key(int(i)) == key) return int(i);
  return -1;
}

int GlobalMap::Component(int i) const {
  int r = i;
  while (parent_[r] != r) r = parent_[r];
  while (parent_[i] != r) {  // path compression
    const int next = parent_[i];
    parent_[i] = r;
    i = next;
  }
  return r;
}

std::vector<int> GlobalMap::Members(int component) const {
  std::vector<int> m;
  for (size_t i = 0; i < entries_.size(); ++i)
    if (Component(int(i)) == component) m.push_back(int(i));
  return m;
}

void GlobalMap::MoveComponent(int i, const Sim3& S) {
  for (int m : Members(Component(i))) entries_[m].S_gl = S * entries_[m].S_gl;
}

void GlobalMap::Union(int i, int j) {
  const int a = Component(i), b = Component(j);
  if (a != b) parent_[a] = b;
}

int GlobalMap::NumKeyframes(int component) const {
  int n = 0;
  for (int m : Members(component)) n += int(entries_[m].submap.keyframes.size());
  return n;
}

int GlobalMap::NumPosedFrames(int component) const {
  std::set<int64_t> t;
  for (int m : Members(component)) {
    const Submap& s = entries_[m].submap;
    for (const Keyframe& kf : s.keyframes) t.insert(kf.timestamp);
    for (const FrameRecord& f : s.frames)
      if (f.state == TrackingState::kTracking || f.state == TrackingState::kCoarse) t.insert(f.timestamp);
  }
  return int(t.size());
}

std::vector<int> GlobalMap::ComponentsBySize() const {
  std::vector<int> roots;
  std::map<int, std::pair<int, int>> size;  // root -> (posed frames, keyframes)
  for (size_t i = 0; i < entries_.size(); ++i) {
    if (Component(int(i)) != int(i)) continue;
    roots.push_back(int(i));
    size[int(i)] = {NumPosedFrames(int(i)), NumKeyframes(int(i))};
  }
  std::stable_sort(roots.begin(), roots.end(), [&](int a, int b) { return size[a] > size[b]; });
  return roots;
}

int GlobalMap::LargestComponent() const {
  const std::vector<int> roots = ComponentsBySize();
  return roots.empty() ? -1 : roots.front();
}

std::vector<int> TimeRanks(const GlobalMap& map) {
  const int n = int(map.size());
  const auto first_time = [&](int s) {
    const auto& kfs = map.submap(s).keyframes;
    return kfs.empty() ? Timestamp(0) : kfs.front().timestamp;
  };
  std::vector<int> by_time(static_cast<size_t>(n)), rank(static_cast<size_t>(n));
  std::iota(by_time.begin(), by_time.end(), 0);
  std::stable_sort(by_time.begin(), by_time.end(), [&](int a, int b) { return first_time(a) < first_time(b); });
  for (int r = 0; r < n; ++r) rank[size_t(by_time[size_t(r)])] = r;
  return rank;
}

}  // namespace rumi
