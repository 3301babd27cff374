#include "manager/manager_options.h"

namespace rumi {

const OptionSpec<ManagerOptions>& ManagerOptions::Spec() {
  using O = ManagerOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("manager");
    s->Number<int64_t>("pairing_max_dt_ns", &O::pairing_max_dt_ns, AtLeast<int64_t>(1), AtMost<int64_t>(1000000000),
                       "back and front keyframes pair when their timestamps differ by less (ns)");
    s->Number("search_n", &O::search_n, AtLeast(0), AtMost(100000),
              "F^search: first and last n keyframes of each back submap; 0: all");
    s->Number("match_radius_px", &O::match_radius_px, Above(0.0), AtMost(100.0),
              "M_com: keypoints of paired keyframes within this radius (undistorted px)");
    s->Flag("pair_tracked_frames", &O::pair_tracked_frames, "also pair back keyframes with tracked front frames");
    s->Number("pair_neighbour_keyframes", &O::pair_neighbour_keyframes, AtLeast(1), AtMost(1000),
              "front keyframes before/after a tracked frame whose points are projected");
    s->Number("pair_ratio", &O::pair_ratio, Above(0.0), AtMost(1.0), "nearest / runner-up projection distance");
    s->Number("min_keyframe_pairs", &O::min_keyframe_pairs, AtLeast(1), AtMost(100000), "keyframe pairs of a merge");
    s->Number("min_common_points", &O::min_common_points, AtLeast(3), AtMost(1000000), "common points of a merge");
    s->Number("min_inlier_ratio", &O::min_inlier_ratio, AtLeast(0.0), Below(1.0),
              "a merge needs an inlier ratio strictly above this");
    s->Flag("verify_merges", &O::verify_merges, "verify a refined merge before committing it");
    s->Number("verify_min_inliers", &O::verify_min_inliers, AtLeast(0), AtMost(1000000), "verification: inliers");
    s->Number("verify_min_kept_ratio", &O::verify_min_kept_ratio, AtLeast(0.0), AtMost(1.0),
              "verification: share of the alignment's inliers that still agree after refinement");
    s->Number("verify_max_rmse_px", &O::verify_max_rmse_px, Above(0.0), AtMost(1000.0),
              "verification: refined reprojection RMSE, px");
    s->Number("verify_max_pose_angle_deg", &O::verify_max_pose_angle_deg, Above(0.0), AtMost(180.0),
              "verification: rotation between paired poses, deg");
    s->Number("verify_max_pose_offset", &O::verify_max_pose_offset, Above(0.0), AtMost(100.0),
              "verification: paired centres apart / back scene radius");
    s->Number("verify_min_agreeing_pairs", &O::verify_min_agreeing_pairs, AtLeast(0), AtMost(100000),
              "verification: paired poses that must agree");
    s->Number("verify_min_agreeing_ratio", &O::verify_min_agreeing_ratio, AtLeast(0.0), AtMost(1.0),
              "verification: share of paired poses that must agree");
    s->Number("ransac_iterations", &O::ransac_iterations, AtLeast(1), AtMost(1000000), "RANSAC Sim(3) samples");
    s->Number("ransac_threshold_ratio", &O::ransac_threshold_ratio, Above(0.0), AtMost(10.0),
              "inlier distance / median scene radius");
    s->Number<uint32_t>("ransac_seed", &O::ransac_seed, Unbounded<uint32_t>(), Unbounded<uint32_t>(), "RANSAC seed");
    s->Choice("robust_loss", &O::robust_loss, {"huber", "cauchy"}, "robust loss of refinement and welding BA");
    s->Number("robust_loss_scale_px", &O::robust_loss_scale_px, Above(0.0), AtMost(1000.0), "robust loss scale");
    s->Number("outlier_threshold_px", &O::outlier_threshold_px, Above(0.0), AtMost(1000.0),
              "residuals above this are dropped after a first solve");
    s->Number("refine_max_iterations", &O::refine_max_iterations, AtLeast(1), AtMost(10000), "Sim(3) refinement");
    s->Number("refine_max_obs_per_point", &O::refine_max_obs_per_point, AtLeast(1), AtMost(100000),
              "Formula 8 observations per point and side");
    s->Number("welding_min_covisible", &O::welding_min_covisible, AtLeast(1), AtMost(100000),
              "welding window: shared map points with a matched keyframe");
    s->Number("welding_max_keyframes", &O::welding_max_keyframes, AtLeast(1), AtMost(100000), "welding window size");
    s->Number("ba_max_iterations", &O::ba_max_iterations, AtLeast(1), AtMost(10000), "welding BA iterations");
    s->Flag("welding_ba", &O::welding_ba, "run the welding-window BA after a merge");
    s->Number("welding_max_shift", &O::welding_max_shift, Above(0.0), AtMost(100.0),
              "welding BA not applied when it moves a keyframe further (x front scene radius)");
    s->Number("culling_redundant_ratio", &O::culling_redundant_ratio, Above(0.0), AtMost(1.0),
              "post-culling: share of a keyframe's points seen by enough others");
    s->Number("culling_min_observers", &O::culling_min_observers, AtLeast(1), AtMost(1000),
              "post-culling: other keyframes that must see a point");
    s->Number("culling_octave_tolerance", &O::culling_octave_tolerance, AtLeast(0), AtMost(31),
              "post-culling: coarser levels that still count");
    s->Number("culling_revisit_ratio", &O::culling_revisit_ratio, AtLeast(0.0), AtMost(1.0),
              "post-culling: a front keyframe this share of whose points other submaps see re-maps a known place "
              "and goes (0: off)");
    s->Number("culling_loop_ratio", &O::culling_loop_ratio, AtLeast(0.0), AtMost(1.0),
              "post-culling: a front keyframe this share of whose points a verified loop detection matched in "
              "an earlier front submap goes (0: off)");
    s->Number("front_search_px", &O::front_search_px, AtLeast(0.0), AtMost(50.0),
              "front points searched in back keyframes within this radius; 0: off");
    s->Number("front_search_max_hamming", &O::front_search_max_hamming, AtLeast(0), AtMost(256),
              "front point search: descriptor distance");
    s->Flag("revisit_fusion", &O::revisit_fusion,
            "fuse the points a front submap maps again where an earlier one of its component mapped them");
    s->Number("revisit_neighbours", &O::revisit_neighbours, AtLeast(1), AtMost(1000),
              "revisit fusion: earlier keyframes searched per keyframe");
    s->Number("revisit_radius", &O::revisit_radius, Above(0.0), AtMost(100.0),
              "revisit fusion: keyframe centres within this x the median scene depth");
    s->Number("revisit_max_angle_deg", &O::revisit_max_angle_deg, Above(0.0), AtMost(180.0),
              "revisit fusion: largest angle between the two optical axes");
    s->Number("revisit_max_offset", &O::revisit_max_offset, Above(0.0), AtMost(10.0),
              "revisit fusion: largest distance between the two points, x their depth");
    s->Number("revisit_wide_px", &O::revisit_wide_px, AtLeast(0.0), AtMost(200.0),
              "revisit fusion: search radius that places a keyframe against the earlier pass first (0: off)");
    s->Number("revisit_min_pnp_inliers", &O::revisit_min_pnp_inliers, AtLeast(6), AtMost(100000),
              "revisit fusion: PnP inliers that place it");
    s->Flag("place_merge", &O::place_merge, "join front submaps of one place by descriptors");
    s->Number("place_max_hamming", &O::place_max_hamming, AtLeast(0), AtMost(256), "place merge: descriptor distance");
    s->Number("place_ratio", &O::place_ratio, Above(0.0), AtMost(1.0), "place merge: nearest / runner-up");
    s->Number("place_ransac_iterations", &O::place_ransac_iterations, AtLeast(1), AtMost(1000000),
              "place merge: RANSAC samples");
    s->Number("place_min_inliers", &O::place_min_inliers, AtLeast(3), AtMost(1000000), "place merge: inliers");
    s->Number("place_min_inlier_ratio", &O::place_min_inlier_ratio, AtLeast(0.0), Below(1.0),
              "place merge: inlier ratio");
    s->Number("place_max_rmse_px", &O::place_max_rmse_px, Above(0.0), AtMost(1000.0),
              "place merge: refined reprojection RMSE");
    s->Number("place_retry_growth", &O::place_retry_growth, AtLeast(0.0), AtMost(100.0),
              "place merge: a rejected pair is tried again once a side has grown by this share of its keyframes "
              "(0: at any change)");
    s->Flag("odometry_merge", &O::odometry_merge, "join consecutive front submaps through the pose source");
    s->Number("odometry_window_s", &O::odometry_window_s, Above(0.0), AtMost(3600.0),
              "odometry merge: fit window around the gap, s");
    s->Number("odometry_min_frames", &O::odometry_min_frames, AtLeast(3), AtMost(1000000),
              "odometry merge: tracked frames per side");
    s->Number("odometry_min_path_m", &O::odometry_min_path_m, Above(0.0), AtMost(1e6),
              "odometry merge: path length that makes the scale observable");
    s->Number("odometry_max_residual", &O::odometry_max_residual, Above(0.0), AtMost(1.0),
              "odometry merge: position residual / spread");
    s->Number("odometry_max_rotation_deg", &O::odometry_max_rotation_deg, Above(0.0), AtMost(180.0),
              "odometry merge: rotation residual");
    s->Number("odometry_max_gap_s", &O::odometry_max_gap_s, AtLeast(0.0), AtMost(1e6),
              "odometry merge: longest gap joined, s");
    s->Flag("loop_closure", &O::loop_closure, "find loops by place recognition and close them in the pose graph");
    s->Number("loop_min_gap_s", &O::loop_min_gap_s, Above(0.0), AtMost(1e6),
              "loop closure: a candidate is at least this much older, s");
    s->Number("loop_candidates", &O::loop_candidates, AtLeast(1), AtMost(100), "loop closure: candidates verified");
    s->Number("loop_min_score_ratio", &O::loop_min_score_ratio, AtLeast(0.0), AtMost(10.0),
              "loop closure: candidate score / the score with the neighbour keyframe");
    s->Number("loop_max_hamming", &O::loop_max_hamming, AtLeast(0), AtMost(256), "loop closure: descriptor distance");
    s->Number("loop_ratio", &O::loop_ratio, Above(0.0), AtMost(1.0), "loop closure: nearest / runner-up");
    s->Number("loop_window", &O::loop_window, AtLeast(0), AtMost(100),
              "loop closure: the candidate's neighbour keyframes each side matched with it");
    s->Number("loop_ransac_ratio", &O::loop_ransac_ratio, Above(0.0), AtMost(1.0),
              "loop closure: RANSAC inlier distance / the candidate's median depth");
    s->Number("loop_min_inliers", &O::loop_min_inliers, AtLeast(3), AtMost(1000000), "loop closure: inliers");
    s->Number("loop_pnp_px", &O::loop_pnp_px, Above(0.0), AtMost(100.0), "loop closure: PnP reprojection threshold, px");
    s->Number("loop_min_consistent", &O::loop_min_consistent, AtLeast(1), AtMost(100),
              "loop closure: keyframes that agree on a loop");
    s->Number("loop_group_s", &O::loop_group_s, Above(0.0), AtMost(1e6),
              "loop closure: the agreeing keyframes lie within this of each other, s");
    s->Number("loop_translation_sigma", &O::loop_translation_sigma, Above(0.0), AtMost(10.0),
              "loop closure: pose-graph translation sigma / median scene depth");
    s->Number("loop_merge_edge_weight", &O::loop_merge_edge_weight, Above(0.0), AtMost(1.0),
              "loop closure: weight of the graph's edges across submaps (1: a submap's own tracking)");
    s->Number("loop_max_solves", &O::loop_max_solves, AtLeast(1), AtMost(1000),
              "loop closure: pose-graph solves per rebuild for new loops (the rest wait)");
    s->Number("loop_batch", &O::loop_batch, AtLeast(1), AtMost(100000),
              "loop closure: new loops tried together in one solve (1: one by one)");
    s->Choice("loop_consistency", &O::loop_consistency, {"edges", "chi2"},
              "loop closure: the graph takes new loops when no edge strains past 3 sigma (edges) or when the "
              "chi-square they add is within its quantile (chi2)");
    s->Number("loop_chi2_confidence", &O::loop_chi2_confidence, Above(0.5), Below(1.0),
              "loop closure: the chi-square quantile of the chi2 test");
    s->Number("loop_variance_factor", &O::loop_variance_factor, Above(0.0), AtMost(1e6),
              "loop closure: the chi2 test's variance factor (real spread over assumed sigmas, squared)");
    s->Number("loop_skip_first_keyframes", &O::loop_skip_first_keyframes, AtLeast(0), AtMost(1000000),
              "loop closure: new loops at one of a front submap's first N keyframes are not closed (0: any)");
    return s;
  }();
  return *spec;
}

bool ManagerOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

}  // namespace rumi
