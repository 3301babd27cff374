#pragma once
// Post-culling (paper step 3, after merging; the ORB-SLAM keyframe rule): a
// keyframe is redundant when at least `culling_redundant_ratio` of its map
// points are seen by at least `culling_min_observers` other keyframes at the
// same or a finer octave (octave <= its own + culling_octave_tolerance). Observers count across submaps
// through fused points and through front points found in back keyframes
// (SearchFrontPoints, run first). Back keyframes are culled first (they duplicate the
// front ones); points left without observations are removed. A culled
// keyframe's pose stays as a FrameRecord so the global trajectory keeps it.
#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

struct CullingReport {
  int keyframes_before = 0, keyframes_after = 0;  // "saved frames"
  int points_before = 0, points_after = 0;
  int culled_back = 0, culled_front = 0;
  int front_points_found = 0;  // observations added by SearchFrontPoints
  double seconds_front_search = 0;  // of the culling's time, SearchFrontPoints'
  // Why back keyframes stay: over the back keyframes examined, the median
  // share of their points seen by culling_min_observers others (culling
  // needs culling_redundant_ratio), at the time each was examined.
  int back_examined = 0;
  double back_redundant_share_median = 0;
};

CullingReport CullRedundantKeyframes(GlobalMap* map, const ManagerOptions& options);

}  // namespace rumi
