#include "back/blank_cut.h"

#include <algorithm>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

namespace rumi {

BlankMeasure MeasureBlank(const cv::Mat& image) {
  BlankMeasure m;
  if (image.empty()) return m;
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  gray.convertTo(gray, CV_32F);
  // Averaged over 8 x 8 pixel blocks, sensor noise shrinks 8x, content
  // does not; and a JPEG frame's blocks are 8 x 8, so neighbours are
  // coded apart (its 4 x 4 means correlate within a block, even on noise).
  constexpr int kBlock = 8;
  cv::Mat b = gray;
  if (gray.cols >= kBlock && gray.rows >= kBlock)
    cv::resize(gray, b, cv::Size(gray.cols / kBlock, gray.rows / kBlock), 0, 0, cv::INTER_AREA);
  cv::Scalar mean, stddev;
  cv::meanStdDev(b, mean, stddev);
  m.stddev = stddev[0];
  const double var = m.stddev * m.stddev;
  if (var <= 1e-12 || b.cols < 2 || b.rows < 2) return m;
  // Lag-1 autocorrelation from neighbour differences: var(a - b) = 2 var (1 - rho).
  cv::Mat dx = b.colRange(1, b.cols) - b.colRange(0, b.cols - 1);
  cv::Mat dy = b.rowRange(1, b.rows) - b.rowRange(0, b.rows - 1);
  const double vdx = cv::norm(dx, cv::NORM_L2SQR) / double(dx.total());
  const double vdy = cv::norm(dy, cv::NORM_L2SQR) / double(dy.total());
  m.structure = 1.0 - (vdx + vdy) / (4.0 * var);
  return m;
}

bool IsBlankImage(const cv::Mat& image, double max_stddev, double max_structure) {
  if (image.empty()) return true;
  const BlankMeasure m = MeasureBlank(image);
  return m.stddev <= max_stddev && m.structure <= max_structure;
}

std::vector<std::pair<Timestamp, Timestamp>> BlankStretches(const std::vector<Timestamp>& t,
                                                            const std::vector<bool>& blank, int min_frames) {
  std::vector<std::pair<Timestamp, Timestamp>> out;
  for (size_t i = 0; i < t.size() && i < blank.size();) {
    if (!blank[i]) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j + 1 < t.size() && j + 1 < blank.size() && blank[j + 1]) ++j;
    if (int(j - i + 1) >= min_frames) out.emplace_back(t[i], t[j]);
    i = j + 1;
  }
  return out;
}

std::vector<Submap> CutAtStretches(const Submap& s, const std::vector<std::pair<Timestamp, Timestamp>>& stretches,
                                   int min_keyframes, int min_point_observations) {
  // Piece of each keyframe: how many stretches end before it.
  std::vector<int> piece(s.keyframes.size(), 0);
  for (size_t k = 0; k < s.keyframes.size(); ++k)
    for (const auto& st : stretches) piece[k] += s.keyframes[k].timestamp > st.second;
  // A stretch with no keyframe on one side cuts nothing: number the
  // non-empty pieces densely.
  std::vector<int> used(piece.begin(), piece.end());
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  if (used.size() <= 1) return {s};
  std::vector<Submap> out;
  for (int p : used) {
    Submap part = s;
    part.keyframes.clear();
    part.points.clear();
    std::unordered_map<int64_t, size_t> kf_of;  // keyframe id -> index in part
    for (size_t k = 0; k < s.keyframes.size(); ++k) {
      if (piece[k] != p) continue;
      kf_of[s.keyframes[k].id] = part.keyframes.size();
      part.keyframes.push_back(s.keyframes[k]);
    }
    if (int(part.keyframes.size()) < min_keyframes) continue;
    for (Keyframe& kf : part.keyframes) std::fill(kf.point_ids.begin(), kf.point_ids.end(), -1);
    for (const MapPoint& mp : s.points) {
      MapPoint q = mp;
      q.observations.clear();
      for (const auto& ob : mp.observations)
        if (kf_of.count(ob.keyframe_id)) q.observations.push_back(ob);
      if (int(q.observations.size()) < min_point_observations) continue;
      for (const auto& ob : q.observations) {
        Keyframe& kf = part.keyframes[kf_of.at(ob.keyframe_id)];
        if (ob.keypoint_index >= 0 && size_t(ob.keypoint_index) < kf.point_ids.size())
          kf.point_ids[size_t(ob.keypoint_index)] = q.id;
      }
      part.points.push_back(std::move(q));
    }
    out.push_back(std::move(part));
  }
  return out;
}

}  // namespace rumi
