#pragma once
// Front map points found in back keyframes, the way ORB-SLAM's fusion finds a
// map point in a keyframe: project it with the merged Sim(3)s, then take the
// closest ORB descriptor among the keyframe's ORB keypoints (rumi-back adds
// them, back/keyframe_orb.h) within a radius growing with the keypoint's
// octave. Back and front points are different features (SIFT blobs vs FAST
// corners) and are rarely fused, so without this a back keyframe that only
// re-images what the front mapped looks necessary to post-culling.
#include <cstdint>
#include <vector>

#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

// Keypoint `keypoint` of keyframe `keyframe_id` of back submap `back` images
// point `point_id` of front submap `front`.
struct CrossObservation {
  int back = -1;
  int64_t keyframe_id = -1;
  int32_t keypoint = -1;
  uint8_t octave = 0;
  int front = -1;
  int64_t point_id = -1;
};

// Every back submap against the front submaps of its component. A keypoint
// goes to the closest descriptor; a front point is found at most once per
// keyframe. Empty when options.front_search_px == 0.
std::vector<CrossObservation> SearchFrontPoints(const GlobalMap& map, const ManagerOptions& options);

}  // namespace rumi
