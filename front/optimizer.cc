#include "front/optimizer.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <cmath>

#include "common/ceres_util.h"

namespace rumi {

int OptimizePose(TrackFrame* f, const PinholeCamera& cam, const ScalePyramid& pyr) {
  struct Ob { int idx; Eigen::Vector3d X; Eigen::Vector2d uv; double w; };
  std::vector<Ob> obs;
  for (size_t i = 0; i < f->points.size(); ++i) {
    Landmark* p = f->points[i];
    if (!p || p->bad) continue;
    f->outlier[i] = false;
    obs.push_back({static_cast<int>(i), p->pos, f->f->un[i], pyr.inv_sigma2[f->f->keypoints[i].octave]});
  }
  if (obs.size() < 3) return 0;
  const double chi2_th = 5.991, huber = std::sqrt(5.991);
  std::vector<char> out(obs.size(), 0);
  Se3 T = f->T_cw;
  const int rounds = 4, iters = 10;
  for (int r = 0; r < rounds; ++r) {
    for (int it = 0; it < iters; ++it) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      const Eigen::Matrix3d R = T.R();
      const Eigen::Vector3d t = T.translation();
      int n = 0;
      for (size_t k = 0; k < obs.size(); ++k) {
        if (out[k]) continue;
        const Eigen::Vector3d pc = R * obs[k].X + t;
        if (pc.z() <= 1e-6) continue;
        const double iz = 1.0 / pc.z();
        const Eigen::Vector2d e(cam.fx() * pc.x() * iz + cam.cx() - obs[k].uv.x(),
                                cam.fy() * pc.y() * iz + cam.cy() - obs[k].uv.y());
        // d(proj)/d(pc), and d(pc)/d(xi) = [I, -[pc]x] (left perturbation).
        Eigen::Matrix<double, 2, 3> Jp;
        Jp << cam.fx() * iz, 0, -cam.fx() * pc.x() * iz * iz, 0, cam.fy() * iz, -cam.fy() * pc.y() * iz * iz;
        Eigen::Matrix<double, 3, 6> Jx;
        Jx.leftCols<3>().setIdentity();
        Jx.rightCols<3>() << 0, pc.z(), -pc.y(), -pc.z(), 0, pc.x(), pc.y(), -pc.x(), 0;
        const Eigen::Matrix<double, 2, 6> J = Jp * Jx;
        const double chi2 = e.squaredNorm() * obs[k].w;
        const double s = std::sqrt(chi2);
        const double hw = s <= huber ? 1.0 : huber / s;
        const double w = obs[k].w * hw;
        H.noalias() += w * J.transpose() * J;
        b.noalias() -= w * J.transpose() * e;
        ++n;
      }
      if (n < 3) break;
      const Eigen::Matrix<double, 6, 1> dx = H.ldlt().solve(b);
      if (!dx.allFinite()) break;
      T = Se3::Exp(dx) * T;
      if (dx.squaredNorm() < 1e-12) break;
    }
    // Classify with the current pose; outliers may come back next round.
    const Eigen::Matrix3d R = T.R();
    const Eigen::Vector3d t = T.translation();
    for (size_t k = 0; k < obs.size(); ++k) {
      const Eigen::Vector3d pc = R * obs[k].X + t;
      if (pc.z() <= 1e-6) { out[k] = 1; continue; }
      const Eigen::Vector2d e = ProjectUndistorted(cam, pc) - obs[k].uv;
      out[k] = e.squaredNorm() * obs[k].w > chi2_th;
    }
  }
  f->T_cw = T;
  int inliers = 0;
  for (size_t k = 0; k < obs.size(); ++k) {
    f->outlier[obs[k].idx] = out[k] != 0;
    inliers += out[k] ? 0 : 1;
  }
  return inliers;
}

