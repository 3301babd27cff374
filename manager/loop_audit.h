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

#include <nlohmann/json.hpp>

#include "common/run_metrics.h"
#include "common/trajectory.h"
#include "manager/loop_closure.h"

namespace rumi {

// A loop as manager_stats.json "loops" holds it (what the audit reads).
nlohmann::json LoopReportToJson(const LoopReport& r);

// The audit of loops in that form (a JSON array; a row without a field
// throws nlohmann::json::exception).
std::vector<LoopAuditRow> AuditLoopsJson(const nlohmann::json& loops, const Trajectory& ground_truth,
                                         double max_dt_s = 0.02);

// Throws std::runtime_error when the file cannot be read or parsed. A stats
// file without "loops" (an older manager) gives no rows.
std::vector<LoopAuditRow> AuditLoops(const std::string& manager_stats_path, const Trajectory& ground_truth,
                                     double max_dt_s = 0.02);

}  // namespace rumi
