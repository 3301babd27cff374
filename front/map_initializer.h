#pragma once
// The first map of a submap, from two views: a reference frame, its features
// matched in the following frames (up to init_max_frames later), a two-view
// reconstruction (front/initializer.h), then two keyframes and their points
// refined by a full BA and scaled to a median depth of 1. A re-initialisation
// (a submap after a loss) uses its own, lower thresholds: a first map can
// wait for a better baseline, a re-initialisation cannot.
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "front/front_options.h"
#include "front/initializer.h"
#include "front/map.h"

namespace rumi {

struct InitialMap {
  KeyFrame* kf0 = nullptr;  // the reference frame (fixed)
  KeyFrame* kf1 = nullptr;  // the current frame
  int tracked = 0;          // points of kf1
  int64_t gap = 1;          // frames between them
  TwoViewResult two_view;
};

class MapInitializer {
 public:
  explicit MapInitializer(const FrontOptions& o) : o_(o) {}
  void Reset() { ref_.reset(); }
  // Feeds one frame: true when it and the reference reconstruct (then Build).
  bool Match(const TrackFrame& cur, bool reinit, const PinholeCamera& cam);
  // The initial map in `map` (caller holds its mutex). False when it is too
  // weak: the map is emptied and the reference dropped.
  bool Build(const TrackFrame& cur, bool reinit, Map* map, const PinholeCamera& cam, const ScalePyramid& pyr,
             InitialMap* out);

 private:
  void SetReference(const TrackFrame& cur);
  int MinPoints(bool reinit) const { return reinit ? o_.reinit_min_triangulated : o_.init_min_triangulated; }

  const FrontOptions& o_;
  std::shared_ptr<const Features> ref_;
  Timestamp ref_t_ = 0;
  int64_t ref_frame_ = 0;
  std::vector<Eigen::Vector2d> prev_matched_;
  std::vector<std::pair<int, int>> matches_;  // reference keypoint, current keypoint
  TwoViewResult two_view_;
};

}  // namespace rumi
