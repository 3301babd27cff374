#pragma once
// Front optimisers: pose-only Gauss-Newton (hand-written 6x6 normal equations
// with a Huber kernel, for the per-frame path) and local bundle adjustment in
// Ceres (mapping thread).
#include <atomic>
#include <vector>

#include "front/map.h"

namespace rumi {

// Refines f->T_cw from its point matches; marks outliers (chi2 > 5.991 on the
// final round). Returns the number of inliers.
int OptimizePose(TrackFrame* f, const PinholeCamera& cam, const ScalePyramid& pyr);

struct LocalBaProblem {
  // Filled by Collect (map locked), solved unlocked, written back locked.
  std::vector<KeyFrame*> local, fixed;
  std::vector<Landmark*> points;
  struct Obs { int kf; int pt; Eigen::Vector2d uv; int level; KeyFrame* k; int idx; };
  std::vector<Obs> obs;
  std::vector<Eigen::Vector4d> q;   // x y z w per keyframe (local then fixed)
  std::vector<Eigen::Vector3d> t;
  std::vector<Eigen::Vector3d> x;
};

// Local BA around kf: kf + its covisible keyframes (up to max_local) are free,
// other keyframes seeing their points (up to max_fixed) fixed.
void CollectLocalBa(KeyFrame* kf, int max_local, int max_fixed, LocalBaProblem* pb);
// Solves in place; stops early when *abort becomes true. Returns whether the
// result should be applied (usable, cost not increased).
bool SolveLocalBa(LocalBaProblem* pb, const PinholeCamera& cam, const ScalePyramid& pyr, int iterations, double max_time_s,
                  const std::atomic<bool>* abort);
// Writes poses/points back and drops observations with large errors.
void ApplyLocalBa(const LocalBaProblem& pb, const PinholeCamera& cam, const ScalePyramid& pyr);

// Full BA over all keyframes (used after initialisation); first keyframe fixed.
void GlobalBa(Map* map, const PinholeCamera& cam, const ScalePyramid& pyr, int iterations);

}  // namespace rumi
