#pragma once
// Post-culling (paper step 3, after merging; the ORB-SLAM keyframe rule): a
// keyframe is redundant when at least `culling_redundant_ratio` of its map
// points are seen by at least `culling_min_observers` other keyframes at the
// same or a finer octave (octave <= its own + culling_octave_tolerance).
// Observers count across submaps through fused points (FuseRevisitPoints,
// run first, adds those of revisited places) and through front points found
// in back keyframes (SearchFrontPoints). Revisits are culled first (newest
// submap first): a front keyframe whose points are, for at least
// `culling_revisit_ratio` of them, seen that way by a living keyframe of
// an earlier front submap (lower index) re-images a place an earlier pass mapped. Then back keyframes
// (they duplicate the front ones), then front ones. Points left without
// observations are removed. A culled keyframe's pose stays as a FrameRecord
// so the global trajectory keeps it.
#include "manager/global_map.h"
#include "manager/manager_options.h"
#include "manager/revisit_fusion.h"

namespace rumi {

struct CullingReport {
  int keyframes_before = 0, keyframes_after = 0;  // "saved frames"
  int points_before = 0, points_after = 0;
  int culled_back = 0, culled_front = 0;
  int culled_revisit = 0;  // front keyframes of a pass over a place an earlier one mapped
  int culled_revisit_detected = 0;  // ... found so by a verified loop detection, not by fused points
  int front_points_found = 0;  // observations added by SearchFrontPoints
  double seconds_front_search = 0;  // of the culling's time, SearchFrontPoints'
  // FuseRevisitPoints, run first: front keyframes searched, points fused.
  int revisit_keyframes_searched = 0, revisit_keyframes_placed = 0, revisit_fused = 0, revisit_submaps_replayed = 0;
  double seconds_revisit = 0;
  // Why back keyframes stay: over the back keyframes examined, the median
  // share of their points seen by culling_min_observers others (culling
  // needs culling_redundant_ratio), at the time each was examined.
  int back_examined = 0;
  double back_redundant_share_median = 0;
};

// revisit_searched, revisit_memo: FuseRevisitPoints' `searched` (nullptr:
// every submap) and `memo`.
CullingReport CullRedundantKeyframes(GlobalMap* map, const ManagerOptions& options,
                                     const std::vector<bool>* revisit_searched = nullptr,
                                     RevisitMemo* revisit_memo = nullptr);

}  // namespace rumi
