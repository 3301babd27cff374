#pragma once
// Place merge: joins two front submaps that no back submap connects, by
// recognising the same place in both (ORB-SLAM's map merging, without a
// vocabulary: the maps are small enough to match every map point). The back
// cannot bridge a stretch where COLMAP registers nothing (a fast pan, a
// blur), but the front's next submap often looks at the same scene again.
// Map-point descriptors are matched across the two submaps, a RANSAC Sim(3)
// over the 3D pairs keeps the consistent ones, Formula 8 refines it with the
// larger side fixed, and the merge then goes on as a back merge does (fuse,
// welding BA). Strict thresholds: a wrong place merge would bend the map,
// a missed one only leaves two components.
#include <vector>

#include "manager/common_points.h"
#include "manager/global_map.h"
#include "manager/manager_options.h"
#include "manager/merge.h"

namespace rumi {

// Map points of `a` matched to map points of `b` by descriptor (points with a
// descriptor and at least two observations): nearest within max_hamming bits
// and closer than ratio times the second nearest, one-to-one (the closer
// claim on a `b` point wins). PointMatch: front_point_id in `a`, back_point_id
// in `b`.
std::vector<PointMatch> MatchMapPoints(const Submap& a, const Submap& b, int max_hamming, double ratio);

// Tries to merge submap `a` into submap `b` (both front) by place
// recognition. Reason set when not merged.
MergeReport PlaceMergePair(GlobalMap* map, int a, int b, const ManagerOptions& options);

// Tries every pair of front submaps in different components, repeating until
// no merge succeeds. No-op when options.place_merge is off.
std::vector<MergeReport> PlaceMergeAll(GlobalMap* map, const ManagerOptions& options);

}  // namespace rumi
