#pragma once
// Two-view monocular initialisation: a homography and an essential matrix are
// estimated in parallel, scored by their symmetric transfer errors, and the
// better explained model (score ratio) is decomposed; the motion hypothesis
// that triangulates most points in front of both cameras with enough parallax
// wins, and only when it is clearly better than the runner-up.
#include <Eigen/Core>
#include <vector>

#include "common/geometry.h"

namespace rumi {

struct TwoViewOptions {
  double sigma = 1.0;                 // keypoint noise in pixels (level 0)
  int min_triangulated = 50;
  double min_parallax_deg = 1.0;
  double homography_ratio = 0.45;     // RH above this selects the homography
  int ransac_iterations = 200;
};

struct TwoViewResult {
  Se3 T_21;                            // camera 1 -> camera 2 (|t| = 1)
  std::vector<Eigen::Vector3d> points; // in camera-1 frame, per match
  std::vector<bool> triangulated;      // per match
  char model = '?';                    // 'H' or 'E'
  double score_ratio = 0;              // RH = SH / (SH + SF)
  double parallax_deg = 0;
  int num_triangulated = 0;
  const char* rejected = "";          // why ReconstructTwoView said no (empty: accepted)
};

// p1, p2: matched undistorted pixel coordinates. K: 3x3 intrinsics.
bool ReconstructTwoView(const std::vector<Eigen::Vector2d>& p1, const std::vector<Eigen::Vector2d>& p2,
                        const Eigen::Matrix3d& K, const TwoViewOptions& o, TwoViewResult* r);

// Linear (DLT) triangulation from two 3x4 projection matrices.
Eigen::Vector3d TriangulateDlt(const Eigen::Matrix<double, 3, 4>& P1, const Eigen::Matrix<double, 3, 4>& P2,
                               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2);

}  // namespace rumi
