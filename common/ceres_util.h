#pragma once
// Small Ceres helpers shared by the optimisers of the front and the manager
// (header-only: common does not link Ceres; its users do).
#include <ceres/ceres.h>

#include <memory>
#include <string>

namespace rumi {

// Robust loss by name ("huber" / "cauchy"; "trivial": none, plain least
// squares) with a scale in the residual's units.
inline ceres::LossFunction* MakeRobustLoss(const std::string& name, double scale) {
  if (name == "trivial") return nullptr;
  if (name == "cauchy") return new ceres::CauchyLoss(scale);
  return new ceres::HuberLoss(scale);
}

// The one Ceres set-up of rumi's solves (the front's bundle adjustments, the
// manager's Sim(3) refinement, welding BA, pose graph): single-threaded (the
// processes share the machine with the realtime front), silent, with the
// problem's linear solver and iteration cap.
inline ceres::Solver::Options CeresSolverOptions(ceres::LinearSolverType linear_solver, int max_iterations) {
  ceres::Solver::Options so;
  so.linear_solver_type = linear_solver;
  so.max_num_iterations = max_iterations;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  return so;
}

// Pinhole projection for Ceres functors.
template <typename T>
inline void PinholeProject(double fx, double fy, double cx, double cy, const T* p, T* uv) {
  uv[0] = T(fx) * p[0] / p[2] + T(cx);
  uv[1] = T(fy) * p[1] / p[2] + T(cy);
}

}  // namespace rumi
