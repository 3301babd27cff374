#pragma once
// Verification of a refined merge before it is committed: the checks a wrong
// alignment cannot pass. RUMI's rule (inlier ratio > 0.1) accepts a Sim(3)
// fitted to a handful of lucky points; the paired keyframes are the same
// images in both submaps, so under a right Sim(3) their poses coincide, and a
// wrong one moves them apart. Each check that fails is named, so the log and
// manager_stats.json say what rejected a merge.
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"
#include "manager/manager_options.h"
#include "manager/pairing.h"

namespace rumi {

struct MergeVerification {
  bool ok = false;
  std::string check;  // the failing check: "inliers", "kept", "rmse", "pose_pairs" (empty when ok)
  std::string why;    // human-readable, with the figures
  int pose_pairs = 0;        // keyframe + frame pairs compared
  int agreeing_pairs = 0;    // pairs within both pose tolerances
  double median_angle_deg = 0;   // rotation between the paired poses
  double median_offset_ratio = 0;  // centre distance / back scene radius
};

// Pose agreement of one pair: the front pose (front frame) moved into the
// back frame by S_bf against the back pose of the same image.
void PoseDisagreement(const Se3& T_wc_front, const Se3& T_wc_back, const Sim3& S_bf, double scene_radius,
                      double* angle_deg, double* offset_ratio);

// inliers: the alignment's (RANSAC) inlier count; kept: how many of them
// still agree in 3D under the refined S_bf (what the merge would fuse; a
// refinement that pulls away from the points it was fitted to is a wrong
// alignment); rmse_px: the refined reprojection RMSE. Pairs are those the
// merge used (front kf or tracked frame <-> back keyframe).
MergeVerification VerifyMerge(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                              const std::vector<FramePair>& frame_pairs, const Sim3& S_bf, int inliers,
                              int kept, double rmse_px, const ManagerOptions& options);

}  // namespace rumi
