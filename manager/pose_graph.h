#pragma once
// A Sim(3) pose graph (ORB-SLAM's essential graph, for a monocular map whose
// scale drifts): nodes are poses S_wi (node frame -> world, with scale), edges
// relative measurements S_ij (node j's frame in node i's) from covisibility,
// merges, place merges, loop closures and odometry, each with a weight.
// Optimised with Ceres under a robust loss, so one wrong edge cannot bend the
// map: its residual stays large and it is reported as an outlier.
//
// docs/manager.md, "Pose graph". Loop closure (loop_closure.h) calls it for
// each verified loop.
#include <string>
#include <vector>

#include "common/geometry.h"

namespace rumi {

enum class PoseGraphEdgeKind { kCovisibility, kMerge, kPlaceMerge, kLoop, kOdometry };
const char* PoseGraphEdgeKindName(PoseGraphEdgeKind k);

struct PoseGraphEdge {
  int i = 0, j = 0;  // node indices
  Sim3 S_ij;         // measured: p_i = S_ij * p_j
  double weight = 1.0;  // information scale: 1 for a keyframe-to-keyframe edge of the map's own BA
  PoseGraphEdgeKind kind = PoseGraphEdgeKind::kCovisibility;
  // Under the robust loss, else plain least squares. Loop closure
  // (loop_closure.h) uses least squares throughout: under a robust loss a
  // long chain's cheapest answer to a large right correction is to break at
  // one edge (a real 23 s loop: one edge at 254 sigma) or to give up the
  // loop edge, rather than bend a little everywhere.
  bool robust = true;
};

struct PoseGraphOptions {
  // Robust loss on each edge's whitened residual (a 7-vector: translation in
  // node i's units / translation_sigma, rotation in rad / rotation_sigma_rad,
  // log scale / scale_sigma). An edge whose residual norm stays above
  // outlier_factor x loss_scale after the solve is reported as an outlier.
  std::string loss = "cauchy";
  double loss_scale = 1.0;
  double translation_sigma = 0.02;      // node i's units (a front submap's metres, up to scale)
  double rotation_sigma_rad = 0.01;
  double scale_sigma = 0.01;
  double outlier_factor = 3.0;
  // Graduated non-convexity: solve at loss_scale x gnc_factor^gnc_steps,
  // then at each smaller power down to loss_scale. 0: the robust loss from
  // the start (CloseLoop brings a new edge in by propagating its correction
  // first, so the graph it optimises is already nearly consistent).
  int gnc_steps = 0;
  double gnc_factor = 10.0;
  int max_iterations = 100;  // per step
  // How CloseLoop decides whether the graph takes its new edges:
  // - "edges": after the solve the edges that were there before stay
  //   consistent: their mean whitened residual at most max_mean_residual,
  //   none of them becomes an outlier (outlier_factor), and no new edge is
  //   an outlier.
  // - "chi2": the increase of the graph's squared whitened residual that
  //   the new edges bring (their innovation, chi-square with 7 degrees of
  //   freedom per new edge when the sigmas are right) at most
  //   variance_factor x its chi2_confidence quantile. One wrong edge shows
  //   as the whole graph's strain, wherever least squares put it.
  std::string consistency = "edges";
  double max_mean_residual = 3.0;
  double chi2_confidence = 0.999;
  // The sigmas' share of the real spread, squared (1: as assumed); a caller
  // that measured it from the loops the graph holds passes it here.
  double variance_factor = 1.0;
};

// The chi-square distribution's p-quantile with dof degrees of freedom
// (Wilson-Hilferty: within 1 % above 3 degrees of freedom).
double ChiSquareQuantile(int dof, double p);

// The chi2 test's bound on one edge's whitened residual (its norm).
double OneEdgeBound(const PoseGraphOptions& o);

struct PoseGraphResult {
  bool ok = false;
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;
  std::vector<int> outlier_edges;  // indices into the edges
  std::string message;             // why not ok, or Ceres's summary line
};

// A pose a solve can start from: finite, scale > 0, unit rotation (a NaN
// reaches Ceres's quaternion manifold as a failed CHECK, which aborts the
// process; the graph functions refuse it with a clear error instead).
bool ValidPose(const Sim3& S);

// Whitened residual of edge e at poses S_w (what the solver minimises).
Eigen::Matrix<double, 7, 1> PoseGraphResidual(const std::vector<Sim3>& S_w, const PoseGraphEdge& e,
                                              const PoseGraphOptions& o);

// Optimises *S_w in place; fixed nodes (at least one: the gauge, 7 degrees of
// freedom of a monocular map) keep their pose. Nodes no edge reaches keep
// theirs too.
PoseGraphResult OptimizePoseGraph(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                                  const std::vector<int>& fixed, const PoseGraphOptions& o = {});

// Spreads a correction along a chain of nodes (the path the drift
// accumulated on, from the loop's old end chain.front(), which stays, to its
// new end chain.back(), which moves to S_w_target): each node takes the share
// of its distance along the chain, rotation and scale about chain.front()'s
// position (ORB-SLAM corrects a loop's keyframes before its essential graph).
void DistributeCorrection(std::vector<Sim3>* S_w, const std::vector<int>& chain, const Sim3& S_w_target);

struct CloseLoopResult {
  bool accepted = false;
  std::string reason;         // why not, or what was done
  PoseGraphResult solve;
  double mean_residual_before = 0, mean_residual_after = 0;  // of the edges that were there before
  // The graph's squared whitened residual that the new edges brought
  // (after the solve, with them, minus before, without them), its degrees
  // of freedom (7 per new edge), and each new edge's own whitened residual
  // after the solve, in the order given.
  double chi2_increase = 0;
  int dof = 0;
  std::vector<double> new_residuals;
};

// A new loop (or merge) edge into a graph whose edges are consistent: its
// correction is spread along chain (from a node that stays, edge.j or one
// after it already in place, to edge.i, which moves), the graph
// solved, and the edge kept only if the graph stays consistent
// (PoseGraphOptions::max_mean_residual, no old edge an outlier, the new one
// not an outlier). Followers (the nodes past the moving end, off the chain,
// say the keyframes after the one that closed the loop) take the moving
// end's whole correction before the solve.
struct NewGraphEdge {
  PoseGraphEdge edge;
  std::vector<int> chain, followers;
};

// Several new edges at once: each one's correction spread in turn, then one
// solve for all, kept only if every one of them holds (a new edge an
// outlier, or an old one made one, refuses the lot: the caller then tries
// them one by one to find which). Rejected: *S_w is as it was.
CloseLoopResult CloseLoopEdges(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                               const std::vector<int>& fixed, const std::vector<NewGraphEdge>& news,
                               const PoseGraphOptions& o = {});

// One new edge: CloseLoopEdges with one.
CloseLoopResult CloseLoop(std::vector<Sim3>* S_w, const std::vector<PoseGraphEdge>& edges,
                          const std::vector<int>& fixed, const PoseGraphEdge& new_edge, const std::vector<int>& chain,
                          const PoseGraphOptions& o = {}, const std::vector<int>& followers = {});

// How a point expressed in world coordinates moves with its node: the point
// was p_w under S_w_old and is S_w_new * S_w_old^-1 * p_w now.
inline Eigen::Vector3d MoveWithNode(const Eigen::Vector3d& p_w, const Sim3& S_w_old, const Sim3& S_w_new) {
  return S_w_new * (S_w_old.Inverse() * p_w);
}

}  // namespace rumi
