#include "manager/manager_options.h"

namespace rumi {
namespace {
bool Fail(std::string* why, const std::string& msg) {
  if (why) *why = msg;
  return false;
}
}  // namespace

bool ManagerOptions::Check(std::string* why) const {
  if (pairing_max_dt_ns <= 0) return Fail(why, "pairing_max_dt_ns must be > 0");
  if (search_n < 0) return Fail(why, "search_n must be >= 0");
  if (!(match_radius_px > 0)) return Fail(why, "match_radius_px must be > 0");
  if (pair_neighbour_keyframes < 1) return Fail(why, "pair_neighbour_keyframes must be >= 1");
  if (!(pair_ratio > 0 && pair_ratio <= 1)) return Fail(why, "pair_ratio must be in (0, 1]");
  if (min_keyframe_pairs < 1) return Fail(why, "min_keyframe_pairs must be >= 1");
  if (min_common_points < 3) return Fail(why, "min_common_points must be >= 3");
  if (!(min_inlier_ratio >= 0 && min_inlier_ratio < 1)) return Fail(why, "min_inlier_ratio must be in [0, 1)");
  if (ransac_iterations < 1) return Fail(why, "ransac_iterations must be >= 1");
  if (!(ransac_threshold_ratio > 0)) return Fail(why, "ransac_threshold_ratio must be > 0");
  if (robust_loss != "huber" && robust_loss != "cauchy")
    return Fail(why, "robust_loss must be 'huber' or 'cauchy' (got '" + robust_loss + "')");
  if (!(robust_loss_scale_px > 0)) return Fail(why, "robust_loss_scale_px must be > 0");
  if (!(outlier_threshold_px > 0)) return Fail(why, "outlier_threshold_px must be > 0");
  if (refine_max_iterations < 1) return Fail(why, "refine_max_iterations must be >= 1");
  if (refine_max_obs_per_point < 1) return Fail(why, "refine_max_obs_per_point must be >= 1");
  if (welding_max_keyframes < 1) return Fail(why, "welding_max_keyframes must be >= 1");
  if (welding_min_covisible < 1) return Fail(why, "welding_min_covisible must be >= 1");
  if (ba_max_iterations < 1) return Fail(why, "ba_max_iterations must be >= 1");
  if (!(culling_redundant_ratio > 0 && culling_redundant_ratio <= 1))
    return Fail(why, "culling_redundant_ratio must be in (0, 1]");
  if (culling_min_observers < 1) return Fail(why, "culling_min_observers must be >= 1");
  if (culling_octave_tolerance < 0 || culling_octave_tolerance > 31)
    return Fail(why, "culling_octave_tolerance must be in [0, 31]");
  if (!(front_search_px >= 0 && front_search_px <= 50)) return Fail(why, "front_search_px must be in [0, 50]");
  if (front_search_max_hamming < 0 || front_search_max_hamming > 256)
    return Fail(why, "front_search_max_hamming must be in [0, 256]");
  if (place_max_hamming < 0 || place_max_hamming > 256) return Fail(why, "place_max_hamming must be in [0, 256]");
  if (!(place_ratio > 0 && place_ratio <= 1)) return Fail(why, "place_ratio must be in (0, 1]");
  if (place_ransac_iterations < 1) return Fail(why, "place_ransac_iterations must be >= 1");
  if (place_min_inliers < 3) return Fail(why, "place_min_inliers must be >= 3");
  if (!(place_min_inlier_ratio >= 0 && place_min_inlier_ratio < 1))
    return Fail(why, "place_min_inlier_ratio must be in [0, 1)");
  if (!(place_max_rmse_px > 0)) return Fail(why, "place_max_rmse_px must be > 0");
  if (!(odometry_window_s > 0)) return Fail(why, "odometry_window_s must be > 0");
  if (odometry_min_frames < 3) return Fail(why, "odometry_min_frames must be >= 3");
  if (!(odometry_min_path_m > 0)) return Fail(why, "odometry_min_path_m must be > 0");
  if (!(odometry_max_residual > 0 && odometry_max_residual <= 1))
    return Fail(why, "odometry_max_residual must be in (0, 1]");
  if (!(odometry_max_rotation_deg > 0 && odometry_max_rotation_deg <= 180))
    return Fail(why, "odometry_max_rotation_deg must be in (0, 180]");
  if (!(odometry_max_gap_s >= 0)) return Fail(why, "odometry_max_gap_s must be >= 0");
  return true;
}

void ReadOptions(ConfigSection& s, ManagerOptions* o) {
  s.ReadInRange<int64_t>("pairing_max_dt_ns", &o->pairing_max_dt_ns, 1, 1000000000);
  s.ReadInRange("search_n", &o->search_n, 0, 100000);
  s.ReadInRange("match_radius_px", &o->match_radius_px, 1e-3, 100.0);
  s.Read("pair_tracked_frames", &o->pair_tracked_frames);
  s.ReadInRange("pair_neighbour_keyframes", &o->pair_neighbour_keyframes, 1, 1000);
  s.ReadInRange("pair_ratio", &o->pair_ratio, 1e-3, 1.0);
  s.ReadInRange("min_keyframe_pairs", &o->min_keyframe_pairs, 1, 100000);
  s.ReadInRange("min_common_points", &o->min_common_points, 3, 1000000);
  s.ReadInRange("min_inlier_ratio", &o->min_inlier_ratio, 0.0, 0.99);
  s.ReadInRange("ransac_iterations", &o->ransac_iterations, 1, 1000000);
  s.ReadInRange("ransac_threshold_ratio", &o->ransac_threshold_ratio, 1e-6, 10.0);
  s.ReadInRange<uint32_t>("ransac_seed", &o->ransac_seed, 0u, 0xffffffffu);
  s.Read("robust_loss", &o->robust_loss);
  s.ReadInRange("robust_loss_scale_px", &o->robust_loss_scale_px, 1e-3, 1000.0);
  s.ReadInRange("outlier_threshold_px", &o->outlier_threshold_px, 1e-3, 1000.0);
  s.ReadInRange("refine_max_iterations", &o->refine_max_iterations, 1, 10000);
  s.ReadInRange("refine_max_obs_per_point", &o->refine_max_obs_per_point, 1, 100000);
  s.ReadInRange("welding_min_covisible", &o->welding_min_covisible, 1, 100000);
  s.ReadInRange("welding_max_keyframes", &o->welding_max_keyframes, 1, 100000);
  s.ReadInRange("ba_max_iterations", &o->ba_max_iterations, 1, 10000);
  s.Read("welding_ba", &o->welding_ba);
  s.ReadInRange("culling_redundant_ratio", &o->culling_redundant_ratio, 1e-3, 1.0);
  s.ReadInRange("culling_min_observers", &o->culling_min_observers, 1, 1000);
  s.ReadInRange("culling_octave_tolerance", &o->culling_octave_tolerance, 0, 31);
  s.ReadInRange("front_search_px", &o->front_search_px, 0.0, 50.0);
  s.ReadInRange("front_search_max_hamming", &o->front_search_max_hamming, 0, 256);
  s.Read("place_merge", &o->place_merge);
  s.ReadInRange("place_max_hamming", &o->place_max_hamming, 0, 256);
  s.ReadInRange("place_ratio", &o->place_ratio, 1e-3, 1.0);
  s.ReadInRange("place_ransac_iterations", &o->place_ransac_iterations, 1, 1000000);
  s.ReadInRange("place_min_inliers", &o->place_min_inliers, 3, 1000000);
  s.ReadInRange("place_min_inlier_ratio", &o->place_min_inlier_ratio, 0.0, 0.99);
  s.ReadInRange("place_max_rmse_px", &o->place_max_rmse_px, 1e-3, 1000.0);
  s.Read("odometry_merge", &o->odometry_merge);
  s.ReadInRange("odometry_window_s", &o->odometry_window_s, 0.1, 3600.0);
  s.ReadInRange("odometry_min_frames", &o->odometry_min_frames, 3, 1000000);
  s.ReadInRange("odometry_min_path_m", &o->odometry_min_path_m, 1e-3, 1e6);
  s.ReadInRange("odometry_max_residual", &o->odometry_max_residual, 1e-3, 1.0);
  s.ReadInRange("odometry_max_rotation_deg", &o->odometry_max_rotation_deg, 0.01, 180.0);
  s.ReadInRange("odometry_max_gap_s", &o->odometry_max_gap_s, 0.0, 1e6);
  std::string why;
  if (!o->Check(&why)) throw ConfigError(s.file() + ": section 'manager': " + why);
}

}  // namespace rumi
