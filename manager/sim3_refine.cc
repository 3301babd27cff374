#include "manager/sim3_refine.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>

#include "common/ceres_util.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

// One observation of Formula 8. forward: X is a front point, observed in a
// back keyframe (pose T_cw); otherwise X is a back point observed in a front
// keyframe and is mapped by the inverse.
struct Sim3Observation {
  bool forward;
  Eigen::Vector3d X;
  Se3 T_cw;
  CameraIntrinsics cam;
  Eigen::Vector2d obs;
};

struct Sim3ReprojectionCost {
  explicit Sim3ReprojectionCost(const Sim3Observation& o) : o_(o) {}
  template <typename T>
  bool operator()(const T* log_s, const T* q_xyzw, const T* t, T* res) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tr(t);
    // A trial step far out (scale e^-854 was seen on a poorly constrained
    // pair) is an invalid point for the solver, not a NaN residual.
    if (!(ceres::abs(log_s[0]) < T(30))) return false;
    const T s = ceres::exp(log_s[0]);
    Eigen::Matrix<T, 3, 1> X;
    if (o_.forward) {
      X = s * (q * o_.X.cast<T>()) + tr;
    } else {
      X = (q.conjugate() * (o_.X.cast<T>() - tr)) / s;
    }
    const Eigen::Matrix<T, 3, 1> pc = o_.T_cw.rotation().cast<T>() * X + o_.T_cw.translation().cast<T>();
    if (pc[2] <= T(1e-9)) return false;
    T uv[2];
    PinholeProject(o_.cam.fx, o_.cam.fy, o_.cam.cx, o_.cam.cy, pc.data(), uv);
    res[0] = uv[0] - T(o_.obs.x());
    res[1] = uv[1] - T(o_.obs.y());
    return true;
  }
  Sim3Observation o_;
};

// Reprojection error in px, negative when behind the camera.
double ErrorPx(const Sim3& S, const Sim3Observation& o) {
  const Eigen::Vector3d X = o.forward ? S * o.X : S.Inverse() * o.X;
  Eigen::Vector2d px;
  if (!ProjectPinhole(o.cam, o.T_cw * X, &px)) return -1.0;
  return (px - o.obs).norm();
}

double Rmse(const Sim3& S, const std::vector<Sim3Observation>& obs) {
  if (obs.empty()) return 0.0;
  double sum = 0.0;
  for (const auto& o : obs) {
    const double e = ErrorPx(S, o);
    sum += e < 0 ? 1e6 : e * e;
  }
  return std::sqrt(sum / double(obs.size()));
}

void AddObservations(const Submap& observed_in, const SubmapIndex& idx, const MapPoint& observed_point,
                     const Eigen::Vector3d& X, bool forward, int max_obs, std::vector<Sim3Observation>* out) {
  const size_t n = observed_point.observations.size();
  const size_t step = std::max<size_t>(1, (n + size_t(max_obs) - 1) / size_t(max_obs));
  for (size_t i = 0; i < n; i += step) {
    const MapPoint::Observation& ob = observed_point.observations[i];
    const int k = idx.Keyframe(ob.keyframe_id);
    if (k < 0) continue;
    const Keyframe& kf = observed_in.keyframes[k];
    if (ob.keypoint_index < 0 || ob.keypoint_index >= int(kf.keypoints.size())) continue;
    out->push_back({forward, X, kf.T_cw, observed_in.camera, kf.keypoints[ob.keypoint_index].cast<double>()});
  }
}

// Solves for S from the observations; returns Ceres' iteration count.
int Solve(const std::vector<Sim3Observation>& obs, const ManagerOptions& o, Sim3* S) {
  double log_s = std::log(S->scale());
  Eigen::Quaterniond q = S->rotation();
  Eigen::Vector3d t = S->translation();
  ceres::Problem problem;
  for (const auto& ob : obs) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Sim3ReprojectionCost, 2, 1, 4, 3>(new Sim3ReprojectionCost(ob)),
        MakeRobustLoss(o.robust_loss, o.robust_loss_scale_px), &log_s, q.coeffs().data(), t.data());
  }
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  const ceres::Solver::Options so = CeresSolverOptions(ceres::DENSE_QR, o.refine_max_iterations);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  *S = Sim3(std::exp(log_s), q.normalized(), t);
  return int(summary.iterations.size());
}

}  // namespace

Sim3RefineResult RefineSim3(const Submap& front, const Submap& back, const std::vector<PointMatch>& matches,
                            const std::vector<char>* use, const Sim3& initial, const ManagerOptions& options) {
  Sim3RefineResult r;
  r.S_bf = initial;
  const SubmapIndex fi(front), bi(back);
  std::vector<Sim3Observation> all;
  for (size_t m = 0; m < matches.size(); ++m) {
    if (use && (m >= use->size() || !(*use)[m])) continue;
    const int f = fi.Point(matches[m].front_point_id), b = bi.Point(matches[m].back_point_id);
    if (f < 0 || b < 0) continue;
    const int k = options.refine_max_obs_per_point;
    AddObservations(back, bi, back.points[b], front.points[f].position, true, k, &all);
    AddObservations(front, fi, front.points[f], back.points[b].position, false, k, &all);
  }
  // Observations behind a camera at the initial guess would stall the solver.
  std::vector<Sim3Observation> obs;
  for (auto& o : all)
    if (ErrorPx(initial, o) >= 0) obs.push_back(o);
  r.num_residuals = int(obs.size());
  if (obs.size() < 6) {
    r.message = "too few observations in front of the cameras (" + std::to_string(obs.size()) + ")";
    return r;
  }
  Sim3 S = initial;
  r.iterations = Solve(obs, options, &S);
  std::vector<Sim3Observation> kept;
  for (const auto& o : obs) {
    const double e = ErrorPx(S, o);
    if (e >= 0 && e < options.outlier_threshold_px) kept.push_back(o);
  }
  r.num_inlier_residuals = int(kept.size());
  if (kept.size() < 6) {
    r.message = "too few inlier observations after refinement (" + std::to_string(kept.size()) + ")";
    return r;
  }
  r.iterations += Solve(kept, options, &S);
  r.initial_rmse_px = Rmse(initial, kept);
  r.final_rmse_px = Rmse(S, kept);
  r.S_bf = S;
  r.ok = true;
  return r;
}

}  // namespace rumi
