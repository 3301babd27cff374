#include "manager/common_points.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "manager/submap_index.h"

namespace rumi {
namespace {

// Uniform grid over 2D points (those with ids[i] >= 0), cell = search radius.
class KeypointGrid {
 public:
  KeypointGrid(const std::vector<Eigen::Vector2f>& pts, const std::vector<int64_t>& ids, double cell)
      : pts_(pts), cell_(cell) {
    for (size_t i = 0; i < pts.size(); ++i) {
      if (i >= ids.size() || ids[i] < 0) continue;
      cells_[Key(Cell(pts[i].x()), Cell(pts[i].y()))].push_back(int(i));
    }
  }
  explicit KeypointGrid(const Keyframe& kf, double cell) : KeypointGrid(kf.keypoints, kf.point_ids, cell) {}
  // Nearest point within radius, -1 when none; second: squared distance of the
  // runner-up within the radius (infinity when none).
  int Nearest(const Eigen::Vector2f& p, double radius, double* second_d2 = nullptr, double* best_out = nullptr) const {
    const int cx = Cell(p.x()), cy = Cell(p.y());
    int best = -1;
    const double r2 = radius * radius;
    double best_d2 = r2, second = std::numeric_limits<double>::infinity();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const auto it = cells_.find(Key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (int i : it->second) {
          const double d2 = (pts_[i] - p).cast<double>().squaredNorm();
          if (d2 > r2) continue;
          if (best < 0 || d2 < best_d2) {
            if (best >= 0) second = best_d2;
            best_d2 = d2;
            best = i;
          } else if (d2 < second) {
            second = d2;
          }
        }
      }
    }
    if (second_d2) *second_d2 = second;
    if (best_out) *best_out = best_d2;
    return best;
  }

 private:
  int Cell(float v) const { return int(std::floor(v / cell_)); }
  static int64_t Key(int x, int y) { return (int64_t(x) << 32) ^ int64_t(uint32_t(y)); }
  const std::vector<Eigen::Vector2f>& pts_;
  double cell_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

using Votes = std::map<std::pair<int64_t, int64_t>, int>;

// Keypoint matches of one frame pair into votes.
void VoteFramePair(const Submap& front, const Submap& back, const SubmapIndex& fi, const FramePair& fp,
                   double radius_px, double ratio, Votes* votes, int* keypoint_matches) {
  if (fp.front_frame < 0 || fp.front_frame >= int(front.frames.size()) || fp.back_keyframe < 0 ||
      fp.back_keyframe >= int(back.keyframes.size()))
    return;
  const Se3 T_cw = front.frames[fp.front_frame].T_wc.Inverse();
  const CameraIntrinsics& cam = front.camera;
  std::unordered_set<int64_t> seen;
  std::vector<Eigen::Vector2f> proj;
  std::vector<int64_t> ids;
  for (int k : fp.front_keyframes) {
    if (k < 0 || k >= int(front.keyframes.size())) continue;
    for (int64_t id : front.keyframes[k].point_ids) {
      if (id < 0 || !seen.insert(id).second) continue;
      const int p = fi.Point(id);
      if (p < 0) continue;
      Eigen::Vector2d px;
      if (!ProjectPinhole(cam, T_cw * front.points[p].position, &px)) continue;
      if (px.x() < 0 || px.y() < 0 || px.x() >= cam.width || px.y() >= cam.height) continue;
      proj.push_back(px.cast<float>());
      ids.push_back(id);
    }
  }
  const Keyframe& bk = back.keyframes[fp.back_keyframe];
  const KeypointGrid grid(proj, ids, radius_px);
  for (size_t j = 0; j < bk.keypoints.size() && j < bk.point_ids.size(); ++j) {
    if (bk.point_ids[j] < 0) continue;
    double d1 = 0, d2 = 0;
    const int i = grid.Nearest(bk.keypoints[j], radius_px, &d2, &d1);
    if (i < 0) continue;
    if (std::isfinite(d2) && std::sqrt(d1) >= ratio * std::sqrt(d2)) continue;  // competing projections
    ++(*votes)[{ids[i], bk.point_ids[j]}];
    ++*keypoint_matches;
  }
}

}  // namespace

CommonPoints FindCommonPoints(const Submap& front, const Submap& back,
                              const std::vector<KeyframePair>& pairs, double radius_px) {
  return FindCommonPoints(front, back, pairs, {}, radius_px);
}

CommonPoints FindCommonPoints(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                              const std::vector<FramePair>& frame_pairs, double radius_px, double ratio) {
  CommonPoints out;
  Votes votes;
  if (!frame_pairs.empty()) {
    const SubmapIndex fi(front);
    for (const FramePair& fp : frame_pairs) VoteFramePair(front, back, fi, fp, radius_px, ratio, &votes, &out.keypoint_matches);
  }
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