namespace {

struct ReprojCost {
  ReprojCost(const Eigen::Vector2d& uv, double w, const PinholeCamera& c)
      : u(uv.x()), v(uv.y()), w(w), fx(c.fx()), fy(c.fy()), cx(c.cx()), cy(c.cy()) {}
  template <typename T>
  bool operator()(const T* q, const T* t, const T* X, T* r) const {
    // q: Eigen order x y z w; ceres wants w x y z.
    const T qw[4] = {q[3], q[0], q[1], q[2]};
    T p[3];
    ceres::QuaternionRotatePoint(qw, X, p);
    p[0] += t[0]; p[1] += t[1]; p[2] += t[2];
    if (p[2] <= T(1e-6)) { r[0] = r[1] = T(0); return true; }
    r[0] = T(w) * (T(fx) * p[0] / p[2] + T(cx) - T(u));
    r[1] = T(w) * (T(fy) * p[1] / p[2] + T(cy) - T(v));
    return true;
  }
  double u, v, w, fx, fy, cx, cy;
};

class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* a) : a_(a) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    // Terminate (not abort): Ceres then hands back the last accepted state,
    // never a rejected trial step.
    return (a_ && a_->load()) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
 private:
  const std::atomic<bool>* a_;
};

// Few cameras (<= ~40) per local BA: the reduced camera system is small
// and dense Schur is faster than a sparse factorisation.
ceres::LinearSolverType BaSolver() { return ceres::DENSE_SCHUR; }

}  // namespace

void CollectLocalBa(KeyFrame* kf, int max_local, int max_fixed, LocalBaProblem* pb) {
  *pb = LocalBaProblem();
  const int64_t tag = kf->id;
  pb->local.push_back(kf);
  kf->ba_local_for = tag;
  for (KeyFrame* n : kf->BestCovisibles(max_local - 1)) {
    if (n->bad) continue;
    n->ba_local_for = tag;
    pb->local.push_back(n);
  }
  std::map<Landmark*, int, ById> pidx;
  for (KeyFrame* k : pb->local)
    for (Landmark* p : k->points)
      if (p && !p->bad && !pidx.count(p)) { pidx[p] = static_cast<int>(pb->points.size()); pb->points.push_back(p); }
  for (Landmark* p : pb->points)
    for (auto& [k, idx] : p->obs) {
      if (k->bad || k->ba_local_for == tag || k->ba_fixed_for == tag) continue;
      if (static_cast<int>(pb->fixed.size()) >= max_fixed) break;
      k->ba_fixed_for = tag;
      pb->fixed.push_back(k);
    }
  // Monocular gauge: 7 DoF (pose + scale). With fewer than two fixed
  // keyframes the scale is free and can drift away (seen as a scale collapse),
  // so the oldest local keyframes are held fixed until there are two.
  int num_fixed = static_cast<int>(pb->fixed.size());
  for (KeyFrame* k : pb->local) num_fixed += k->fixed ? 1 : 0;
  while (num_fixed < 2 && pb->local.size() > 2) {
    auto oldest = std::min_element(pb->local.begin() + 1, pb->local.end(),
                                   [](KeyFrame* a, KeyFrame* b) { return a->id < b->id; });
    if ((*oldest)->fixed) break;
    pb->fixed.push_back(*oldest);
    pb->local.erase(oldest);
    ++num_fixed;
  }
  std::map<KeyFrame*, int, ById> kidx;
  for (KeyFrame* k : pb->local) { kidx[k] = static_cast<int>(pb->q.size()); pb->q.push_back(k->T_cw.rotation().coeffs()); pb->t.push_back(k->T_cw.translation()); }
  for (KeyFrame* k : pb->fixed) { kidx[k] = static_cast<int>(pb->q.size()); pb->q.push_back(k->T_cw.rotation().coeffs()); pb->t.push_back(k->T_cw.translation()); }
  for (Landmark* p : pb->points) {
    pb->x.push_back(p->pos);
    for (auto& [k, idx] : p->obs) {
      auto it = kidx.find(k);
      if (it == kidx.end()) continue;
      // Inverse sigma of the keypoint's level weights the residual.
      pb->obs.push_back({it->second, pidx[p], k->f->un[idx], k->f->keypoints[idx].octave, k, idx});
    }
  }
}

