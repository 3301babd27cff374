#include "front/initializer.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace rumi {

Eigen::Vector3d TriangulateDlt(const Eigen::Matrix<double, 3, 4>& P1, const Eigen::Matrix<double, 3, 4>& P2,
                               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12) return Eigen::Vector3d::Constant(std::nan(""));
  return X.head<3>() / X(3);
}

namespace {

// ORB-SLAM-style model score: each correspondence contributes (th - chi2)
// per direction when within the chi-square threshold.
double ScoreHomography(const Eigen::Matrix3d& H21, const std::vector<Eigen::Vector2d>& p1,
                       const std::vector<Eigen::Vector2d>& p2, double sigma, std::vector<bool>* inl) {
  const Eigen::Matrix3d H12 = H21.inverse();
  const double th = 5.991, inv_s2 = 1.0 / (sigma * sigma);
  double score = 0;
  inl->assign(p1.size(), false);
  for (size_t i = 0; i < p1.size(); ++i) {
    const Eigen::Vector3d a = H21 * p1[i].homogeneous();
    const Eigen::Vector3d b = H12 * p2[i].homogeneous();
    const double c2 = (a.hnormalized() - p2[i]).squaredNorm() * inv_s2;
    const double c1 = (b.hnormalized() - p1[i]).squaredNorm() * inv_s2;
    if (c1 > th || c2 > th || !std::isfinite(c1 + c2)) continue;
    score += (th - c1) + (th - c2);
    (*inl)[i] = true;
  }
  return score;
}

double ScoreFundamental(const Eigen::Matrix3d& F21, const std::vector<Eigen::Vector2d>& p1,
                        const std::vector<Eigen::Vector2d>& p2, double sigma, std::vector<bool>* inl) {
  const double th = 3.841, th_score = 5.991, inv_s2 = 1.0 / (sigma * sigma);
  double score = 0;
  inl->assign(p1.size(), false);
  for (size_t i = 0; i < p1.size(); ++i) {
    const Eigen::Vector3d x1 = p1[i].homogeneous(), x2 = p2[i].homogeneous();
    const Eigen::Vector3d l2 = F21 * x1, l1 = F21.transpose() * x2;
    const double n2 = l2.head<2>().squaredNorm(), n1 = l1.head<2>().squaredNorm();
    if (n1 < 1e-20 || n2 < 1e-20) continue;
    const double c2 = std::pow(l2.dot(x2), 2) / n2 * inv_s2;
    const double c1 = std::pow(l1.dot(x1), 2) / n1 * inv_s2;
    if (c1 > th || c2 > th) continue;
    score += (th_score - c1) + (th_score - c2);
    (*inl)[i] = true;
  }
  return score;
}

struct Hypothesis {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

// Triangulates the inliers under (R, t); counts points in front of both
// cameras with small reprojection error. parallax_deg: a low-percentile
// parallax of the good points (robust to a few distant points).
int CheckRt(const Hypothesis& h, const std::vector<Eigen::Vector2d>& p1, const std::vector<Eigen::Vector2d>& p2,
            const std::vector<bool>& inl, const Eigen::Matrix3d& K, double sigma,
            std::vector<Eigen::Vector3d>* pts, std::vector<bool>* good, double* parallax_deg) {
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero(), P2;
  P1.leftCols<3>() = K;
  P2.leftCols<3>() = K * h.R;
  P2.col(3) = K * h.t;
  const Eigen::Vector3d O2 = -h.R.transpose() * h.t;
  const double th2 = 4.0 * sigma * sigma;
  pts->assign(p1.size(), Eigen::Vector3d::Zero());
  good->assign(p1.size(), false);
  std::vector<double> cos_par;
  int n = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    if (!inl[i]) continue;
    const Eigen::Vector3d X = TriangulateDlt(P1, P2, p1[i], p2[i]);
    if (!X.allFinite()) continue;
    const Eigen::Vector3d n1 = X, n2 = X - O2;
    const double cp = n1.dot(n2) / (n1.norm() * n2.norm());
    const Eigen::Vector3d X2 = h.R * X + h.t;
    if (cp < 0.99998 && (X.z() <= 0 || X2.z() <= 0)) continue;
    const Eigen::Vector3d u1 = K * X, u2 = K * X2;
    if ((u1.hnormalized() - p1[i]).squaredNorm() > th2) continue;
    if ((u2.hnormalized() - p2[i]).squaredNorm() > th2) continue;
    cos_par.push_back(cp);
    (*pts)[i] = X;
    ++n;
    if (cp < 0.99998) (*good)[i] = true;
  }
  if (cos_par.empty()) { *parallax_deg = 0; return 0; }
  // Cosines ascending = parallaxes descending: take the 51st largest parallax,
  // so that at least ~50 points see the required parallax.
  std::sort(cos_par.begin(), cos_par.end());
  const double c50 = cos_par[std::min<size_t>(50, cos_par.size() - 1)];
  *parallax_deg = std::acos(std::clamp(c50, -1.0, 1.0)) * 180.0 / M_PI;
  return n;
}

}  // namespace

