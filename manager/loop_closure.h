#pragma once
// Loop closure (#51): a front keyframe that sees a place an earlier keyframe
// of its component mapped is a measurement of the drift accumulated between
// them. As ORB-SLAM does: candidates from the place index (bag of words over
// every keyframe), verified by descriptor matches and a RANSAC Sim(3) over
// the matched 3D points, accepted when several neighbouring keyframes agree,
// then closed in a Sim(3) pose graph over the component's front keyframes
// (pose_graph.h: the correction spread along the walk, a robust solve, the
// edge refused when the rest of the graph disagrees). The points follow
// their reference keyframe, the tracked frames their nearest keyframe, and
// back submaps the front keyframe nearest in time.
//
// The manager rebuilds the map from the received submaps; what a keyframe's
// search found is a fact about two keyframes, so it is searched once
// (LoopClosureState keeps it, the map file too) and the loops are closed
// again at each rebuild from those measurements.
#include <atomic>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "common/geometry.h"
#include "manager/global_map.h"
#include "manager/manager_options.h"
#include "manager/place_index.h"

namespace rumi {

// One loop of a rebuild: its best detection and what closing it did.
struct LoopReport {
  LoopDetection edge;
  int support = 0;         // agreeing keyframes
  double shift = 0;        // how far it moved the query keyframe (global units)
  double shift_ratio = 0;  // ... over the scene depth there
  double rotation_deg = 0, scale_change = 0;
  double depth = 0;        // scene depth at the query keyframe, in its submap's units
  bool closed = false;     // the graph took it (else `reason`)
  std::string reason;
};

struct LoopClosureReport {
  int keyframes_queried = 0;  // this rebuild (new keyframes)
  int candidates_verified = 0;
  int detections = 0;  // verified, over every keyframe of the map
  std::vector<LoopReport> loops;
  int closed = 0;
  int waiting = 0;  // new loops left for the next rebuild (loop_max_solves)
  int keyframes_moved = 0;
  double seconds_detect = 0, seconds_close = 0;
};

// Kept by the manager across rebuilds: the place index, and the memory
// (raw poses, searches) that the map file keeps too (GlobalMap::loops()).
class LoopClosureState {
 public:
  PlaceIndex index;
  LoopMemory memory;
  // The loops decided (closed: true, refused: false), by their first
  // detection's query and match keyframes: not tried again.
  struct GroupKey {
    SubmapKey query_submap;
    int64_t query_keyframe;
    SubmapKey match_submap;
    int64_t match_keyframe;
    bool operator<(const GroupKey& o) const {
      return std::tie(query_submap, query_keyframe, match_submap, match_keyframe) <
             std::tie(o.query_submap, o.query_keyframe, o.match_submap, o.match_keyframe);
    }
  };
  std::map<GroupKey, bool> decided;
  // Index key of a keyframe (the place index keys by int64).
  int64_t Handle(const SubmapKey& s, int64_t keyframe);
  const std::pair<SubmapKey, int64_t>& Keyframe(int64_t handle) const { return handles_[size_t(handle)]; }

 private:
  std::map<std::pair<SubmapKey, int64_t>, int64_t> handle_of_;
  std::vector<std::pair<SubmapKey, int64_t>> handles_;
};

// Searches the front keyframes not searched yet, then closes every loop of
// every component (no-op with options.loop_closure off). fresh[i]: submap i
// is as it came, no correction applied (nullptr: all are); the others
// (the manager's base, corrected by an earlier rebuild) are solved from the
// raw poses kept in *state. Leaves a copy of state->memory in
// map->loops() (for the map file). *cancel: stops between keyframes; the
// map is then as it was.
LoopClosureReport CloseLoops(GlobalMap* map, const ManagerOptions& options, LoopClosureState* state,
                             const std::vector<bool>* fresh = nullptr, const std::atomic<bool>* cancel = nullptr);

// The verification of one candidate (exposed for tests): descriptor matches
// between keyframe q of submap Q and the points of keyframe m of submap M
// and its options.loop_window neighbours each side, then the RANSAC Sim(3).
// False (and why) when it does not hold.
bool VerifyLoop(const Submap& Q, int q, const Submap& M, int m, const ManagerOptions& options, LoopDetection* out,
                std::string* why = nullptr);

}  // namespace rumi
