#include "front/relocalizer.h"

#include <opencv2/calib3d.hpp>

#include "common/descriptor_match.h"
#include "front/matcher.h"
#include "front/optimizer.h"

namespace rumi {

std::vector<KeyFrame*> Relocalizer::NextCandidates(const Map& map) {
  std::vector<KeyFrame*> recent;
  for (auto it = map.keyframes.rbegin(); it != map.keyframes.rend() && recent.size() < 6; ++it)
    if (!it->second->bad) recent.push_back(it->second.get());
  std::vector<KeyFrame*> cands;
  for (size_t k = 0; k < 2 && k < recent.size(); ++k) cands.push_back(recent[(cursor_ + k) % recent.size()]);
  cursor_ += 2;
  return cands;
}

bool Relocalizer::Localize(TrackFrame* cur, KeyFrame* kf, int min_inliers, const PinholeCamera& cam,
                           const ScalePyramid& pyr) const {
  const Features& f = *cur->f;
  std::vector<int> kidx;
  for (size_t i = 0; i < kf->points.size(); ++i)
    if (kf->points[i] && !kf->points[i]->bad) kidx.push_back(static_cast<int>(i));
  if (kidx.size() < 15) return false;
  cv::Mat kd(static_cast<int>(kidx.size()), 32, CV_8U);
  for (size_t i = 0; i < kidx.size(); ++i) kf->f->descriptors.row(kidx[i]).copyTo(kd.row(static_cast<int>(i)));
  const cv::Mat fd = f.descriptors.isContinuous() ? f.descriptors : f.descriptors.clone();  // packed rows
  const auto m = MatchDescriptors(fd.ptr<uint8_t>(), size_t(fd.rows), kd.ptr<uint8_t>(),
                                  kidx.size(), {64, 0.8, /*mutual=*/true});
  if (m.size() < 15) return false;
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> img;
  for (auto [i, j] : m) {
    const Eigen::Vector3d X = kf->points[kidx[j]]->pos;
    obj.emplace_back(X.x(), X.y(), X.z());
    img.emplace_back(f.un[i].x(), f.un[i].y());
  }
  // Keypoints are undistorted already: the pinhole K and no distortion.
  cv::Mat rvec, tvec;
  std::vector<int> inl;
  if (!cv::solvePnPRansac(obj, img, cam.K(), cv::noArray(), rvec, tvec, false, 200, 4.0f, 0.99, inl, cv::SOLVEPNP_EPNP) ||
      inl.size() < 12)
    return false;
  cv::Mat Rcv;
  cv::Rodrigues(rvec, Rcv);
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) R(r, c) = Rcv.at<double>(r, c);
  cur->T_cw = Se3(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  cur->Reset(f.size());
  for (int k : inl) cur->points[m[k].first] = kf->points[kidx[m[k].second]];
  int n = OptimizePose(cur, cam, pyr);
  if (n < 10) return false;
  for (size_t i = 0; i < cur->points.size(); ++i) if (cur->outlier[i]) cur->points[i] = nullptr;
  if (n < min_inliers) {
    SearchKeyFramePoints(cur, *kf, cam, pyr, 10.0, kDescHigh, 0.9);
    n = OptimizePose(cur, cam, pyr);
  }
  return n >= min_inliers / 2;
}

}  // namespace rumi
