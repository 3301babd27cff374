#pragma once
// Sim(3) refinement (paper step 2, Formula 8): the reprojection error of M_com
// with the back submap fixed. Front points mapped by S_bf are projected into
// the back keyframes that observe their partner, and back points mapped by
// S_bf^-1 into the front keyframes; only the Sim(3) is optimised, under a
// robust loss, in two rounds (the second without gross outliers).
// Parametrisation: (log scale, unit quaternion on EigenQuaternionManifold,
// translation).
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/submap.h"
#include "manager/common_points.h"
#include "manager/manager_options.h"

namespace rumi {

struct Sim3RefineResult {
  bool ok = false;
  std::string message;
  Sim3 S_bf;                   // front frame -> back frame
  int num_residuals = 0;       // 2D observations used in round 1
  int num_inlier_residuals = 0;  // kept for round 2
  double initial_rmse_px = 0;  // on the kept observations, at the initial Sim(3)
  double final_rmse_px = 0;
  int iterations = 0;
};

// use: optional mask over matches (nullptr = all).
Sim3RefineResult RefineSim3(const Submap& front, const Submap& back, const std::vector<PointMatch>& matches,
                            const std::vector<char>* use, const Sim3& initial, const ManagerOptions& options);

}  // namespace rumi
