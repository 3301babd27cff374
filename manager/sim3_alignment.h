#pragma once
// Initial alignment T_ini of a front submap to a back submap (paper step 1):
// Umeyama Sim(3) on the centres of the paired keyframes, and a RANSAC Sim(3)
// over the 3D correspondences of M_com; the candidate with the higher inlier
// ratio (measured on M_com) wins. Merges with too few pairs or an inlier
// ratio <= min_inlier_ratio are rejected with a reason.
#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"
#include "manager/common_points.h"
#include "manager/manager_options.h"
#include "manager/pairing.h"

namespace rumi {

struct RansacSim3Result {
  bool ok = false;
  Sim3 transform;             // maps src into dst
  std::vector<char> inliers;  // per correspondence
  int num_inliers = 0;
};

// Minimal 3-point samples drawn with a seeded RNG; the best model is refitted
// on its inliers. Inlier: |dst - S * src| < threshold.
RansacSim3Result RansacSim3(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                            double threshold, int iterations, uint32_t seed);

struct AlignmentResult {
  bool ok = false;
  std::string reason;  // why the merge was rejected (empty when ok)
  Sim3 S_bf;           // front submap frame -> back submap frame
  std::string method;  // "umeyama-keyframes" or "ransac-points"
  int num_keyframe_pairs = 0;
  int num_point_matches = 0;
  int num_inliers = 0;
  double inlier_ratio = 0.0;
  double inlier_threshold = 0.0;  // back submap units
  double umeyama_inlier_ratio = 0.0, ransac_inlier_ratio = 0.0;
  std::vector<char> inliers;  // per common.matches
};

// frame_pairs count towards min_keyframe_pairs and add their centres (the
// tracked frame's) to the keyframe-centre candidate.
AlignmentResult AlignSubmaps(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                             const CommonPoints& common, const ManagerOptions& options,
                             const std::vector<FramePair>& frame_pairs = {});

// Median distance of the points to their centroid: the scene scale of a submap.
double SceneRadius(const std::vector<Eigen::Vector3d>& points);

}  // namespace rumi
