#pragma once
// The front's keyframe policy and insertion. A tracked frame becomes a
// keyframe when mapping can take it (cadence, idle mapper, or tracking
// decaying fast) and it tracks noticeably less than the reference keyframe
// or than the peak since the last keyframe.
#include <algorithm>
#include <cstdint>

#include "front/front_options.h"
#include "front/map.h"

namespace rumi {

class LocalMapper;

class KeyframeInserter {
 public:
  explicit KeyframeInserter(const FrontOptions& o) : o_(o) {}
  // A keyframe was made at frame_id tracking `inliers` (initialisation).
  void Reset(int64_t frame_id, int inliers) { last_kf_frame_ = frame_id; peak_inliers_ = inliers; }
  void Relocalised(int inliers) { peak_inliers_ = inliers; }
  void Tracked(int inliers) { peak_inliers_ = std::max(peak_inliers_, inliers); }
  // frame_interval_s: the measured frame interval (cadence without options.fps).
  // The caller holds the map mutex.
  bool Need(const TrackFrame& cur, int inliers, const KeyFrame* ref, const Map& map, const LocalMapper& mapper,
            double frame_interval_s) const;
  // cur as a new keyframe observing its matched points, queued for mapping.
  // The caller holds the map mutex.
  KeyFrame* Insert(const TrackFrame& cur, int inliers, Map* map, LocalMapper* mapper);

 private:
  const FrontOptions& o_;
  int64_t last_kf_frame_ = 0;
  int peak_inliers_ = 0;  // most inliers of a frame since the last keyframe
};

}  // namespace rumi
