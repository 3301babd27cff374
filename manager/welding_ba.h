#pragma once
// Welding-window local BA (paper step 3): after the Sim(3)s are updated, the
// front keyframes that were paired with the back submap and their covisible
// neighbours are optimised together with the points they see, in the global
// frame; the fused points are the back submap's (fixed), back keyframes and
// keyframes outside the window are fixed. Results are written back into the
// front submap's own frame.
#include <unordered_set>
#include <vector>

#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

struct WeldingReport {
  int window_keyframes = 0;
  int fixed_keyframes = 0;
  int variable_points = 0;
  int fixed_points = 0;  // fused (back) points
  int residuals = 0;
  double initial_rmse_px = 0, final_rmse_px = 0;
  int iterations = 0;
  // How far the window keyframes' centres moved, over the front submap's
  // scene radius (median distance of its points to their centroid).
  double median_shift_ratio = 0, max_shift_ratio = 0;
  // max_shift_ratio > welding_max_shift: the solve was not applied.
  bool reverted = false;
  // The solve ran and its poses and points were written back.
  bool applied = false;
};

// Keyframe ids of `front`: the seeds plus those sharing at least
// min_covisible map points with a seed, the most covisible first, at most
// max_keyframes in all (seeds always in).
std::unordered_set<int64_t> WeldingWindow(const Submap& front, const std::vector<int64_t>& seed_keyframe_ids,
                                          int min_covisible, int max_keyframes = 1 << 30);

// fused_front_to_back: front point id -> back point id (points of `back`).
WeldingReport WeldWindow(GlobalMap* map, int front, int back, const std::unordered_set<int64_t>& window,
                         const std::vector<std::pair<int64_t, int64_t>>& fused_front_to_back,
                         const ManagerOptions& options);

}  // namespace rumi
