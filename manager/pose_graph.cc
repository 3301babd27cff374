#include "manager/pose_graph.h"

#include <ceres/ceres.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>

#include "common/ceres_util.h"

namespace rumi {
namespace {

// A node: log scale, unit quaternion (x, y, z, w), translation; S_wi.
struct Node {
  double log_s = 0;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

// r = whiten(Log(S_ij_meas^-1 * S_wi^-1 * S_wj)), with the rotation part as
// twice the vector part of the error quaternion (its angle for small errors).
template <typename T>
void EdgeResidual(const T* log_si, const T* qi_xyzw, const T* ti_p, const T* log_sj, const T* qj_xyzw,
                  const T* tj_p, const Sim3& meas, const double* w, T* r) {
  const Eigen::Map<const Eigen::Quaternion<T>> qi(qi_xyzw), qj(qj_xyzw);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ti(ti_p), tj(tj_p);
  const T si = ceres::exp(log_si[0]);
  // Estimated S_ij = S_wi^-1 * S_wj.
  const Eigen::Quaternion<T> q_ij = qi.conjugate() * qj;
  const Eigen::Matrix<T, 3, 1> t_ij = (qi.conjugate() * (tj - ti)) / si;
  const T log_s_ij = log_sj[0] - log_si[0];
  // Error S_meas^-1 * S_ij.
  const Eigen::Quaternion<T> qm = meas.rotation().cast<T>();
  const T sm = T(meas.scale());
  const Eigen::Quaternion<T> q_e = qm.conjugate() * q_ij;
  const Eigen::Matrix<T, 3, 1> t_e = (qm.conjugate() * (t_ij - meas.translation().cast<T>())) / sm;
  const T sign = q_e.w() < T(0) ? T(-1) : T(1);  // the shorter way round
  for (int k = 0; k < 3; ++k) {
    r[k] = t_e[k] * T(w[0]);
    r[3 + k] = T(2) * sign * q_e.vec()[k] * T(w[1]);
  }
  r[6] = (log_s_ij - T(std::log(meas.scale()))) * T(w[2]);
}

struct EdgeCost {
  EdgeCost(const Sim3& m, double wt, double wr, double ws) : meas(m), w{wt, wr, ws} {}
  template <typename T>
  bool operator()(const T* log_si, const T* qi, const T* ti, const T* log_sj, const T* qj, const T* tj,
                  T* r) const {
    // A trial step to an absurd scale is an invalid point, not a NaN.
    if (!(ceres::abs(log_si[0]) < T(30)) || !(ceres::abs(log_sj[0]) < T(30))) return false;
    EdgeResidual(log_si, qi, ti, log_sj, qj, tj, meas, w, r);
    return true;
  }
  Sim3 meas;
  double w[3];
};

void Weights(const PoseGraphEdge& e, const PoseGraphOptions& o, double w[3]) {
  const double sw = std::sqrt(std::max(0.0, e.weight));
  w[0] = sw / o.translation_sigma;
  w[1] = sw / o.rotation_sigma_rad;
  w[2] = sw / o.scale_sigma;
}

// Why nodes, edges and fixed nodes do not make a graph of n nodes ("" when they do).
std::string GraphError(const std::vector<Sim3>& S_w, const std::vector<PoseGraphEdge>& edges,
                       const std::vector<int>& fixed) {
  const int n = static_cast<int>(S_w.size());
  if (fixed.empty()) return "no fixed node: the graph's gauge (7 degrees of freedom) is free";
  for (int f : fixed)
    if (f < 0 || f >= n) return "fixed node " + std::to_string(f) + " is not a node";
  for (const PoseGraphEdge& e : edges) {
    if (e.i < 0 || e.j < 0 || e.i >= n || e.j >= n || e.i == e.j)
      return "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) + " is not an edge between two nodes";
    if (!ValidPose(e.S_ij))
      return "edge " + std::to_string(e.i) + "-" + std::to_string(e.j) +
             " has no valid measurement (non-finite, or scale outside e^-30..e^30)";
  }
  for (int k = 0; k < n; ++k)
    if (!ValidPose(S_w[size_t(k)]))
      return "node " + std::to_string(k) + " has no valid pose (non-finite, or scale outside e^-30..e^30)";
  return "";
}

Node ToNode(const Sim3& S) { return Node{std::log(S.scale()), S.rotation(), S.translation()}; }
Sim3 ToSim3(const Node& n) { return Sim3(std::exp(n.log_s), n.q, n.t); }

}  // namespace

bool ValidPose(const Sim3& S) {
  // |log scale| < 30: what EdgeCost evaluates (beyond, exp overflows its derivatives).
  return S.scale() > 0 && std::isfinite(S.scale()) && std::abs(std::log(S.scale())) < 30 &&
         S.rotation().coeffs().allFinite() &&
         std::abs(S.rotation().norm() - 1.0) < 1e-6 && S.translation().allFinite();
}

const char* PoseGraphEdgeKindName(PoseGraphEdgeKind k) {
  switch (k) {
    case PoseGraphEdgeKind::kCovisibility: return "covisibility";
    case PoseGraphEdgeKind::kMerge: return "merge";
    case PoseGraphEdgeKind::kPlaceMerge: return "place_merge";
    case PoseGraphEdgeKind::kLoop: return "loop";
    case PoseGraphEdgeKind::kOdometry: return "odometry";
  }
  return "?";
}

Eigen::Matrix<double, 7, 1> PoseGraphResidual(const std::vector<Sim3>& S_w, const PoseGraphEdge& e,
                                              const PoseGraphOptions& o) {
  const Node a = ToNode(S_w[e.i]), b = ToNode(S_w[e.j]);
  double w[3];
  Weights(e, o, w);
  Eigen::Matrix<double, 7, 1> r;
  EdgeResidual(&a.log_s, a.q.coeffs().data(), a.t.data(), &b.log_s, b.q.coeffs().data(), b.t.data(), e.S_ij, w,
               r.data());
  return r;
}

PoseGraphResult OptimizePoseGraph(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                                  const std::vector<int>& fixed, const PoseGraphOptions& o) {
  PoseGraphResult res;
  const int n = static_cast<int>(S_w->size());
  res.message = GraphError(*S_w, edges, fixed);
  if (!res.message.empty()) return res;
  std::vector<Node> nodes(n);
  for (int k = 0; k < n; ++k) nodes[k] = ToNode((*S_w)[k]);
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  // Graduated non-convexity: a robust loss from the start would take a right
  // loop edge (large residual: the drift it corrects) for an outlier. Solve
  // first with the loss nearly quadratic, then shrink its scale: edges that
  // agree with the rest end with small residuals, a wrong one with a large
  // residual the loss no longer listens to.
  std::vector<double> scales;
  for (int k = o.gnc_steps; k >= 0; --k) scales.push_back(o.loss_scale * std::pow(o.gnc_factor, k));
  ceres::LossFunctionWrapper loss(MakeRobustLoss(o.loss, scales[0]), ceres::TAKE_OWNERSHIP);
  ceres::EigenQuaternionManifold quaternion;
  std::set<int> used;
  for (const PoseGraphEdge& e : edges) {
    double w[3];
    Weights(e, o, w);
    auto* cost = new ceres::AutoDiffCostFunction<EdgeCost, 7, 1, 4, 3, 1, 4, 3>(new EdgeCost(e.S_ij, w[0], w[1], w[2]));
    Node& a = nodes[e.i];
    Node& b = nodes[e.j];
    problem.AddResidualBlock(cost, o.loss == "trivial" || !e.robust ? nullptr : &loss, &a.log_s, a.q.coeffs().data(), a.t.data(),
                             &b.log_s, b.q.coeffs().data(), b.t.data());
    used.insert(e.i);
    used.insert(e.j);
  }
  for (int k : used) problem.SetManifold(nodes[k].q.coeffs().data(), &quaternion);
  for (int f : fixed) {
    if (!used.count(f)) continue;
    problem.SetParameterBlockConstant(&nodes[f].log_s);
    problem.SetParameterBlockConstant(nodes[f].q.coeffs().data());
    problem.SetParameterBlockConstant(nodes[f].t.data());
  }
  ceres::Solver::Options so = CeresSolverOptions(ceres::SPARSE_NORMAL_CHOLESKY, o.max_iterations);
  // Solved to convergence, not to Ceres's default 1e-6 change in cost: the
  // manager solves the same graph again at later rebuilds (loop closure puts
  // the loops it closed back in with one solve) and must land where it did
  // (at 1e-6 the two differed by 2 cm in a room of 1 m).
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  for (size_t stage = 0; stage < scales.size(); ++stage) {
    if (stage > 0) {
      if (o.loss == "trivial") break;
      loss.Reset(MakeRobustLoss(o.loss, scales[stage]), ceres::TAKE_OWNERSHIP);
    }
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    res.iterations += static_cast<int>(summary.iterations.size());
    if (stage == 0) res.initial_cost = summary.initial_cost;
    res.final_cost = summary.final_cost;
    res.message = summary.BriefReport();
    res.ok = summary.IsSolutionUsable();
    if (!res.ok) return res;
  }
  for (int k : used) (*S_w)[k] = ToSim3(nodes[k]);
  for (size_t k = 0; k < edges.size(); ++k)
    if (PoseGraphResidual(*S_w, edges[k], o).norm() > o.outlier_factor * o.loss_scale)
      res.outlier_edges.push_back(static_cast<int>(k));
  return res;
}

void DistributeCorrection(std::vector<Sim3>* S_w, const std::vector<int>& chain, const Sim3& S_w_target) {
  if (chain.size() < 2) return;
  std::vector<Sim3>& S = *S_w;
  // The world-frame correction of the moving end, about the fixed end's position.
  const Sim3 C = S_w_target * S[chain.back()].Inverse();
  const Eigen::Vector3d pivot = S[chain.front()].translation();
  const Eigen::Vector3d d = C * pivot - pivot;
  std::vector<double> along(chain.size(), 0.0);
  for (size_t k = 1; k < chain.size(); ++k)
    along[k] = along[k - 1] + (S[chain[k]].translation() - S[chain[k - 1]].translation()).norm() + 1e-9;
  const double total = along.back();
  const Eigen::Quaterniond I = Eigen::Quaterniond::Identity();
  std::vector<Sim3> out(chain.size());
  for (size_t k = 0; k < chain.size(); ++k) {
    const double f = along[k] / total;
    const double s = std::pow(C.scale(), f);
    const Eigen::Quaterniond q = I.slerp(f, C.rotation());
    // C_f(p) = s R (p - pivot) + pivot + f d, applied to the node's pose.
    const Sim3 C_f(s, q, pivot + f * d - s * (q * pivot));
    out[k] = C_f * S[chain[k]];
  }
  for (size_t k = 0; k < chain.size(); ++k) S[chain[k]] = out[k];
  S[chain.back()] = S_w_target;  // exactly, not to rounding
}

namespace {

double Chi2(const std::vector<Sim3>& S_w, const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& o) {
  double sum = 0;
  for (const PoseGraphEdge& e : edges) sum += PoseGraphResidual(S_w, e, o).squaredNorm();
  return sum;
}

double MeanResidual(const std::vector<Sim3>& S_w, const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& o) {
  if (edges.empty()) return 0;
  double sum = 0;
  for (const PoseGraphEdge& e : edges) sum += PoseGraphResidual(S_w, e, o).norm();
  return sum / static_cast<double>(edges.size());
}

}  // namespace

double ChiSquareQuantile(int dof, double p) {
  if (dof <= 0) return 0;
  // The standard normal's p-quantile: Acklam's rational approximation is
  // more than this needs; Abramowitz-Stegun 26.2.23 (error < 4.5e-4).
  const double q = p < 0.5 ? p : 1.0 - p;
  const double t = std::sqrt(-2.0 * std::log(std::max(q, 1e-300)));
  double z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) / (1.0 + 1.432788 * t + 0.189269 * t * t +
                                                                 0.001308 * t * t * t);
  if (p < 0.5) z = -z;
  const double k = dof, a = 2.0 / (9.0 * k);
  const double c = 1.0 - a + z * std::sqrt(a);
  return k * c * c * c;
}

double OneEdgeBound(const PoseGraphOptions& o) {
  return std::sqrt(o.variance_factor * ChiSquareQuantile(7, o.chi2_confidence));
}

CloseLoopResult CloseLoopEdges(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                               const std::vector<int>& fixed, const std::vector<NewGraphEdge>& news,
                               const PoseGraphOptions& o) {
  CloseLoopResult r;
  const int n = static_cast<int>(S_w->size());
  std::vector<PoseGraphEdge> all = edges;
  for (const NewGraphEdge& ne : news) all.push_back(ne.edge);
  // Checked before anything reads a pose by these indices.
  r.reason = GraphError(*S_w, all, fixed);
  if (!r.reason.empty()) return r;
  if (news.empty()) {
    r.reason = "no new edge";
    return r;
  }
  for (const NewGraphEdge& ne : news) {
    if (ne.chain.size() < 2 || ne.chain.back() != ne.edge.i) {
      r.reason = "the chain must run to the edge's i";
      return r;
    }
    for (const auto* list : {&ne.chain, &ne.followers})
      for (int k : *list)
        if (k < 0 || k >= n) {
          r.reason = "chain or follower node " + std::to_string(k) + " is not a node";
          return r;
        }
  }
  if (o.consistency != "edges" && o.consistency != "chi2") {
    r.reason = "unknown consistency test '" + o.consistency + "' (edges or chi2)";
    return r;
  }
  const std::vector<Sim3> before = *S_w;
  r.mean_residual_before = MeanResidual(before, edges, o);
  // The innovation is measured from the old graph's own optimum: edges
  // taken without a solve (consistent already) may have left it short of it.
  double chi2_before = Chi2(before, edges, o);
  if (o.consistency == "chi2" && chi2_before > 0) {
    std::vector<Sim3> old = before;
    if (OptimizePoseGraph(&old, edges, fixed, o).ok) chi2_before = std::min(chi2_before, Chi2(old, edges, o));
  }
  for (const NewGraphEdge& ne : news) {
    const Sim3 end_was = (*S_w)[size_t(ne.chain.back())];
    // Where the new edge puts its i: S_wi = S_wj * S_ij^-1.
    DistributeCorrection(S_w, ne.chain, (*S_w)[ne.edge.j] * ne.edge.S_ij.Inverse());
    // What lies beyond the moving end (off the chain, untouched by the
    // spread) takes its whole correction.
    const Sim3 C = (*S_w)[size_t(ne.chain.back())] * end_was.Inverse();
    for (int k : ne.followers) (*S_w)[size_t(k)] = C * (*S_w)[size_t(k)];
  }
  r.solve = OptimizePoseGraph(S_w, all, fixed, o);
  auto reject = [&](const std::string& why) {
    *S_w = before;
    r.accepted = false;
    r.reason = why;
    return r;
  };
  if (!r.solve.ok) return reject("the solve failed: " + r.solve.message);
  r.mean_residual_after = MeanResidual(*S_w, edges, o);
  r.dof = 7 * static_cast<int>(news.size());
  r.chi2_increase = Chi2(*S_w, all, o) - chi2_before;
  for (const NewGraphEdge& ne : news) r.new_residuals.push_back(PoseGraphResidual(*S_w, ne.edge, o).norm());
  if (o.consistency == "chi2") {
    const double bound = o.variance_factor * ChiSquareQuantile(r.dof, o.chi2_confidence);
    char why[200];
    std::snprintf(why, sizeof(why), "the graph's chi-square rises by %.1f with %s (bound %.1f, %d dof)",
                  r.chi2_increase, news.size() == 1 ? "it" : "them", bound, r.dof);
    if (!(r.chi2_increase <= bound)) return reject(why);
    // In a lot, one wrong edge's strain can hide in the others' slack: each
    // new edge also within one edge's bound.
    const double one = OneEdgeBound(o);
    for (size_t k = 0; k < r.new_residuals.size(); ++k)
      if (!(r.new_residuals[k] <= one)) {
        std::snprintf(why, sizeof(why), "new edge %zu disagrees with the graph (whitened residual %.1f, bound %.1f)",
                      k, r.new_residuals[k], one);
        return reject(why);
      }
    r.accepted = true;
    r.reason = std::string("accepted: ") + why;
    return r;
  }
  for (int k : r.solve.outlier_edges) {
    if (k >= static_cast<int>(edges.size()))
      return reject(news.size() == 1 ? "the new edge disagrees with the graph (an outlier)"
                                     : "new edge " + std::to_string(k - int(edges.size())) +
                                           " disagrees with the graph (an outlier)");
    const double was = PoseGraphResidual(before, edges[k], o).norm();
    if (was <= o.outlier_factor * o.loss_scale) {
      const Eigen::Matrix<double, 7, 1> now = PoseGraphResidual(*S_w, edges[k], o);
      char why[300];
      std::snprintf(why, sizeof(why),
                    "edge %d-%d (%s), consistent before (%.2f), is an outlier with it (%.2f: translation %.2f, "
                    "rotation %.2f, scale %.2f)",
                    edges[k].i, edges[k].j, PoseGraphEdgeKindName(edges[k].kind), was, now.norm(),
                    now.head<3>().norm(), now.segment<3>(3).norm(), std::abs(now(6)));
      return reject(why);
    }
  }
  if (r.mean_residual_after > o.max_mean_residual)
    return reject("the graph's edges strain to " + std::to_string(r.mean_residual_after) + " (whitened, mean) with it");
  r.accepted = true;
  r.reason = "accepted";
  return r;
}

CloseLoopResult CloseLoop(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                          const std::vector<int>& fixed, const PoseGraphEdge& new_edge, const std::vector<int>& chain,
                          const PoseGraphOptions& o, const std::vector<int>& followers) {
  return CloseLoopEdges(S_w, edges, fixed, {NewGraphEdge{new_edge, chain, followers}}, o);
}

}  // namespace rumi
