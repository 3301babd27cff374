#include "front/keyframe_inserter.h"

#include <cmath>

#include "front/local_mapping.h"

namespace rumi {

bool KeyframeInserter::Need(const TrackFrame& cur, int inliers, const KeyFrame* ref, const Map& map,
                            const LocalMapper& mapper, double frame_interval_s) const {
  if (mapper.QueueSize() > 2) return false;
  if (!ref) return true;
  const int nkf = map.NumGoodKeyFrames();
  const int ref_tracked = ref->TrackedPoints(nkf <= 2 ? 2 : 3);
  const int64_t since = cur.id - last_kf_frame_;
  const double fps = o_.fps > 0 ? o_.fps : (frame_interval_s > 0 ? 1.0 / frame_interval_s : 10.0);
  const bool c1a = since >= static_cast<int64_t>(std::round(fps));
  const bool c1b = mapper.Idle();
  // The reference count only includes points seen by >= 3 keyframes, so a
  // young reference (just inserted, its points freshly triangulated) has few
  // and tracking could decay through a whole turn with no keyframe (seen on
  // `smooth`: inliers 309 -> 134 over 0.8 s, then a scale collapse). Hence
  // also: tracking has weakened against what the last keyframe tracked, and,
  // much weaker, a keyframe even while mapping is busy. The peak since the
  // last keyframe is the baseline: the keyframe's own frame sees few points,
  // the next ones also the points triangulated from it.
  const bool weak = inliers < o_.kf_weak_ratio * peak_inliers_;
  const bool c1c = inliers < 0.5 * o_.kf_weak_ratio * peak_inliers_;
  const bool c2 = (inliers < o_.kf_tracked_ratio * ref_tracked || weak) && inliers > 15;
  return (c1a || c1b || c1c) && c2;
}

KeyFrame* KeyframeInserter::Insert(const TrackFrame& cur, int inliers, Map* map, LocalMapper* mapper) {
  KeyFrame* kf = map->NewKeyFrame(cur.timestamp, cur.id, cur.f, cur.T_cw);
  for (size_t i = 0; i < cur.points.size(); ++i) {
    Landmark* p = cur.points[i];
    if (p && !p->bad && !p->obs.count(kf)) Map::AddObservation(p, kf, static_cast<int>(i));
  }
  last_kf_frame_ = cur.id;
  peak_inliers_ = inliers;
  mapper->Push(kf);
  return kf;
}

}  // namespace rumi
