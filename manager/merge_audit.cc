#include "manager/merge_audit.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "manager/sim3_json.h"

namespace rumi {
namespace {

// The posed frames of a submap: a front's tracked (or coarse) frame records,
// a back's keyframes; sorted by time, one pose per timestamp.
Trajectory PosedFrames(const Submap& s) {
  Trajectory t;
  if (s.source == SubmapSource::kBack) {
    for (const Keyframe& kf : s.keyframes) t.push_back({kf.timestamp, kf.T_wc()});
  } else {
    for (const FrameRecord& f : s.frames)
      if (f.state == TrackingState::kTracking || f.state == TrackingState::kCoarse) t.push_back({f.timestamp, f.T_wc});
  }
  std::sort(t.begin(), t.end(), [](const StampedPose& x, const StampedPose& y) { return x.t < y.t; });
  t.erase(std::unique(t.begin(), t.end(), [](const StampedPose& x, const StampedPose& y) { return x.t == y.t; }),
          t.end());
  return t;
}

struct Paired {
  std::vector<Eigen::Vector3d> est, gt;
};

Paired PairWithTruth(const Trajectory& est, const Trajectory& gt, const AssociationOptions& o, const Sim3& S) {
  Paired p;
  if (est.empty() || gt.empty()) return p;
  for (const PosePair& pp : AssociateByTimestamp(est, gt, o)) {
    p.est.push_back(S * est[pp.est].T_wc.translation());
    p.gt.push_back(gt[pp.gt].T_wc.translation());
  }
  return p;
}

std::optional<double> OwnAte(const Paired& p) {
  if (p.est.size() < 3) return std::nullopt;
  const UmeyamaResult u = UmeyamaAlign(p.est, p.gt, true);
  if (!u.ok) return std::nullopt;
  return u.rmse;
}

double Rms(const std::vector<double>& r, size_t begin, size_t end) {
  double s = 0;
  for (size_t i = begin; i < end; ++i) s += r[i] * r[i];
  return end > begin ? std::sqrt(s / double(end - begin)) : 0.0;
}

}  // namespace

std::vector<MergeAttempt> ReadMergeAttempts(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<MergeAttempt> out;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (!j.contains("merge_reports") || !j["merge_reports"].is_array())
      throw std::runtime_error("no \"merge_reports\" array");
    for (const auto& r : j["merge_reports"]) {
      // A refined (or merged) attempt has S_bf; one the alignment refused
      // only its candidate, S_bf_initial.
      const char* key = r.contains("S_bf") ? "S_bf" : r.contains("S_bf_initial") ? "S_bf_initial" : nullptr;
      if (!key) continue;
      MergeAttempt a;
      a.kind = r.value("kind", "merge");
      a.a = r.at("front").get<std::string>();
      a.b = r.at("back").get<std::string>();
      a.merged = r.at("merged").get<bool>();
      a.reason = r.value("reason", "");
      a.rejected_by = r.value("rejected_by", "");
      a.has_transform = true;
      a.S_ba = Sim3FromJson(r.at(key));
      out.push_back(a);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return out;
}

std::vector<MergeAttempt> AttemptsOf(const std::vector<MergeReport>& reports) {
  std::vector<MergeAttempt> out;
  for (const MergeReport& r : reports) {
    if (!r.merged && !r.refined && !r.aligned) continue;
    MergeAttempt a;
    a.kind = r.kind;
    a.a = ToString(r.front);
    a.b = ToString(r.back);
    a.merged = r.merged;
    a.reason = r.reason;
    a.rejected_by = r.rejected_by;
    a.has_transform = true;
    a.S_ba = r.merged || r.refined ? r.S_bf : r.S_bf_initial;
    out.push_back(a);
  }
  return out;
}

std::vector<MergeAuditRow> AuditMerges(const GlobalMap& raw, const std::vector<MergeAttempt>& attempts,
                                       const Trajectory& gt, const MergeAuditOptions& o) {
  auto find = [&](const std::string& name) -> const Submap* {
    for (size_t i = 0; i < raw.size(); ++i)
      if (ToString(raw.Key(int(i))) == name) return &raw.submap(int(i));
    return nullptr;
  };
  std::vector<MergeAuditRow> rows;
  for (const MergeAttempt& m : attempts) {
    MergeAuditRow row;
    row.kind = m.kind;
    row.a = m.a;
    row.b = m.b;
    row.accepted = m.merged;
    row.reason = m.reason;
    row.rejected_by = m.rejected_by;
    const Submap* A = find(m.a);
    const Submap* B = find(m.b);
    if (!A || !B || !m.has_transform || gt.empty()) {
      row.note = gt.empty() ? "no ground truth" : !m.has_transform ? "no Sim(3)" : "submap not in the raw map";
      rows.push_back(row);
      continue;
    }
    const Trajectory b_traj = PosedFrames(*B);
    Trajectory a_all = PosedFrames(*A), a_traj;
    if (!b_traj.empty()) {
      const Timestamp lo = b_traj.front().t - SecondsToNs(o.near_s), hi = b_traj.back().t + SecondsToNs(o.near_s);
      for (const StampedPose& p : a_all)
        if (p.t >= lo && p.t <= hi) a_traj.push_back(p);
    }
    if (a_traj.size() < 3) a_traj = a_all;

    const Paired pa = PairWithTruth(a_traj, gt, o.association, Sim3());
    const Paired pb = PairWithTruth(b_traj, gt, o.association, Sim3());
    const Paired pb_in_a = PairWithTruth(b_traj, gt, o.association, m.S_ba.Inverse());
    row.a_frames = pa.est.size();
    row.b_frames = pb.est.size();
    row.ate_a = OwnAte(pa);
    row.ate_b = OwnAte(pb);
    Paired joint = pa;
    joint.est.insert(joint.est.end(), pb_in_a.est.begin(), pb_in_a.est.end());
    joint.gt.insert(joint.gt.end(), pb_in_a.gt.begin(), pb_in_a.gt.end());
    const UmeyamaResult u = joint.est.size() >= 3 ? UmeyamaAlign(joint.est, joint.gt, true) : UmeyamaResult{};
    if (!row.ate_a || !u.ok) {
      row.note = "too few frames with ground truth to align";
      rows.push_back(row);
      continue;
    }
    row.ate_joint = u.rmse;
    row.ate_a_joint = Rms(u.residuals, 0, pa.est.size());
    Eigen::Vector3d lo = joint.gt[0], hi = joint.gt[0];
    for (const auto& g : joint.gt) lo = lo.cwiseMin(g), hi = hi.cwiseMax(g);
    const double floor = o.floor_ratio * (hi - lo).norm();
    row.harmful = u.rmse > o.joint_ratio * std::max(*row.ate_a, row.ate_b.value_or(0.0)) + floor ||
                  u.rmse > o.front_ratio * *row.ate_a + floor;
    rows.push_back(row);
  }
  return rows;
}

}  // namespace rumi
