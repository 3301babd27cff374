#pragma once
// The loop audit of `rumi eval run`: every loop the manager's last rebuild
// found (manager_stats.json "loops"), its measured relation of the two
// cameras (S_qm) against the ground truth's at the two keyframes' times. A
// loop is right when the rotation agrees within 5 deg and, where the
// cameras are at least a fifth of the scene depth apart, the direction from
// one to the other within 20 deg (a monocular loop measures no metric
// length); a closed loop that is not right is harmful.
#include <string>
#include <vector>

#include "common/run_metrics.h"
#include "common/trajectory.h"

namespace rumi {

// Throws std::runtime_error when the file cannot be read or parsed. A stats
// file without "loops" (an older manager) gives no rows.
std::vector<LoopAuditRow> AuditLoops(const std::string& manager_stats_path, const Trajectory& ground_truth,
                                     double max_dt_s = 0.02);

}  // namespace rumi
