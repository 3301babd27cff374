#include "back/blank_cut.h"

#include <algorithm>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

namespace rumi {

bool IsBlankImage(const cv::Mat& image, double max_stddev) {
  if (image.empty()) return true;
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  // Averaged over 4 x 4 pixel blocks, sensor noise shrinks 4x, content
  // does not: a covered generated camera 0.16, its darkest `dark` frames
  // 1.95-2.7 (0.6 and 2.3-3.7 per pixel).
  cv::Mat blocks = gray;
  if (gray.cols >= 4 && gray.rows >= 4) cv::resize(gray, blocks, cv::Size(gray.cols / 4, gray.rows / 4), 0, 0, cv::INTER_AREA);
  cv::Scalar mean, stddev;
  cv::meanStdDev(blocks, mean, stddev);
  return stddev[0] <= max_stddev;
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
