#include "manager/merge_verify.h"

#include <cmath>

#include "common/logging.h"
#include "common/stats.h"
#include "manager/sim3_alignment.h"

namespace rumi {

void PoseDisagreement(const Se3& T_wc_front, const Se3& T_wc_back, const Sim3& S_bf, double scene_radius,
                      double* angle_deg, double* offset_ratio) {
  const Se3 moved = S_bf.TransformPose(T_wc_front);
  *angle_deg = RotationAngle(T_wc_back.rotation().conjugate() * moved.rotation()) * 180.0 / M_PI;
  const double d = (moved.translation() - T_wc_back.translation()).norm();
  *offset_ratio = scene_radius > 0 ? d / scene_radius : INFINITY;
}

MergeVerification VerifyMerge(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                              const std::vector<FramePair>& frame_pairs, const Sim3& S_bf, int inliers,
                              int kept, double rmse_px, const ManagerOptions& o) {
  MergeVerification v;
  std::vector<Eigen::Vector3d> points;
  points.reserve(back.points.size());
  for (const MapPoint& p : back.points) points.push_back(p.position);
  const double radius = SceneRadius(points);

  std::vector<double> angles, offsets;
  auto compare = [&](const Se3& T_front, const Se3& T_back) {
    double a = 0, r = 0;
    PoseDisagreement(T_front, T_back, S_bf, radius, &a, &r);
    angles.push_back(a);
    offsets.push_back(r);
    if (a <= o.verify_max_pose_angle_deg && r <= o.verify_max_pose_offset) ++v.agreeing_pairs;
  };
  for (const KeyframePair& p : pairs)
    compare(front.keyframes[p.front_keyframe].T_wc(), back.keyframes[p.back_keyframe].T_wc());
  for (const FramePair& p : frame_pairs)
    compare(front.frames[p.front_frame].T_wc, back.keyframes[p.back_keyframe].T_wc());
  v.pose_pairs = int(angles.size());
  v.median_angle_deg = Median(angles).value_or(0.0);
  v.median_offset_ratio = Median(offsets).value_or(0.0);

  if (inliers < o.verify_min_inliers) {
    v.check = "inliers";
    v.why = fmt::format("{} inliers < {}", inliers, o.verify_min_inliers);
  } else if (kept < o.verify_min_kept_ratio * inliers) {
    v.check = "kept";
    v.why = fmt::format("{} of {} inliers still agree after refinement, under {:.0f} %", kept, inliers,
                        100.0 * o.verify_min_kept_ratio);
  } else if (rmse_px > o.verify_max_rmse_px) {
    v.check = "rmse";
    v.why = fmt::format("refined reprojection RMSE {:.2f} px > {:.2f} px", rmse_px, o.verify_max_rmse_px);
  } else if (v.agreeing_pairs < o.verify_min_agreeing_pairs ||
             v.agreeing_pairs < o.verify_min_agreeing_ratio * v.pose_pairs) {
    v.check = "pose_pairs";
    v.why = fmt::format("{} of {} paired poses agree (median {:.2f} deg, {:.3f} x scene radius apart)",
                        v.agreeing_pairs, v.pose_pairs, v.median_angle_deg, v.median_offset_ratio);
  }
  v.ok = v.check.empty();
  return v;
}

}  // namespace rumi
