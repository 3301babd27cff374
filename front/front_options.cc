#include "front/front_options.h"

#include <cmath>
#include <vector>

namespace rumi {

bool FrontOptions::Check(std::string* why) const {
  auto fail = [&](const char* m) { if (why) *why = m; return false; };
  if (!orb.Check(why)) return false;
  if (!hier.Check(why)) return false;
  if (!(init_search_radius_frac > 0 && init_search_radius_frac <= 1)) return fail("init_search_radius_frac must be in (0, 1]");
  if (init_min_matches < 8) return fail("init_min_matches must be >= 8");
  if (init_min_triangulated < 8) return fail("init_min_triangulated must be >= 8");
  if (reinit_min_triangulated < init_min_triangulated)
    return fail("reinit_min_triangulated must be >= init_min_triangulated");
  if (!(init_min_parallax_deg > 0) || !(reinit_min_parallax_deg > 0))
    return fail("init_min_parallax_deg and reinit_min_parallax_deg must be > 0");
  if (init_max_frames < 1) return fail("init_max_frames must be >= 1");
  if (!(motion_search_radius > 0) || !(local_search_radius > 0)) return fail("search radii must be > 0");
  if (min_tracked_inliers < 10) return fail("min_tracked_inliers must be >= 10");
  if (!(short_term_s >= 0) || !(mid_term_dist >= 0)) return fail("short_term_s and mid_term_dist must be >= 0");
  if (max_local_keyframes < 1) return fail("max_local_keyframes must be >= 1");
  if (!(fps >= 0)) return fail("fps must be >= 0 (0: from timestamps)");
  if (!(kf_tracked_ratio > 0 && kf_tracked_ratio <= 1)) return fail("kf_tracked_ratio must be in (0, 1]");
  if (triangulation_neighbours < 1) return fail("triangulation_neighbours must be >= 1");
  if (local_ba_iterations < 0 || !(local_ba_max_time_s > 0)) return fail("local BA limits must be positive");
  if (local_ba_max_keyframes < 1) return fail("local_ba_max_keyframes must be >= 1");
  if (local_ba_max_fixed < 0) return fail("local_ba_max_fixed must be >= 0");
  if (max_ba_skips < 0) return fail("max_ba_skips must be >= 0");
  if (!(kf_weak_ratio >= 0 && kf_weak_ratio <= 1)) return fail("kf_weak_ratio must be in [0, 1]");
  if (!(kf_cull_redundancy > 0 && kf_cull_redundancy <= 1)) return fail("kf_cull_redundancy must be in (0, 1]");
  if (!(reloc_time_s >= 0)) return fail("reloc_time_s must be >= 0");
  if (reloc_min_inliers < 10) return fail("reloc_min_inliers must be >= 10");
  return true;
}

void ReadOptions(ConfigSection& s, OrbExtractorOptions* o) {
  s.ReadInRange("num_features", &o->num_features, 0, 100000);
  s.ReadInRange("num_levels", &o->num_levels, 1, 16);
  s.ReadInRange("scale_factor", &o->scale_factor, 1.01, 1.99);
  s.ReadInRange("fast_threshold", &o->fast_threshold, 1, 255);
  s.ReadInRange("fast_min_threshold", &o->fast_min_threshold, 1, 255);
  s.ReadInRange("cell_size", &o->cell_size, 8, 1024);
  CheckOptions(*o, s, "orb");
}

void ReadOptions(ConfigSection& s, FrontOptions* o) {
  ConfigSection orb = s.Child("orb");
  ReadOptions(orb, &o->orb);
  s.ReadInRange("init_search_radius_frac", &o->init_search_radius_frac, 1e-3, 1.0);
  s.ReadInRange("init_min_matches", &o->init_min_matches, 8, 100000);
  s.ReadInRange("init_min_triangulated", &o->init_min_triangulated, 8, 100000);
  s.ReadInRange("reinit_min_triangulated", &o->reinit_min_triangulated, 8, 100000);
  s.ReadInRange("init_min_parallax_deg", &o->init_min_parallax_deg, 0.01, 90.0);
  s.ReadInRange("reinit_min_parallax_deg", &o->reinit_min_parallax_deg, 0.01, 90.0);
  s.ReadInRange("init_max_frames", &o->init_max_frames, 1, 100000);
  s.ReadInRange("motion_search_radius", &o->motion_search_radius, 0.5, 500.0);
  s.ReadInRange("local_search_radius", &o->local_search_radius, 0.1, 100.0);
  s.ReadInRange("min_tracked_inliers", &o->min_tracked_inliers, 10, 100000);
  s.ReadInRange("short_term_s", &o->short_term_s, 0.0, 1e6);
  s.ReadInRange("mid_term_dist", &o->mid_term_dist, 0.0, 1e6);
  s.ReadInRange("max_local_keyframes", &o->max_local_keyframes, 1, 10000);
  s.ReadInRange("fps", &o->fps, 0.0, 1000.0);
  s.ReadInRange("kf_tracked_ratio", &o->kf_tracked_ratio, 0.01, 1.0);
  s.ReadInRange("kf_weak_ratio", &o->kf_weak_ratio, 0.0, 1.0);
  s.Read("local_mapping_thread", &o->local_mapping_thread);
  s.ReadInRange("triangulation_neighbours", &o->triangulation_neighbours, 1, 100);
  s.ReadInRange("local_ba_iterations", &o->local_ba_iterations, 0, 1000);
  s.ReadInRange("local_ba_max_time_s", &o->local_ba_max_time_s, 1e-3, 100.0);
  s.ReadInRange("local_ba_max_keyframes", &o->local_ba_max_keyframes, 1, 1000);
  s.ReadInRange("local_ba_max_fixed", &o->local_ba_max_fixed, 0, 1000);
  s.ReadInRange("kf_cull_redundancy", &o->kf_cull_redundancy, 0.01, 1.0);
  s.ReadInRange("max_ba_skips", &o->max_ba_skips, 0, 1000);
  s.ReadInRange("reloc_time_s", &o->reloc_time_s, 0.0, 1e6);
  s.ReadInRange("reloc_min_inliers", &o->reloc_min_inliers, 10, 100000);
  s.Read("hierarchical", &o->hierarchical);
  ConfigSection h = s.Child("hierarchical_mode");
  ReadOptions(h, &o->hier);
  std::vector<double> T;
  if (s.Read("odometry_T_bc", &T)) {
    if (T.size() != 7) s.Fail("odometry_T_bc", "expected [tx, ty, tz, qx, qy, qz, qw], got " + std::to_string(T.size()) + " values");
    const Eigen::Quaterniond q(T[6], T[3], T[4], T[5]);
    if (!(std::abs(q.norm() - 1.0) < 1e-3)) s.Fail("odometry_T_bc", "rotation is not a unit quaternion (x y z w order)");
    o->odometry_T_bc = Se3(q, Eigen::Vector3d(T[0], T[1], T[2]));
  }
  CheckOptions(*o, s, "front");
}

}  // namespace rumi
