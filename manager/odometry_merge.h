#pragma once
// Odometry merge: joins consecutive front submaps that no visual merge
// joined, through the robot's pose source (the hierarchical mode's
// pose-based merging, paper 000). Vision cannot bridge a stretch where
// neither the front nor COLMAP registers a frame and the two sides share no
// view (a blurred pan that ends on a new scene); odometry keeps running
// through it. Each submap's Sim(3) into the odometry frame is fitted on its
// tracked frames next to the gap (rotation from the orientations, scale and
// translation from the positions), so odometry drift enters only over the
// gap and the two windows. Runs after the back and place merges, which are
// tied to image evidence and win where they apply.
#include <optional>
#include <string>
#include <vector>

#include "common/submap.h"
#include "manager/global_map.h"
#include "manager/manager_options.h"
#include "manager/merge.h"

namespace rumi {

struct OdometryFit {
  Sim3 S_os;                  // submap frame -> odometry frame
  int frames = 0;             // tracked frames with an odometry pose used
  double path_m = 0;          // odometry path length over them
  double position_rmse_m = 0; // |o_i - S c_i| RMS, odometry metres
  double spread_m = 0;        // RMS distance of the odometry positions to their mean
  double rotation_rmse_deg = 0;
};

// Fits S_os on the tracked frames of `s` that carry odometry and lie in
// [t_begin, t_end]. nullopt (and why) when too few frames, too little motion
// for the scale, or residuals above the options' limits.
std::optional<OdometryFit> FitOdometry(const Submap& s, Timestamp t_begin, Timestamp t_end,
                                       const ManagerOptions& options, std::string* why = nullptr);

// Tries to join front submap `a` (earlier) and `b` (later) by odometry.
// Report: front = a, back = b, S_bf = a's frame -> b's frame,
// init_method "odometry", common_points = frames fitted on both sides.
MergeReport OdometryMergePair(GlobalMap* map, int a, int b, const ManagerOptions& options);

// Every pair of front submaps consecutive in time (by first tracked frame)
// that lie in different components. No-op when options.odometry_merge is off
// or no submap carries odometry.
std::vector<MergeReport> OdometryMergeAll(GlobalMap* map, const ManagerOptions& options);

}  // namespace rumi
