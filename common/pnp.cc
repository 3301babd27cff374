#include "common/pnp.h"

#include <opencv2/calib3d.hpp>

namespace rumi {

bool PnpRansacFromGuess(const std::vector<cv::Point3f>& points, const std::vector<cv::Point2f>& keypoints,
                        const CameraIntrinsics& K, const Eigen::Matrix3d& R0, const Eigen::Vector3d& t0,
                        double threshold_px, Se3* T_cw, std::vector<int>* inliers) {
  const cv::Mat Kcv = (cv::Mat_<double>(3, 3) << K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
  cv::Mat R0cv(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R0cv.at<double>(r, c) = R0(r, c);
    tvec.at<double>(r) = t0(r);
  }
  cv::Rodrigues(R0cv, rvec);
  if (!cv::solvePnPRansac(points, keypoints, Kcv, cv::noArray(), rvec, tvec, /*useExtrinsicGuess=*/true, 100,
                          float(threshold_px), 0.99, *inliers, cv::SOLVEPNP_ITERATIVE))
    return false;
  cv::Mat Rcv;
  cv::Rodrigues(rvec, Rcv);
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = Rcv.at<double>(r, c);
  *T_cw = Se3(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  return true;
}

}  // namespace rumi
