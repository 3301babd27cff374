#pragma once
// Front map points found in back keyframes, the way ORB-SLAM's fusion finds a
// map point in a keyframe: project it with the merged Sim(3)s, then take the
// closest ORB descriptor among the keyframe's ORB keypoints (rumi-back adds
// them, back/keyframe_orb.h) within a radius growing with the keypoint's
// octave. Back and front points are different features (SIFT blobs vs FAST
// corners) and are rarely fused, so without this a back keyframe that only
// re-images what the front mapped looks necessary to post-culling.
#include <cstdint>
#include <unordered_map>
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

// The search itself, shared with the revisit fusion (revisit_fusion.h): the
// ORB keypoints of one keyframe bucketed by position, either those without a
// map point (a back keyframe's ORB keypoints) or those with one (a front
// keyframe's mapped corners).
class KeyframeSearch {
 public:
  KeyframeSearch(const Keyframe& kf, const CameraIntrinsics& camera, bool mapped);
  // The keypoint that best images a point at X (the keyframe's submap frame)
  // with descriptor `desc`: ORB-SLAM's scale prediction from max_distance
  // (PointMaxDistance, same units as X), then the closest descriptor within
  // radius_px x 1.2^level and max_hamming. -1 when none; *hamming its distance.
  // T_cw: the keyframe's pose to project with (nullptr: its own).
  int Match(const Eigen::Vector3d& X, const uint8_t* desc, double max_distance, double radius_px, int max_hamming,
            int* hamming, const Se3* T_cw = nullptr) const;

 private:
  const Keyframe& kf_;
  const CameraIntrinsics& camera_;
  int cols_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;
};

// A map point's ORB descriptor: its representative, else any observation's;
// nullptr when it has none. kf_index: keyframe id -> index in s.
const uint8_t* PointDescriptor(const Submap& s, const MapPoint& p, const std::unordered_map<int64_t, int>& kf_index);
// ORB-SLAM's scale-invariance distance: the distance from its first observing
// keyframe times that observation's level scale (0 when unknown).
double PointMaxDistance(const Submap& s, const MapPoint& p, const std::unordered_map<int64_t, int>& kf_index);

}  // namespace rumi
