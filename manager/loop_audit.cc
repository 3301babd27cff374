#include "manager/loop_audit.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "common/timestamp.h"
#include "manager/sim3_json.h"

namespace rumi {
namespace {

// The ground-truth pose nearest to t within max_dt, or nullptr.
const StampedPose* Nearest(const Trajectory& gt, Timestamp t, Timestamp max_dt) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t,
                                   [](const StampedPose& p, Timestamp x) { return p.t < x; });
  const StampedPose* best = nullptr;
  for (auto c : {it, it == gt.begin() ? it : it - 1})
    if (c != gt.end() && std::llabs(c->t - t) <= max_dt && (!best || std::llabs(c->t - t) < std::llabs(best->t - t)))
      best = &*c;
  return best;
}

double Degrees(double rad) { return rad * 180.0 / M_PI; }

}  // namespace

nlohmann::json LoopReportToJson(const LoopReport& r) {
  return {{"query", ToString(r.edge.query_submap)},
          {"query_keyframe", r.edge.query_keyframe},
          {"query_time_s", NsToSeconds(r.edge.query_time)},
          {"match", ToString(r.edge.match_submap)},
          {"match_keyframe", r.edge.match_keyframe},
          {"match_time_s", NsToSeconds(r.edge.match_time)},
          {"inliers", r.edge.inliers},
          {"matches", r.edge.matches},
          {"support", r.support},
          {"closed", r.closed},
          {"reason", r.reason},
          {"S_qm", Sim3ToJson(r.edge.S_qm)},
          {"depth", r.depth},
          {"shift", r.shift},
          {"shift_ratio", r.shift_ratio},
          {"rotation_deg", r.rotation_deg},
          {"scale_change", r.scale_change}};
}

std::vector<LoopAuditRow> AuditLoops(const std::string& path, const Trajectory& gt, double max_dt_s) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (!j.contains("loops")) return {};
    return AuditLoopsJson(j.at("loops"), gt, max_dt_s);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

std::vector<LoopAuditRow> AuditLoopsJson(const nlohmann::json& loops, const Trajectory& gt, double max_dt_s) {
  std::vector<LoopAuditRow> out;
  const Timestamp max_dt = Timestamp(max_dt_s * 1e9);
  for (const auto& l : loops) {
    LoopAuditRow r;
    r.query = l.at("query").get<std::string>();
    r.match = l.at("match").get<std::string>();
    r.query_keyframe = l.at("query_keyframe").get<int64_t>();
    r.match_keyframe = l.at("match_keyframe").get<int64_t>();
    r.query_time_s = l.at("query_time_s").get<double>();
    r.match_time_s = l.at("match_time_s").get<double>();
    r.closed = l.at("closed").get<bool>();
    const StampedPose* q = Nearest(gt, Timestamp(std::llround(r.query_time_s * 1e9)), max_dt);
    const StampedPose* m = Nearest(gt, Timestamp(std::llround(r.match_time_s * 1e9)), max_dt);
    if (!l.contains("S_qm")) {
      r.note = "no S_qm in the stats";
    } else if (!q || !m) {
      r.note = "no ground truth within " + std::to_string(max_dt_s) + " s of a keyframe";
    } else {
      // p_q = S_qm p_m (camera frames); the truth: T_qm = T_wc_q^-1 T_wc_m.
      const Sim3 S = Sim3FromJson(l.at("S_qm"));
      const Se3 T = q->T_wc.Inverse() * m->T_wc;
      r.rotation_error_deg = Degrees(S.rotation().angularDistance(T.rotation()));
      // The direction between the cameras only where they are far apart
      // for the scene (a fifth of its depth): closer, a few millimetres
      // of position noise turn it any way (a right loop 8 % of the depth
      // apart read 100 deg off).
      const double depth = l.value("depth", 0.0);
      if (depth > 0 && S.translation().norm() >= 0.2 * depth && T.translation().norm() > 0) {
        const double c = S.translation().normalized().dot(T.translation().normalized());
        r.direction_error_deg = Degrees(std::acos(std::clamp(c, -1.0, 1.0)));
      }
      r.right = *r.rotation_error_deg <= 5.0 && (!r.direction_error_deg || *r.direction_error_deg <= 20.0);
    }
    r.harmful = r.closed && r.rotation_error_deg && !r.right;
    out.push_back(r);
  }
  return out;
}

}  // namespace rumi
