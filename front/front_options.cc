#include "front/front_options.h"

#include <cmath>
#include <vector>

namespace rumi {

const OptionSpec<HierarchicalOptions>& HierarchicalOptions::Spec() {
  using O = HierarchicalOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("hierarchical_mode");
    s->Number("eta", &O::eta, AtLeast(0.0), AtMost(1e4), "min feature density: keypoints per 100x100 px");
    s->Number("lambda", &O::lambda, AtLeast(1), AtMost(100000), "window length (frames) of the stall counter");
    s->Number("stall_threshold", &O::stall_threshold, AtLeast(1), AtMost(100000),
              "stall count (submap unchanged) that turns coarse");
    s->Number("sparse_frames", &O::sparse_frames, AtLeast(1), AtMost(100000),
              "consecutive sparse frames that turn coarse");
    s->Number("resume_frames", &O::resume_frames, AtLeast(1), AtMost(100000),
              "consecutive dense frames that go back to fine");
    s->Rule("stall_threshold must be <= lambda", [](const O& o) { return o.stall_threshold <= o.lambda; });
    return s;
  }();
  return *spec;
}

bool HierarchicalOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

namespace {
// odometry_T_bc, imu_T_bc: [tx, ty, tz, qx, qy, qz, qw].
void ReadPose(ConfigSection& s, const std::string& key, Se3* T) {
  std::vector<double> v;
  if (!s.Read(key, &v)) return;
  if (v.size() != 7)
    s.Fail(key, "expected [tx, ty, tz, qx, qy, qz, qw], got " + std::to_string(v.size()) + " values");
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (!(std::abs(q.norm() - 1.0) < 1e-3)) s.Fail(key, "rotation is not a unit quaternion (x y z w order)");
  *T = Se3(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2]));
}

void AddPoseOption(OptionSpec<FrontOptions>* s, const std::string& key, const std::string& help,
                   Se3 FrontOptions::*field) {
  s->Custom({key, "", "[tx, ty, tz, qx, qy, qz, qw]", help},
            [key, field](ConfigSection& sec, FrontOptions* o) { ReadPose(sec, key, &(o->*field)); }, nullptr,
            [field](const FrontOptions& o) {
              const auto& t = (o.*field).translation();
              const auto& q = (o.*field).rotation();
              return "[" + std::to_string(t.x()) + ", " + std::to_string(t.y()) + ", " + std::to_string(t.z()) +
                     ", " + std::to_string(q.x()) + ", " + std::to_string(q.y()) + ", " + std::to_string(q.z()) +
                     ", " + std::to_string(q.w()) + "]";
            });
}
}  // namespace

