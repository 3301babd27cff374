#include "manager/welding_ba.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "common/stats.h"
#include "common/ceres_util.h"
#include "manager/sim3_alignment.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

struct ReprojectionCost {
  ReprojectionCost(const CameraIntrinsics& cam, const Eigen::Vector2d& obs) : cam_(cam), obs_(obs) {}
  template <typename T>
  bool operator()(const T* q_xyzw, const T* t, const T* X, T* res) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tr(t), p(X);
    const Eigen::Matrix<T, 3, 1> pc = q * p + tr;
    if (pc[2] <= T(1e-9)) return false;
    T uv[2];
    PinholeProject(cam_.fx, cam_.fy, cam_.cx, cam_.cy, pc.data(), uv);
    res[0] = uv[0] - T(obs_.x());
    res[1] = uv[1] - T(obs_.y());
    return true;
  }
  CameraIntrinsics cam_;
  Eigen::Vector2d obs_;
};

struct PoseParam {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
};

}  // namespace

std::unordered_set<int64_t> WeldingWindow(const Submap& front, const std::vector<int64_t>& seed_keyframe_ids,
                                          int min_covisible, int max_keyframes) {
  std::unordered_set<int64_t> window(seed_keyframe_ids.begin(), seed_keyframe_ids.end());
  const SubmapIndex idx(front);
  std::unordered_map<int64_t, int> shared;  // keyframe id -> max shared points with one seed
  for (int64_t seed : seed_keyframe_ids) {
    const int k = idx.Keyframe(seed);
    if (k < 0) continue;
    std::unordered_map<int64_t, int> count;
    for (int64_t pid : front.keyframes[k].point_ids) {
      const int p = pid < 0 ? -1 : idx.Point(pid);
      if (p < 0) continue;
      for (const auto& ob : front.points[p].observations) ++count[ob.keyframe_id];
    }
    for (const auto& [kf, n] : count) shared[kf] = std::max(shared[kf], n);
  }
  std::vector<std::pair<int, int64_t>> ranked;  // (-shared, id): most covisible first
  for (const auto& [kf, n] : shared)
    if (n >= min_covisible && !window.count(kf)) ranked.emplace_back(-n, kf);
  std::sort(ranked.begin(), ranked.end());
  for (const auto& [neg, kf] : ranked) {
    if (int(window.size()) >= max_keyframes) break;
    window.insert(kf);
  }
  return window;
}