bool SolveLocalBa(LocalBaProblem* pb, const PinholeCamera& cam, const ScalePyramid& pyr, int iterations, double max_time_s,
                  const std::atomic<bool>* abort) {
  if (pb->obs.empty()) return false;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::EigenQuaternionManifold qm;
  ceres::HuberLoss huber(std::sqrt(5.991));
  for (const auto& o : pb->obs) {
    // Residuals weighted by the inverse sigma of the keypoint's level.
    auto* cost = new ceres::AutoDiffCostFunction<ReprojCost, 2, 4, 3, 3>(
        new ReprojCost(o.uv, 1.0 / pyr.scales[o.level], cam));
    problem.AddResidualBlock(cost, &huber, pb->q[o.kf].data(), pb->t[o.kf].data(), pb->x[o.pt].data());
  }
  const int nl = static_cast<int>(pb->local.size());
  for (int i = 0; i < static_cast<int>(pb->q.size()); ++i) {
    if (!problem.HasParameterBlock(pb->q[i].data())) continue;
    problem.SetManifold(pb->q[i].data(), &qm);
    const bool fixed = i >= nl || pb->local[i]->fixed;
    if (fixed) {
      problem.SetParameterBlockConstant(pb->q[i].data());
      problem.SetParameterBlockConstant(pb->t[i].data());
    }
  }
  ceres::Solver::Options so = CeresSolverOptions(BaSolver(), iterations);
  so.max_solver_time_in_seconds = max_time_s;
  AbortCallback cb(abort);
  so.callbacks.push_back(&cb);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  // Write back only a usable solution that did not increase the cost.
  return summary.IsSolutionUsable() && std::isfinite(summary.final_cost) &&
         summary.final_cost <= summary.initial_cost;
}

void ApplyLocalBa(const LocalBaProblem& pb, const PinholeCamera& cam, const ScalePyramid& pyr) {
  for (size_t i = 0; i < pb.local.size(); ++i) {
    KeyFrame* k = pb.local[i];
    if (k->bad || k->fixed) continue;
    k->T_cw = Se3(Eigen::Quaterniond(pb.q[i]), pb.t[i]);
  }
  for (size_t i = 0; i < pb.points.size(); ++i)
    if (!pb.points[i]->bad) pb.points[i]->pos = pb.x[i];
  // Drop observations that stay bad after the optimisation.
  for (const auto& o : pb.obs) {
    Landmark* p = pb.points[o.pt];
    if (p->bad || o.k->bad) continue;
    const Eigen::Vector3d pc = o.k->T_cw * p->pos;
    const int lvl = o.k->f->keypoints[o.idx].octave;
    if (pc.z() <= 0 || (ProjectUndistorted(cam, pc) - o.uv).squaredNorm() * pyr.inv_sigma2[lvl] > 5.991)
      Map::EraseObservation(p, o.k);
  }
  for (Landmark* p : pb.points)
    if (!p->bad) Map::UpdateNormalAndDepth(p, pyr);
}

void GlobalBa(Map* map, const PinholeCamera& cam, const ScalePyramid& pyr, int iterations) {
  LocalBaProblem pb;
  KeyFrame* first = nullptr;
  for (auto& [id, k] : map->keyframes) {
    if (k->bad) continue;
    if (!first) first = k.get();
  }
  if (!first) return;
  CollectLocalBa(first, 1 << 20, 0, &pb);
  // Every keyframe free except the gauge one.
  std::vector<KeyFrame*> all;
  for (auto& [id, k] : map->keyframes)
    if (!k->bad) all.push_back(k.get());
  if (all.size() != pb.local.size()) {  // disconnected ones: include them too
    pb = LocalBaProblem();
    pb.local = all;
    std::map<Landmark*, int, ById> pidx;
    std::map<KeyFrame*, int, ById> kidx;
    for (KeyFrame* k : all) { kidx[k] = static_cast<int>(pb.q.size()); pb.q.push_back(k->T_cw.rotation().coeffs()); pb.t.push_back(k->T_cw.translation()); }
    for (auto& [id, p] : map->points) {
      if (p->bad) continue;
      const int pi = static_cast<int>(pb.points.size());
      pb.points.push_back(p.get());
      pb.x.push_back(p->pos);
      for (auto& [k, idx] : p->obs)
        if (kidx.count(k)) pb.obs.push_back({kidx[k], pi, k->f->un[idx], k->f->keypoints[idx].octave, k, idx});
    }
  }
  if (SolveLocalBa(&pb, cam, pyr, iterations, 1.0, nullptr)) ApplyLocalBa(pb, cam, pyr);
}

}  // namespace rumi
