#include "back/keyframe_orb.h"

namespace rumi {

int AddOrbKeypoints(const cv::Mat& grey, OrbExtractor* orb, Keyframe* kf) {
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  orb->Extract(grey, &kps, &desc);
  const int n_old = static_cast<int>(kf->keypoints.size());
  const int n = n_old + static_cast<int>(kps.size());
  cv::Mat all = cv::Mat::zeros(n, 32, CV_8U);
  // Rows of keypoints already described (a second call) are kept.
  if (!kf->descriptors.empty() && kf->descriptors.rows == n_old && kf->descriptors.type() == CV_8U &&
      kf->descriptors.cols == 32)
    kf->descriptors.copyTo(all.rowRange(0, n_old));
  if (!kps.empty()) desc.copyTo(all.rowRange(n_old, n));
  kf->descriptors = all;
  kf->octaves.resize(n_old, 0);
  kf->point_ids.resize(n_old, -1);
  for (const cv::KeyPoint& k : kps) {
    kf->keypoints.emplace_back(k.pt.x, k.pt.y);
    kf->octaves.push_back(static_cast<uint8_t>(k.octave));
    kf->point_ids.push_back(-1);
  }
  return static_cast<int>(kps.size());
}

}  // namespace rumi