WeldingReport WeldWindow(GlobalMap* map, int front, int back, const std::unordered_set<int64_t>& window,
                         const std::vector<std::pair<int64_t, int64_t>>& fused_front_to_back,
                         const ManagerOptions& options) {
  WeldingReport rep;
  Submap& F = map->submap(front);
  const Submap& B = map->submap(back);
  const Sim3 S_gf = map->ToGlobal(front), S_gb = map->ToGlobal(back);
  const Sim3 S_fg = S_gf.Inverse();
  const SubmapIndex fi(F), bi(B);
  std::unordered_map<int64_t, int64_t> fused(fused_front_to_back.begin(), fused_front_to_back.end());

  // Poses in the global frame, for the window and the fixed observers.
  std::unordered_map<int64_t, PoseParam> poses;
  auto pose_of = [&](int64_t kf_id) -> PoseParam* {
    auto it = poses.find(kf_id);
    if (it != poses.end()) return &it->second;
    const int k = fi.Keyframe(kf_id);
    if (k < 0) return nullptr;
    const Se3 T_cw = S_gf.TransformPose(F.keyframes[k].T_wc()).Inverse();
    return &(poses[kf_id] = {T_cw.rotation(), T_cw.translation()});
  };
  // Points seen by the window.
  std::unordered_map<int64_t, Eigen::Vector3d> points;  // front point id -> global position
  for (int64_t kf_id : window) {
    const int k = fi.Keyframe(kf_id);
    if (k < 0) continue;
    for (int64_t pid : F.keyframes[k].point_ids) {
      if (pid < 0 || points.count(pid)) continue;
      const int p = fi.Point(pid);
      if (p < 0) continue;
      const auto fu = fused.find(pid);
      const int b = fu == fused.end() ? -1 : bi.Point(fu->second);
      points[pid] = b >= 0 ? S_gb * B.points[b].position : S_gf * F.points[p].position;
    }
  }
  ceres::Problem problem;
  std::vector<std::pair<int64_t, ceres::ResidualBlockId>> blocks;
  std::unordered_set<int64_t> fixed_kfs;
  for (auto& [pid, X] : points) {
    const bool is_fused = fused.count(pid) && bi.Point(fused[pid]) >= 0;
    const MapPoint& mp = F.points[fi.Point(pid)];
    bool added = false;
    for (const auto& ob : mp.observations) {
      const bool in_window = window.count(ob.keyframe_id) > 0;
      if (is_fused && !in_window) continue;  // nothing variable
      const int k = fi.Keyframe(ob.keyframe_id);
      if (k < 0 || ob.keypoint_index < 0 || ob.keypoint_index >= int(F.keyframes[k].keypoints.size())) continue;
      PoseParam* P = pose_of(ob.keyframe_id);
      const Eigen::Vector3d pc = P->q * X + P->t;
      if (pc.z() <= 1e-9) continue;
      auto* cost = new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 4, 3, 3>(
          new ReprojectionCost(F.camera, F.keyframes[k].keypoints[ob.keypoint_index].cast<double>()));
      blocks.emplace_back(pid, problem.AddResidualBlock(
                                   cost, MakeRobustLoss(options.robust_loss, options.robust_loss_scale_px),
                                   P->q.coeffs().data(), P->t.data(), X.data()));
      if (!in_window) fixed_kfs.insert(ob.keyframe_id);
      added = true;
    }
    if (!added) continue;
    if (is_fused) {
      problem.SetParameterBlockConstant(X.data());
      ++rep.fixed_points;
    } else {
      ++rep.variable_points;
    }
  }
  for (auto& [kf_id, P] : poses) {
    if (!problem.HasParameterBlock(P.q.coeffs().data())) continue;
    problem.SetManifold(P.q.coeffs().data(), new ceres::EigenQuaternionManifold);
    if (fixed_kfs.count(kf_id)) {
      problem.SetParameterBlockConstant(P.q.coeffs().data());
      problem.SetParameterBlockConstant(P.t.data());
    }
  }
  rep.fixed_keyframes = int(fixed_kfs.size());
  rep.window_keyframes = int(poses.size()) - rep.fixed_keyframes;
  rep.residuals = int(blocks.size());
  if (blocks.empty()) return rep;

  auto rmse = [&]() {
    ceres::Problem::EvaluateOptions eo;
    double cost = 0;
    std::vector<double> res;
    eo.apply_loss_function = false;
    problem.Evaluate(eo, &cost, &res, nullptr, nullptr);
    return std::sqrt(2.0 * cost / double(blocks.size()));
  };
  rep.initial_rmse_px = rmse();
  const ceres::Solver::Options so = CeresSolverOptions(ceres::SPARSE_SCHUR, options.ba_max_iterations);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  rep.iterations = int(summary.iterations.size());
  rep.final_rmse_px = rmse();

  // How far the solve moved the window keyframes. A keyframe the window
  // barely constrains can be flung away while the RMSE stays (a drifting
  // front submap: one welded keyframe moved by a third of the scene radius
  // made the run's ATE 1.5x worse); such a solve is not applied, and the
  // merge stands on its Sim(3) alone.
  std::vector<Eigen::Vector3d> front_points;
  for (const MapPoint& p : F.points) front_points.push_back(p.position);
  const double radius = SceneRadius(front_points);
  std::vector<double> shifts;
  for (const auto& [kf_id, P] : poses) {
    if (fixed_kfs.count(kf_id) || !(radius > 0)) continue;
    const Se3 after = S_fg.TransformPose(Se3(P.q.normalized(), P.t).Inverse());
    shifts.push_back((after.translation() - F.keyframes[fi.Keyframe(kf_id)].T_wc().translation()).norm() / radius);
  }
  if (!shifts.empty()) {
    rep.median_shift_ratio = Median(shifts).value_or(0.0);
    rep.max_shift_ratio = *std::max_element(shifts.begin(), shifts.end());
  }
  if (rep.max_shift_ratio > options.welding_max_shift) {
    rep.reverted = true;
    return rep;
  }
  // Back into the front submap's own frame.
  for (const auto& [kf_id, P] : poses) {
    if (fixed_kfs.count(kf_id)) continue;
    Keyframe& kf = F.keyframes[fi.Keyframe(kf_id)];
    kf.T_cw = S_fg.TransformPose(Se3(P.q.normalized(), P.t).Inverse()).Inverse();
  }
  for (const auto& [pid, X] : points) F.points[fi.Point(pid)].position = S_fg * X;
  rep.applied = true;
  return rep;
}

}  // namespace rumi
