#pragma once
// ORB keypoints on back keyframes. COLMAP's SIFT keypoints cannot be matched
// with the front's ORB map points; ORB corners detected the front's way can
// (the manager's SearchFrontPoints). They are appended after the SIFT ones
// with no map point; the SIFT keypoints get all-zero descriptor rows, which
// stand for "no descriptor" (HasDescriptor).
#include <opencv2/core.hpp>

#include "common/orb_extractor.h"
#include "common/submap.h"

namespace rumi {

// `grey` is the undistorted image of kf (the one COLMAP saw). Returns the
// number of ORB keypoints added.
int AddOrbKeypoints(const cv::Mat& grey, OrbExtractor* orb, Keyframe* kf);

}  // namespace rumi
