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
#include <vector>

#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

struct RevisitFusionReport {
  int keyframes_searched = 0;  // front keyframes with earlier neighbours
  int keyframes_corrected = 0;  // of those, placed against the earlier pass by PnP first
  int fused = 0;               // FusedPoints added
  double seconds = 0;
};

// Adds the FusedPoints (dup: the later submap's point, kept: the earlier
// one's) that the map does not hold yet. With `searched`, only the keyframes
// of submaps i with searched[i] are searched (the manager's received ones: a
// baked submap's links were found when it arrived and stay in the map), so a
// rebuild's cost follows what changed, not the session. No-op when
// options.revisit_fusion is off or options.front_search_px is 0 (the same
// matcher).
RevisitFusionReport FuseRevisitPoints(GlobalMap* map, const ManagerOptions& options,
                                      const std::vector<bool>* searched = nullptr);

}  // namespace rumi
