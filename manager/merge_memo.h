#pragma once
// Memo of MergePair (and PlaceMergePair) outcomes across rebuilds. The manager rebuilds the global
// map from scratch whenever a submap arrives or grows, and a merge (mostly
// its welding BA) costs about 0.15 s: a session of 32 losses took 10 s per
// rebuild (merge_benchmark BM_RebuildSession). A merge's outcome depends only
// on the two submaps as they enter it (the back is never changed by a merge;
// the front is, by fusing and welding) and on which back keyframes are in
// F^search. So an attempt whose front state, back and search membership are
// the same as in an earlier rebuild is replayed: the same Sim(3) joins the
// components, the front takes its stored post-merge state, the fused links
// are restored. Only merges that involve a changed submap are computed again
// (in a live session: the growing front submap and what follows from it).
// The front's post-merge state is kept as an edit (the poses and positions
// the merge changed, a merge changes nothing else), not as a copy: a copy of
// every merged front doubled the manager's memory in a long session.
// The key does not hold the ManagerOptions: use one memo per set of options
// (the service's are fixed for its lifetime).
#include <cstdint>
#include <map>
#include <set>
#include <tuple>
#include <vector>

#include "manager/merge.h"

namespace rumi {

// Content hash of a submap: ids, timestamps, poses, keypoints, point ids,
// octaves, point positions and observations, frame records, odometry
// (descriptors are not hashed; they never change without the rest).
uint64_t SubmapFingerprint(const Submap& s);
// Hash of the keyframe ids and poses only: what a merge's edit (welding)
// changes without changing any count.
uint64_t KeyframePoseFingerprint(const Submap& s);

// What a merge changed in its front submap (index, new value), each list
// sorted by index: keyframe poses and point positions (fusing, welding) and
// frame-record poses.
struct SubmapEdit {
  std::vector<std::pair<int32_t, Se3>> keyframe_poses;
  std::vector<std::pair<int32_t, Eigen::Vector3d>> point_positions;
  std::vector<std::pair<int32_t, Se3>> frame_poses;
  // Begin takes every pose and position of the submap before the merge;
  // Finish keeps those the merge changed. False when the merge changed more
  // than poses and positions (counts): then the edit is unusable.
  void Begin(const Submap& before);
  bool Finish(const Submap& after);
  void Apply(Submap* s) const;
  size_t size() const { return keyframe_poses.size() + point_positions.size() + frame_poses.size(); }
};

class MergeMemo {
 public:
  // Starts a MergeAll run over `map`'s current submaps with this F^search
  // (and resets hits / misses).
  // With content fingerprints (SubmapFingerprint per map index, 0: hash it
  // here) set just before, for the map of the next BeginRun or BeginPlaceRun:
  // a caller that keeps its submaps across rebuilds hashes each version once
  // (hashing a whole long session at every rebuild took 0.2 s).
  void SetContentFingerprints(std::vector<uint64_t> fingerprints) { content_ = std::move(fingerprints); }
  void BeginRun(const GlobalMap& map, const SearchSet& search, int64_t max_dt_ns);
  // MergePair, or its replay when the memo holds the same attempt.
  MergeReport Merge(GlobalMap* map, int front, int back, const SearchSet& search, const ManagerOptions& options);
  // Keeps only the MergePair attempts of this run.
  void EndRun();

  // The same for PlaceMergeAll (front submap `a` is the one that moves and
  // is welded, as in PlaceMergePair); hits and misses add to the run's.
  // Called on the same map right after a MergeAll run, it goes on with that
  // run's fingerprints (the map must not change in between).
  void BeginPlaceRun(const GlobalMap& map);
  MergeReport Place(GlobalMap* map, int a, int b, const ManagerOptions& options);
  void EndPlaceRun();

  size_t size() const { return entries_.size(); }
  int hits() const { return hits_; }      // since BeginRun
  int misses() const { return misses_; }  // since BeginRun

 private:
  enum Kind : uint64_t { kBackMerge = 1, kPlaceMerge = 2 };
  // kind, moving front's state, the other submap, back's search membership
  using Key = std::tuple<uint64_t, uint64_t, uint64_t, uint64_t>;
  struct Entry {
    MergeReport report;
    SubmapEdit front_edit;                           // merged only
    std::vector<std::pair<int64_t, int64_t>> fused;  // front point id, other submap's point id
  };
  template <typename Compute>
  MergeReport Attempt(GlobalMap* map, int front, int other, const Key& key, Compute compute);
  void Drop(Kind kind);
  uint64_t Fingerprint(const GlobalMap& map, int i);
  void StartFingerprints(const GlobalMap& map);
  static uint64_t KeyHash(const Key& key);

  std::map<Key, Entry> entries_;
  std::set<Key> used_;
  // Per map index; 0: not computed. A merge's outcome depends only on its
  // key, so the front's fingerprint after it is the key's hash (no rehash).
  std::vector<uint64_t> fingerprint_;
  std::vector<uint64_t> content_;  // SetContentFingerprints, for the next run
  bool chained_ = false;           // fingerprint_ is BeginRun's map's
  std::vector<uint64_t> membership_;   // per back index
  int hits_ = 0, misses_ = 0;
};

}  // namespace rumi
