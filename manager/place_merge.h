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
#include <atomic>
#include <map>
#include <utility>
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

// Pairs of submaps already matched without a merge, with their keyframe and
// point counts then: the manager rebuilds the map every time a submap
// arrives, and a finished front submap never changes, so with the memo only
// pairs that involve a grown submap are matched again (O(n) per rebuild, not
// O(n^2)). A rejection depends only on the two submaps and the options.
// It also remembers which submap each one last merged with: a front submap
// resent while it grows is tried first against that one, which it almost
// always joins again, instead of against every earlier front in index order
// (in a looped walk that was tens of full matchings per rebuild).
class PlaceMergeMemo {
 public:
  // The pair was rejected before, and since then neither side has grown by
  // `retry_growth` of its keyframes nor shrunk (0: neither changed at all).
  // PlaceMergeAll gives a growth only for pairs with the newest front, the
  // one still being built: it is resent every 2 s, and matching it at each
  // resend against every front it does not join was most of a rebuild's
  // place time. Finished fronts are matched again at any change, so once in
  // their final form.
  bool Rejected(const Submap& a, const Submap& b, double retry_growth = 0) const;
  void AddRejected(const Submap& a, const Submap& b);
  size_t size() const { return rejected_.size(); }
  void SetPartner(const SubmapKey& a, const SubmapKey& b) { partner_[a] = b, partner_[b] = a; }
  const SubmapKey* Partner(const SubmapKey& a) const {
    const auto it = partner_.find(a);
    return it == partner_.end() ? nullptr : &it->second;
  }

 private:
  std::map<SubmapKey, SubmapKey> partner_;
  struct Sizes {
    size_t keyframes_a, points_a, keyframes_b, points_b;
  };
  std::map<std::pair<SubmapKey, SubmapKey>, Sizes> rejected_;  // at the last rejection
};

// Tries every pair of front submaps in different components, repeating until
// no merge succeeds; for each submap, the earlier ones in index order, its
// last partner (memo) first. No-op when options.place_merge is off. With a
// memo, pairs it holds are skipped and new rejections and partners are
// added to it. With a
// merge memo, attempts on unchanged submaps are replayed (merge_memo.h).
// *cancel: as MergeAll's.
std::vector<MergeReport> PlaceMergeAll(GlobalMap* map, const ManagerOptions& options,
                                       PlaceMergeMemo* memo = nullptr, MergeMemo* merge_memo = nullptr,
                                       const std::atomic<bool>* cancel = nullptr);

}  // namespace rumi
