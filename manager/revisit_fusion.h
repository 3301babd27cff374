#pragma once
// Revisit fusion: a front submap that looks at a place an earlier front
// submap of its component mapped (a place merge, a loop, a looped walk)
// maps the same corners again under new point ids. Nothing tells culling
// that those are the same points, so every pass over a room kept its
// keyframes (a 25-minute looped walk: 94 % of 8,045 keyframes survived
// culling) and the manager grew with the session (#18). As ORB-SLAM's loop
// fusion does, each front keyframe's mapped corners are matched against the
// points of the nearest keyframes of earlier front submaps, projected with
// the merged Sim(3)s; a corner and a point that agree in image position,
// descriptor and depth become a FusedPoint, which post-culling counts as one
// point with the observers of both.
#include <cstdint>
#include <map>
#include <vector>

#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

struct RevisitFusionReport {
  int keyframes_searched = 0;  // front keyframes with earlier neighbours
  int keyframes_corrected = 0;  // of those, placed against the earlier pass by PnP
  int fused = 0;               // FusedPoints added
  int submaps_replayed = 0;    // searched submaps whose links came from the memo
  double seconds = 0;
};

// What each submap's last search found, kept across rebuilds. A fused link
// is a fact about two points, not about the merge that brought them
// together, so a submap is searched again only when it or the earlier front
// submaps of its component changed (who those submaps are, their counts of
// keyframes, points and frames, and their keyframe poses). The live manager
// searched every received submap at each rebuild: 2.9 s of a 3.35 s rebuild
// after 12 minutes of a looped walk.
class RevisitMemo {
 public:
  struct Link {
    int64_t point = -1;  // of the searched submap
    SubmapKey kept;
    int64_t kept_point = -1;
  };
  struct Entry {
    std::vector<int64_t> signature;
    std::vector<Link> links;
  };
  std::map<SubmapKey, Entry>& entries() { return entries_; }
  // Keeps only the entries of the submaps searched[i] of the map (a baked
  // submap is not searched again: its links are in the map).
  void Retain(const GlobalMap& map, const std::vector<bool>& searched);

 private:
  std::map<SubmapKey, Entry> entries_;
};

// Adds the FusedPoints (dup: the later submap's point, kept: the earlier
// one's) that the map does not hold yet. With `searched`, only the keyframes
// of submaps i with searched[i] are searched (the manager's received ones: a
// baked submap's links were found when it arrived and stay in the map), so a
// rebuild's cost follows what changed, not the session. No-op when
// options.revisit_fusion is off or options.front_search_px is 0 (the same
// matcher). With a memo, a searched submap whose signature is unchanged
// gets its links from it instead of a search.
RevisitFusionReport FuseRevisitPoints(GlobalMap* map, const ManagerOptions& options,
                                      const std::vector<bool>* searched = nullptr, RevisitMemo* memo = nullptr);

}  // namespace rumi
