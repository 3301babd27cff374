#pragma once
// Options of the manager's merging pipeline (YAML section `manager:`).
#include <cstdint>
#include <string>

#include "common/option_spec.h"

namespace rumi {

struct ManagerOptions {
  // Pairing: a back and a front keyframe are the same image when their
  // timestamps differ by strictly less than this (1e-4 s).
  int64_t pairing_max_dt_ns = 100000;
  // F^search: first and last n keyframes of each back submap (plus the frames
  // the front failed on). 0 = every back keyframe.
  int search_n = 10;
  // M_com: keypoints of paired keyframes within this radius (undistorted px).
  double match_radius_px = 3.0;
  // Also pair a back keyframe with a tracked front frame (FrameRecord) when no
  // front keyframe has its timestamp: front points of the nearest keyframes
  // (pair_neighbour_keyframes before and after) are projected with the
  // frame's pose and matched by position; the match is dropped when another
  // projection lies within the radius and the nearest is not closer than
  // pair_ratio times the runner-up.
  bool pair_tracked_frames = true;
  int pair_neighbour_keyframes = 3;
  double pair_ratio = 0.7;
  // A merge needs at least this many keyframe pairs and common points.
  int min_keyframe_pairs = 1;
  int min_common_points = 20;
  // ... and an inlier ratio strictly above this.
  double min_inlier_ratio = 0.1;
  // Verification after refinement (manager/merge_verify.h): a merge needs
  // verify_min_inliers inliers, verify_min_kept_ratio of them still in
  // agreement in 3D under the refined Sim(3) (right merges keep 88-98 %, the
  // harmful one of 2026-11-28 kept 14 of 42), a refined reprojection RMSE of at most
  // verify_max_rmse_px, and paired poses (the same image in both submaps)
  // that agree under the Sim(3): within verify_max_pose_angle_deg and
  // verify_max_pose_offset x the back scene radius, for at least
  // verify_min_agreeing_pairs pairs and verify_min_agreeing_ratio of them.
  bool verify_merges = true;
  int verify_min_inliers = 20;
  double verify_min_kept_ratio = 0.5;
  double verify_max_rmse_px = 3.0;
  double verify_max_pose_angle_deg = 5.0;
  double verify_max_pose_offset = 0.1;
  int verify_min_agreeing_pairs = 1;
  double verify_min_agreeing_ratio = 0.5;
  // RANSAC Sim(3) over 3D point correspondences.
  int ransac_iterations = 300;
  double ransac_threshold_ratio = 0.05;  // inlier distance / median scene radius
  uint32_t ransac_seed = 42;
  // Robust loss of the Sim(3) refinement and the welding BA.
  std::string robust_loss = "huber";  // "huber" or "cauchy"
  double robust_loss_scale_px = 2.0;
  // After a first solve, residuals above this are dropped and the solve repeated.
  double outlier_threshold_px = 6.0;
  int refine_max_iterations = 30;
  // Formula 8 observations per matched point and side (evenly spread over its
  // keyframes): enough for conditioning, bounded cost.
  int refine_max_obs_per_point = 4;
  // Welding window: matched front keyframes + keyframes sharing at least this
  // many map points with one of them.
  int welding_min_covisible = 15;
  // At most this many window keyframes: the seeds, then the most covisible.
  int welding_max_keyframes = 30;
  int ba_max_iterations = 10;
  // Off by default: the BA holds the back fixed and pulls the window's front
  // keyframes onto it, but the tracked frames between them keep their poses;
  // on 27 generated runs it made the front's own frames up to 1.24x worse and
  // the merged ATE no better (within 7 %, either way). Worth turning on where
  // the back submaps are known to be more accurate than the front.
  bool welding_ba = false;
  // A welding solve that moves a window keyframe's centre by more than this
  // x the front scene radius is not applied (welding_ba.h).
  double welding_max_shift = 0.05;
  // Post-culling (ORB-SLAM rule): a keyframe is redundant when at least
  // culling_redundant_ratio of its map points are seen by at least
  // culling_min_observers other keyframes at the same or a finer octave.
  double culling_redundant_ratio = 0.9;
  int culling_min_observers = 3;
  // Observers up to this many pyramid levels coarser still count: ORB-SLAM's
  // code (and rumi's front, local_mapping.cc) allow one level of jitter in
  // the level a corner is detected at. Back SIFT observations are all level 0.
  int culling_octave_tolerance = 1;
  // Revisit culling (post_culling.h), before the rule above: a front keyframe
  // at least this share of whose points a living keyframe of an earlier
  // front submap sees (through fused points) maps a place an earlier pass mapped,
  // and goes, the newest pass first. The rest of its
  // points go with it unless others see them. Without it a looped room keeps
  // every pass. 0: off.
  double culling_revisit_ratio = 0.5;
  // ... or this share of whose points were inliers of a verified loop
  // detection (loop_closure.h) against an earlier front submap of its
  // component whose keyframes there live: the place is mapped, without
  // placing the keyframe first. 0: off.
  double culling_loop_ratio = 0.15;
  // Before culling, front map points are searched in back keyframes (their
  // ORB keypoints, manager/front_point_search.h) within this radius times
  // 1.2^(predicted level), accepting descriptor distances up to
  // front_search_max_hamming (ORB-SLAM's fusion: 3 px, 50). 0 = off.
  double front_search_px = 3.0;
  int front_search_max_hamming = 50;
  // Revisit fusion (manager/revisit_fusion.h), with the same matcher: each
  // front keyframe's mapped corners are searched for the points of the
  // revisit_neighbours nearest keyframes of earlier front submaps of its
  // component (centres within revisit_radius x the median scene depth,
  // optical axes within revisit_max_angle_deg); a match whose own point lies
  // within revisit_max_offset x its depth of the projected one is fused, so
  // culling sees a revisited place as one.
  bool revisit_fusion = true;
  int revisit_neighbours = 4;
  double revisit_radius = 0.5;
  double revisit_max_angle_deg = 30.0;
  double revisit_max_offset = 0.3;
  // Before that search, each keyframe is placed against the earlier pass:
  // matches within revisit_wide_px (x 1.2^level) and PnP RANSAC from the
  // merged pose, kept when revisit_min_pnp_inliers agree. 0 px: off.
  double revisit_wide_px = 15.0;
  int revisit_min_pnp_inliers = 20;
  // Place merge (manager/place_merge.h): front submaps that no back submap
  // joined are matched by the ORB descriptors of their map points (nearest
  // within place_max_hamming bits and below place_ratio times the runner-up),
  // a RANSAC Sim(3) with place_ransac_iterations samples keeps the matches
  // within ransac_threshold_ratio of the scene radius, and a merge needs
  // place_min_inliers of them, an inlier ratio of place_min_inlier_ratio and
  // a refined reprojection RMSE of at most place_max_rmse_px.
  bool place_merge = true;
  int place_max_hamming = 50;
  double place_ratio = 0.8;
  int place_ransac_iterations = 2000;
  int place_min_inliers = 40;
  double place_min_inlier_ratio = 0.25;
  double place_max_rmse_px = 3.0;
  // A rejected pair is tried again once one side has grown by this share of
  // its keyframes (0: at any change).
  double place_retry_growth = 0.25;
  // Odometry merge (manager/odometry_merge.h): front submaps still apart
  // after the visual merges, consecutive in time and at most
  // odometry_max_gap_s apart, are joined through the pose source they carry.
  // Each side's Sim(3) into the odometry frame is fitted on its tracked frames
  // within odometry_window_s of the gap (at least odometry_min_frames, the
  // odometry moving at least odometry_min_path_m so the scale is observable);
  // a fit is refused when its position residual exceeds
  // odometry_max_residual times the spread of the positions or its rotation
  // residual exceeds odometry_max_rotation_deg. Submap odometry holds camera
  // poses (the front applies front.odometry_T_bc).
  bool odometry_merge = true;
  double odometry_window_s = 3.0;
  int odometry_min_frames = 10;
  double odometry_min_path_m = 0.1;
  double odometry_max_residual = 0.15;
  double odometry_max_rotation_deg = 3.0;
  double odometry_max_gap_s = 2.0;
  // Loop closure (manager/loop_closure.h): every front keyframe looks for
  // earlier front keyframes of its component, at least loop_min_gap_s older,
  // in the place index (bag of words; candidates scoring at least
  // loop_min_score_ratio x its score with its neighbour keyframe, the best
  // loop_candidates). A candidate is verified by descriptor matches
  // (loop_max_hamming, loop_ratio) between the keyframe's points and those
  // of the candidate and its loop_window neighbours each side, then a RANSAC
  // Sim(3) within loop_ransac_ratio x the candidate's median depth, then the
  // query camera placed on the inliers by PnP RANSAC within loop_pnp_px,
  // each with at least loop_min_inliers inliers. A loop needs loop_min_consistent
  // keyframes within loop_group_s of each other that agree on it; it is
  // closed through the Sim(3) pose graph (pose_graph.h), which refuses an
  // edge the rest of the graph disagrees with.
  bool loop_closure = true;
  double loop_min_gap_s = 10.0;
  int loop_candidates = 3;
  double loop_min_score_ratio = 0.75;
  int loop_max_hamming = 50;
  double loop_ratio = 0.8;
  int loop_window = 2;
  double loop_ransac_ratio = 0.03;
  int loop_min_inliers = 30;
  double loop_pnp_px = 3.0;  // then PnP RANSAC of the query camera on them
  int loop_min_consistent = 3;
  double loop_group_s = 3.0;
  // The pose graph's translation sigma, as a share of the median scene depth
  // (its rotation and scale sigmas: PoseGraphOptions).
  double loop_translation_sigma = 0.01;
  // The weight (information scale) of the graph's edge between the last
  // keyframe of a submap and the next submap's first: 1 for an edge of a
  // submap's own tracking.
  double loop_merge_edge_weight = 0.01;
  // New loops closed with a solve of the whole graph per rebuild (the rest
  // wait for the next one); loops decided before are put back with one
  // solve for all of them.
  int loop_max_solves = 8;
  // New loops tried together in one solve (a looped walk's pass brings a
  // few dozen); when the lot does not hold, the rest of the rebuild closes
  // them one by one. 1: one by one always.
  int loop_batch = 64;
  // How the graph decides whether it takes new loops (PoseGraphOptions::
  // consistency): "edges" (no edge that was consistent strained past
  // 3 sigma) or "chi2" (the innovation's chi-square within its
  // loop_chi2_confidence quantile; a lot refused is tried again without
  // its own worst loops, which then go alone).
  std::string loop_consistency = "edges";
  double loop_chi2_confidence = 0.999;
  // The chi2 test's variance factor: the walk's real spread over its
  // assumed sigmas, squared (PoseGraphOptions::variance_factor).
  double loop_variance_factor = 1.0;
  // New loops whose query or match is among the first this many keyframes
  // of its front submap are not closed (ORB-SLAM looks for loops only once
  // its map has 10 keyframes). 0: any keyframe.
  int loop_skip_first_keyframes = 0;

  // The keys of the `manager:` section (ReadOptions(root.Child("manager"), &o)).
  static const OptionSpec<ManagerOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

}  // namespace rumi
