#include "manager/global_map.h"

#include <map>

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

int GlobalMap::LargestComponent() const {
  std::map<int, int> kfs;
  for (size_t i = 0; i < entries_.size(); ++i) kfs[Component(int(i))] += int(entries_[i].submap.keyframes.size());
  int best = -1, best_n = -1;
  for (const auto& [c, n] : kfs) {
    if (n > best_n) {
      best = c;
      best_n = n;
    }
  }
  return best;
}

}  // namespace rumi
