#pragma once
// The manager's global map: every submap in its own frame plus a Sim(3) from
// that frame into the global frame (design.md), a union-find of connected
// components (submaps merged directly or through a chain: front A <-> back
// <-> front B share one frame although A and B share no image), and the
// fused duplicate points. Merging changes Sim(3)s and welded poses only.
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"

namespace rumi {

struct SubmapKey {
  SubmapSource source = SubmapSource::kFront;
  int64_t id = -1;
  bool operator==(const SubmapKey& o) const { return source == o.source && id == o.id; }
  bool operator<(const SubmapKey& o) const { return source != o.source ? source < o.source : id < o.id; }
};
std::string ToString(const SubmapKey& k);  // "front#3"

// Point `dup_point` of submap `dup` is the same 3D point as `kept_point` of
// `kept` (a back point fused with its front duplicate).
struct FusedPoint {
  int dup = -1;
  int64_t dup_point = -1;
  int kept = -1;
  int64_t kept_point = -1;
};

// A loop that loop closure (loop_closure.h) found: front keyframe
// `query_keyframe` of one submap sees the place keyframe `match_keyframe`
// of an earlier one (or its own) mapped.
struct LoopDetection {
  SubmapKey query_submap, match_submap;
  int64_t query_keyframe = -1, match_keyframe = -1;
  Timestamp query_time = 0, match_time = 0;
  Sim3 S_mq;  // query submap frame -> match submap frame, as found
  // The same as a relation of the two cameras (p_q = S_qm * p_m, camera
  // frames, with scale): what the graph's loop edge measures. It stays true
  // when a correction later moves either submap's keyframes and points
  // together, as S_mq does not.
  Sim3 S_qm;
  int matches = 0, inliers = 0;
  double score = 0;  // bag-of-words
};

// What loop closure keeps across rebuilds and in the map file, so that a
// restarted manager closes the same loops without searching again: each
// front keyframe's raw pose (in its submap's frame, before any loop
// correction; the graph is built from these), what each keyframe's search
// found, and where the last solve put it.
struct LoopMemory {
  std::map<std::pair<SubmapKey, int64_t>, Se3> raw_pose;
  std::map<std::pair<SubmapKey, int64_t>, std::vector<LoopDetection>> searched;
  // Where the last solve put each keyframe of a component with loops
  // (global, with scale: the scale its points carry).
  std::map<std::pair<SubmapKey, int64_t>, Sim3> solved;
  bool empty() const { return raw_pose.empty() && searched.empty() && solved.empty(); }
};

class GlobalMap {
 public:
  struct Entry {
    Submap submap;
    Sim3 S_gl;  // submap (local) frame -> global frame
  };

  // Adds a submap as a component of its own with S_gl = identity. Returns its
  // index, or -1 (and why) when a submap with the same key is present.
  int AddSubmap(Submap s, std::string* why = nullptr);
  int Find(const SubmapKey& key) const;  // -1 when absent

  size_t size() const { return entries_.size(); }
  const Entry& entry(int i) const { return entries_[i]; }
  Entry& entry(int i) { return entries_[i]; }
  const Submap& submap(int i) const { return entries_[i].submap; }
  Submap& submap(int i) { return entries_[i].submap; }
  const Sim3& ToGlobal(int i) const { return entries_[i].S_gl; }
  SubmapKey Key(int i) const { return {entries_[i].submap.source, entries_[i].submap.id}; }

  // Union-find over submaps.
  int Component(int i) const;
  bool Connected(int i, int j) const { return Component(i) == Component(j); }
  std::vector<int> Members(int component) const;
  // Applies S (old global -> new global) to every submap of i's component.
  void MoveComponent(int i, const Sim3& S);
  void Union(int i, int j);
  // The main component: the most posed frames (the longest stretch of the
  // sequence it covers), then the most keyframes; -1 when empty. Ranking by
  // keyframes alone would pick a dense short map over a long merged one.
  int LargestComponent() const;
  // Components' roots, the main one first, in the same order.
  std::vector<int> ComponentsBySize() const;
  int NumKeyframes(int component) const;
  // Distinct frames with a pose: keyframes and tracked frame records.
  int NumPosedFrames(int component) const;

  std::vector<FusedPoint>& fused() { return fused_; }
  const std::vector<FusedPoint>& fused() const { return fused_; }
  LoopMemory& loops() { return loops_; }
  const LoopMemory& loops() const { return loops_; }

  // Restores raw state (used by the map file loader).
  void SetParent(int i, int parent) { parent_[i] = parent; }
  int RawParent(int i) const { return parent_[i]; }

 private:
  std::vector<Entry> entries_;
  mutable std::vector<int> parent_;
  std::vector<FusedPoint> fused_;
  LoopMemory loops_;
};

// Each submap's rank in time order of its first keyframe (ties by index;
// a submap without keyframes first). "An earlier pass" is this order, not
// the map's: a manager's base precedes what it received, and a loaded map
// lists its raw submaps before the baked ones. Frame times are capture
// times (design contract), so one camera's passes follow each other; a
// recording replayed again into the same map would interleave with its
// first replay.
std::vector<int> TimeRanks(const GlobalMap& map);

}  // namespace rumi
