#pragma once
// M_com: common map points of a front and a back submap found on paired
// keyframes by image-plane position, not by descriptor (the back has SIFT,
// the front ORB; a paired keyframe is the same image). No geometric
// verification here: the alignment's RANSAC and the robust BA handle outliers.
#include <cstdint>
#include <vector>

#include "common/submap.h"
#include "manager/pairing.h"

namespace rumi {

struct PointMatch {
  int64_t front_point_id = -1;
  int64_t back_point_id = -1;
  int votes = 0;  // paired keyframes on which the two keypoints coincided
};

struct CommonPoints {
  std::vector<PointMatch> matches;  // one-to-one, sorted by front point id
  int keypoint_matches = 0;         // raw keypoint-level matches (all pairs)
  int conflicts_dropped = 0;        // (front, back) candidates lost the vote
};

// For each paired keyframe, each front keypoint with a map point is matched to
// the nearest back keypoint with a map point within radius_px. Votes are
// summed over pairs; a front point matched to several back points keeps the
// most frequent (and vice versa), ties to the smaller id.
CommonPoints FindCommonPoints(const Submap& front, const Submap& back,
                              const std::vector<KeyframePair>& pairs, double radius_px);

// As above, plus frame pairs: the front points observed by a frame pair's
// front keyframes are projected with the tracked frame's pose (in front of
// the camera, inside the image), and each back keypoint with a map point takes
// the nearest projection within radius_px; it is dropped when a second
// projection lies within the radius and the nearest is not clearly closer
// (d1 >= ratio * d2). Votes add to those of the keyframe pairs.
CommonPoints FindCommonPoints(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                              const std::vector<FramePair>& frame_pairs, double radius_px, double ratio = 0.7);

}  // namespace rumi
