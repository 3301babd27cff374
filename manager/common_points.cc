#include "manager/common_points.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

namespace rumi {
namespace {

// Uniform grid over the keypoints of one image, cell = search radius.
class KeypointGrid {
 public:
  KeypointGrid(const Keyframe& kf, double cell) : kf_(kf), cell_(cell) {
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      if (i >= kf.point_ids.size() || kf.point_ids[i] < 0) continue;
      cells_[Key(Cell(kf.keypoints[i].x()), Cell(kf.keypoints[i].y()))].push_back(int(i));
    }
  }
  // Nearest keypoint within radius, -1 when none.
  int Nearest(const Eigen::Vector2f& p, double radius) const {
    const int cx = Cell(p.x()), cy = Cell(p.y());
    int best = -1;
    double best_d2 = radius * radius;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const auto it = cells_.find(Key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (int i : it->second) {
          const double d2 = (kf_.keypoints[i] - p).cast<double>().squaredNorm();
          if (d2 <= best_d2) {
            best_d2 = d2;
            best = i;
          }
        }
      }
    }
    return best;
  }

 private:
  int Cell(float v) const { return int(std::floor(v / cell_)); }
  static int64_t Key(int x, int y) { return (int64_t(x) << 32) ^ int64_t(uint32_t(y)); }
  const Keyframe& kf_;
  double cell_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

}  // namespace

CommonPoints FindCommonPoints(const Submap& front, const Submap& back,
                              const std::vector<KeyframePair>& pairs, double radius_px) {
  CommonPoints out;
  std::map<std::pair<int64_t, int64_t>, int> votes;
  for (const KeyframePair& pr : pairs) {
    if (pr.front_keyframe < 0 || pr.back_keyframe < 0 || pr.front_keyframe >= int(front.keyframes.size()) ||
        pr.back_keyframe >= int(back.keyframes.size()))
      continue;
    const Keyframe& fk = front.keyframes[pr.front_keyframe];
    const Keyframe& bk = back.keyframes[pr.back_keyframe];
    const KeypointGrid grid(bk, radius_px);
    for (size_t i = 0; i < fk.keypoints.size() && i < fk.point_ids.size(); ++i) {
      if (fk.point_ids[i] < 0) continue;
      const int j = grid.Nearest(fk.keypoints[i], radius_px);
      if (j < 0) continue;
      ++votes[{fk.point_ids[i], bk.point_ids[j]}];
      ++out.keypoint_matches;
    }
  }
  // Best back point per front point, then best front point per back point.
  std::map<int64_t, PointMatch> by_front;
  for (const auto& [key, n] : votes) {
    auto it = by_front.find(key.first);
    if (it == by_front.end()) {
      by_front[key.first] = {key.first, key.second, n};
    } else {
      ++out.conflicts_dropped;
      if (n > it->second.votes) it->second = {key.first, key.second, n};  // map order: ties keep smaller id
    }
  }
  std::map<int64_t, PointMatch> by_back;
  for (const auto& [fid, m] : by_front) {
    auto it = by_back.find(m.back_point_id);
    if (it == by_back.end()) {
      by_back[m.back_point_id] = m;
    } else {
      ++out.conflicts_dropped;
      if (m.votes > it->second.votes) it->second = m;
    }
  }
  for (const auto& [bid, m] : by_back) out.matches.push_back(m);
  std::sort(out.matches.begin(), out.matches.end(),
            [](const PointMatch& a, const PointMatch& b) { return a.front_point_id < b.front_point_id; });
  return out;
}

}  // namespace rumi