bool ReconstructTwoView(const std::vector<Eigen::Vector2d>& p1, const std::vector<Eigen::Vector2d>& p2,
                        const Eigen::Matrix3d& K, const TwoViewOptions& o, TwoViewResult* r) {
  if (p1.size() != p2.size() || p1.size() < 8) return false;
  std::vector<cv::Point2d> c1(p1.size()), c2(p2.size());
  for (size_t i = 0; i < p1.size(); ++i) {
    c1[i] = {p1[i].x(), p1[i].y()};
    c2[i] = {p2[i].x(), p2[i].y()};
  }
  cv::Mat Kcv;
  cv::eigen2cv(K, Kcv);
  const double th = std::sqrt(5.991) * o.sigma;
  cv::Mat Hcv = cv::findHomography(c1, c2, cv::RANSAC, th, cv::noArray(), o.ransac_iterations, 0.99);
  // USAC_ACCURATE: locally optimised RANSAC, a better model than a minimal sample.
  cv::Mat Ecv = cv::findEssentialMat(c1, c2, Kcv, cv::USAC_ACCURATE, 0.999, std::sqrt(3.841) * o.sigma);
  std::vector<bool> inl_h, inl_f;
  double sh = 0, sf = 0;
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity(), E = Eigen::Matrix3d::Zero();
  if (Hcv.rows == 3 && Hcv.cols == 3) {
    cv::cv2eigen(Hcv, H);
    sh = ScoreHomography(H, p1, p2, o.sigma, &inl_h);
  }
  if (Ecv.rows == 3 && Ecv.cols == 3) {  // several solutions stacked: take the first
    cv::cv2eigen(Ecv.rowRange(0, 3), E);
    const Eigen::Matrix3d Kinv = K.inverse();
    sf = ScoreFundamental(Kinv.transpose() * E * Kinv, p1, p2, o.sigma, &inl_f);
  }
  if (sh + sf <= 0) { r->rejected = "no model"; return false; }
  const double rh = sh / (sh + sf);
  r->score_ratio = rh;
  std::vector<Hypothesis> hyps;
  const std::vector<bool>* inl = nullptr;
  if (rh > o.homography_ratio) {
    r->model = 'H';
    inl = &inl_h;
    std::vector<cv::Mat> Rs, ts, ns;
    cv::decomposeHomographyMat(Hcv, Kcv, Rs, ts, ns);
    for (size_t i = 0; i < Rs.size(); ++i) {
      Hypothesis h;
      cv::cv2eigen(Rs[i], h.R);
      Eigen::Vector3d t;
      cv::cv2eigen(ts[i], t);
      if (t.norm() < 1e-9) continue;
      h.t = t.normalized();
      hyps.push_back(h);
    }
  } else {
    r->model = 'E';
    inl = &inl_f;
    cv::Mat R1, R2, t;
    cv::decomposeEssentialMat(Ecv.rowRange(0, 3), R1, R2, t);
    Eigen::Matrix3d eR1, eR2;
    Eigen::Vector3d et;
    cv::cv2eigen(R1, eR1);
    cv::cv2eigen(R2, eR2);
    cv::cv2eigen(t, et);
    hyps = {{eR1, et}, {eR1, -et}, {eR2, et}, {eR2, -et}};
  }
  int num_inl = 0;
  for (bool b : *inl) num_inl += b ? 1 : 0;
  int best = -1, best_n = 0, second_n = 0;
  std::vector<Eigen::Vector3d> best_pts;
  std::vector<bool> best_good;
  double best_par = 0;
  for (size_t i = 0; i < hyps.size(); ++i) {
    std::vector<Eigen::Vector3d> pts;
    std::vector<bool> good;
    double par = 0;
    const int n = CheckRt(hyps[i], p1, p2, *inl, K, o.sigma, &pts, &good, &par);
    if (n > best_n) {
      second_n = best_n;
      best_n = n; best = static_cast<int>(i);
      best_pts = std::move(pts); best_good = std::move(good); best_par = par;
    } else if (n > second_n) {
      second_n = n;
    }
  }
  if (best < 0) { r->rejected = "no hypothesis"; return false; }
  const int min_good = std::max(o.min_triangulated, static_cast<int>(0.6 * num_inl));
  r->parallax_deg = best_par;
  r->num_triangulated = best_n;
  if (best_n < min_good) { r->rejected = "few good points"; return false; }
  if (second_n > 0.75 * best_n) { r->rejected = "ambiguous motion"; return false; }
  if (best_par < o.min_parallax_deg) { r->rejected = "low parallax"; return false; }
  r->T_21 = Se3(hyps[best].R, hyps[best].t);
  r->points = std::move(best_pts);
  r->triangulated = std::move(best_good);
  r->parallax_deg = best_par;
  r->num_triangulated = 0;
  for (bool b : r->triangulated) r->num_triangulated += b ? 1 : 0;
  return r->num_triangulated >= o.min_triangulated;
}

}  // namespace rumi