const OptionSpec<FrontOptions>& FrontOptions::Spec() {
  using O = FrontOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("front");
    s->Section("orb", &O::orb, OrbExtractorOptions::Spec());
    s->Number("init_search_radius_frac", &O::init_search_radius_frac, Above(0.0), AtMost(1.0),
              "initialisation match window radius / image width");
    s->Number("init_min_matches", &O::init_min_matches, AtLeast(8), AtMost(100000), "matches to try an initialisation");
    s->Number("init_min_triangulated", &O::init_min_triangulated, AtLeast(8), AtMost(100000),
              "points a first map needs");
    s->Number("reinit_min_triangulated", &O::reinit_min_triangulated, AtLeast(8), AtMost(100000),
              "points a re-initialisation needs");
    s->Number("init_min_parallax_deg", &O::init_min_parallax_deg, Above(0.0), AtMost(90.0),
              "parallax of a first map");
    s->Number("reinit_min_parallax_deg", &O::reinit_min_parallax_deg, Above(0.0), AtMost(90.0),
              "parallax of a re-initialisation");
    s->Number("init_max_frames", &O::init_max_frames, AtLeast(1), AtMost(100000),
              "initialisation reference frame replaced after this many tries");
    s->Flag("init_backfill", &O::init_backfill,
            "pose the frames between the first map's two keyframes once it exists (not re-initialisations)");
    s->Number("motion_search_radius", &O::motion_search_radius, AtLeast(0.5), AtMost(500.0),
              "motion-model search radius, px at level 0");
    s->Number("local_search_radius", &O::local_search_radius, AtLeast(0.1), AtMost(100.0),
              "local-map search radius factor");
    s->Number("min_tracked_inliers", &O::min_tracked_inliers, AtLeast(10), AtMost(100000),
              "inliers below which a frame is lost");
    s->Number("short_term_s", &O::short_term_s, AtLeast(0.0), AtMost(1e6), "short-term association window Th_t, s");
    s->Number("mid_term_dist", &O::mid_term_dist, AtLeast(0.0), AtMost(1e6),
              "mid-term distance Th_p, initial median depths");
    s->Number("max_local_keyframes", &O::max_local_keyframes, AtLeast(1), AtMost(10000), "local map size");
    s->Number("fps", &O::fps, AtLeast(0.0), AtMost(1000.0), "frame rate for the keyframe cadence; 0: from timestamps");
    s->Number("kf_tracked_ratio", &O::kf_tracked_ratio, Above(0.0), AtMost(1.0), "keyframe when tracked < ratio x ref");
    s->Number("kf_weak_ratio", &O::kf_weak_ratio, AtLeast(0.0), AtMost(1.0),
              "keyframe when inliers < ratio x their peak since the last one");
    s->Flag("local_mapping_thread", &O::local_mapping_thread, "false: run mapping inline (tests; repeatable when local_ba_max_time_s never cuts)");
    s->Number("triangulation_neighbours", &O::triangulation_neighbours, AtLeast(1), AtMost(100),
              "keyframes to triangulate with");
    s->Number("local_ba_iterations", &O::local_ba_iterations, AtLeast(0), AtMost(1000), "local BA iterations");
    s->Number("local_ba_max_time_s", &O::local_ba_max_time_s, AtLeast(1e-3), AtMost(100.0), "local BA time bound");
    s->Number("local_ba_max_keyframes", &O::local_ba_max_keyframes, AtLeast(1), AtMost(1000), "free keyframes");
    s->Number("local_ba_max_fixed", &O::local_ba_max_fixed, AtLeast(0), AtMost(1000), "fixed keyframes");
    s->Number("kf_cull_redundancy", &O::kf_cull_redundancy, Above(0.0), AtMost(1.0), "keyframe culling ratio");
    s->Number("max_ba_skips", &O::max_ba_skips, AtLeast(0), AtMost(1000),
              "keyframes in a row without local BA when behind");
    s->Number("reloc_time_s", &O::reloc_time_s, AtLeast(0.0), AtMost(1e6), "give up relocalising after this long");
    s->Number("reloc_min_inliers", &O::reloc_min_inliers, AtLeast(10), AtMost(100000), "inliers of a relocalisation");
    s->Flag("hierarchical", &O::hierarchical, "fine/coarse mode of the rat-robot paper");
    s->Section("hierarchical_mode", &O::hier, HierarchicalOptions::Spec());
    AddPoseOption(s, "odometry_T_bc", "camera pose in the pose source's body frame; identity when omitted",
                  &O::odometry_T_bc);
    s->Flag("gyro_prior", &O::gyro_prior, "predict each frame's rotation from the IMU's gyro when there is one");
    s->Number("gyro_bridge_s", &O::gyro_bridge_s, AtLeast(0.0), AtMost(10.0),
              "lost with a gyro: track from the last tracked frame by its rotation this long (0: never)");
    AddPoseOption(s, "imu_T_bc", "camera pose in the IMU frame (its rotation turns the gyro); identity when omitted",
                  &O::imu_T_bc);
    s->Rule("reinit_min_triangulated must be >= init_min_triangulated",
            [](const O& o) { return o.reinit_min_triangulated >= o.init_min_triangulated; });
    return s;
  }();
  return *spec;
}

bool FrontOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

}  // namespace rumi
