#pragma once
// Options of the realtime front end (config section `front:`).
#include <string>

#include "common/option_spec.h"
#include "common/geometry.h"
#include "common/orb_extractor.h"
#include "front/hierarchical.h"

namespace rumi {

struct FrontOptions {
  OrbExtractorOptions orb;
  // Initialization.
  double init_search_radius_frac = 0.12;  // window radius / image width
  int init_min_matches = 100;
  int init_min_triangulated = 50;
  // A re-initialisation (any submap after the first) happens right where
  // tracking failed (fast turn, blur, low texture): it needs more points.
  // Re-inits over 1 frame with 105 and 180 points lost their scale in the
  // turn that followed (generated dark seed 1, weak seed 2); the ones a few
  // frames later with 356-394 points did not (docs/front.md).
  int reinit_min_triangulated = 200;
  // Parallax (51st largest, ORB-SLAM) the two views must show. A first map
  // at 1.9 deg over 3 frames halved its scale within 2 s on `weak` seed 2
  // (first submap ATE 8.5 cm, 0.75 cm at 2 deg); a first init can wait, the
  // sequence has only started. A re-init happens inside the hard stretch,
  // where waiting costs tracked frames (KITTI's restart, front_loss_test),
  // and it needs reinit_min_triangulated points already: 1 deg there.
  double init_min_parallax_deg = 2.0;
  double reinit_min_parallax_deg = 1.0;
  int init_max_frames = 30;               // ref frame replaced after this many tries
  // Once the first map exists, the frames between its two keyframes get
  // their poses too (PnP against it), as the reference frame does: the
  // wait for parallax costs no trajectory. Not for re-initialisations.
  bool init_backfill = true;
  // Tracking.
  double motion_search_radius = 15.0;     // px at level 0 (scaled by octave)
  double local_search_radius = 1.0;       // x 2.5-4 px x scale (x3 after (re)initialisation)
  int min_tracked_inliers = 30;
  double short_term_s = 3.0;              // Th_t: short-term association window
  double mid_term_dist = 3.0;             // Th_p, in units of the initial median depth
  int max_local_keyframes = 30;
  // Keyframes.
  double fps = 0;                         // frame rate for the keyframe cadence; 0: from timestamps
  double kf_tracked_ratio = 0.9;
  double kf_weak_ratio = 0.9;             // also a keyframe when inliers < this x their peak since the last keyframe
  // Local mapping.
  bool local_mapping_thread = true;       // false: run mapping inline (tests)
  int triangulation_neighbours = 15;
  int local_ba_iterations = 5;
  int local_ba_max_keyframes = 20;        // free keyframes (new + best covisible)
  double local_ba_max_time_s = 0.15;
  int local_ba_max_fixed = 20;
  double kf_cull_redundancy = 0.9;
  int max_ba_skips = 2;                   // behind: at most this many keyframes in a row without local BA
  // Loss handling.
  double reloc_time_s = 0.5;              // give up relocalizing after this long
  int reloc_min_inliers = 40;
  // Hierarchical fine/coarse mode (paper 000).
  bool hierarchical = false;
  HierarchicalOptions hier;
  // External pose source: the camera's pose in the source's body frame
  // (YAML `odometry_T_bc: [tx, ty, tz, qx, qy, qz, qw]`), so body poses
  // become camera poses (coarse poses, submap links, Submap::odometry).
  Se3 odometry_T_bc;
  // IMU (a robot link's, or a dataset's imu file): the gyro predicts each
  // frame's rotation from the last (the motion model keeps the translation),
  // its bias estimated online against the tracked rotation; a loss or a gap
  // in the frames is bridged from the last tracked frame by the gyro's
  // rotation (the camera centre extrapolated). imu_T_bc is the
  // camera's pose in the IMU frame (only its rotation is used).
  bool gyro_prior = true;
  double gyro_bridge_s = 1.5;             // lost with a gyro: try its prediction from the last tracked frame this long
  Se3 imu_T_bc;

  // Section `front:` (sub-sections `orb:` and `hierarchical_mode:`).
  static const OptionSpec<FrontOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

}  // namespace rumi
