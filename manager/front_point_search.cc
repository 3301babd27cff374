#include "manager/front_point_search.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "common/orb_extractor.h"

namespace rumi {
namespace {

constexpr int kCell = 16;  // keypoint grid cell (px)
// ORB pyramid of front and back alike (OrbExtractorOptions defaults).
constexpr int kLevels = 8;

// ORB keypoints of one keyframe bucketed by position.
struct KeypointGrid {
  int cols = 0, rows = 0;
  std::vector<std::vector<int>> cells;
  KeypointGrid(const Keyframe& kf, int width, int height) {
    cols = std::max(1, (width + kCell - 1) / kCell);
    rows = std::max(1, (height + kCell - 1) / kCell);
    cells.resize(size_t(cols) * rows);
    const cv::Mat& d = kf.descriptors;
    if (d.type() != CV_8U || d.cols != 32 || d.rows != int(kf.keypoints.size())) return;
    for (int i = 0; i < d.rows; ++i) {
      if (kf.point_ids[i] >= 0 || !HasDescriptor(d.ptr<uint8_t>(i))) continue;
      const int cx = int(kf.keypoints[i].x()) / kCell, cy = int(kf.keypoints[i].y()) / kCell;
      if (cx < 0 || cy < 0 || cx >= cols || cy >= rows) continue;
      cells[size_t(cy) * cols + cx].push_back(i);
    }
  }
};

// Octaves may be absent (a valid submap): level 0 then.
int Octave(const Keyframe& kf, int kp) { return kp < int(kf.octaves.size()) ? kf.octaves[kp] : 0; }

const uint8_t* PointDescriptor(const Submap& s, const MapPoint& p,
                               const std::unordered_map<int64_t, int>& kf_index) {
  if (p.descriptor.type() == CV_8U && p.descriptor.cols == 32 && p.descriptor.rows >= 1)
    return p.descriptor.ptr<uint8_t>(0);
  for (const auto& ob : p.observations) {  // no representative: any observation
    const auto it = kf_index.find(ob.keyframe_id);
    if (it == kf_index.end()) continue;
    const cv::Mat& d = s.keyframes[it->second].descriptors;
    if (d.type() == CV_8U && d.cols == 32 && ob.keypoint_index >= 0 && ob.keypoint_index < d.rows)
      return d.ptr<uint8_t>(ob.keypoint_index);
  }
  return nullptr;
}

// ORB-SLAM's scale-invariance distance: the distance from its first observing
// keyframe times that observation's level scale (0 when unknown).
double MaxDistance(const Submap& s, const MapPoint& p, const std::unordered_map<int64_t, int>& kf_index,
                   const double* level_scale) {
  for (const auto& ob : p.observations) {
    const auto it = kf_index.find(ob.keyframe_id);
    if (it == kf_index.end()) continue;
    const Keyframe& kf = s.keyframes[it->second];
    const int level = ob.keypoint_index >= 0 && ob.keypoint_index < int(kf.octaves.size())
                          ? std::min<int>(kf.octaves[ob.keypoint_index], kLevels - 1)
                          : 0;
    return (kf.T_cw * p.position).norm() * level_scale[level];
  }
  return 0;
}

}  // namespace

std::vector<CrossObservation> SearchFrontPoints(const GlobalMap& map, const ManagerOptions& o) {
  std::vector<CrossObservation> out;
  if (o.front_search_px <= 0) return out;
  const int n = int(map.size());
  double level_scale[kLevels];
  level_scale[0] = 1.0;
  for (int l = 1; l < kLevels; ++l) level_scale[l] = level_scale[l - 1] * 1.2;
  const double max_r = o.front_search_px * level_scale[kLevels - 1];
  for (int b = 0; b < n; ++b) {
    const Submap& B = map.submap(b);
    if (B.source != SubmapSource::kBack) continue;
    const CameraIntrinsics& K = B.camera;
    std::vector<KeypointGrid> grids;
    grids.reserve(B.keyframes.size());
    for (const Keyframe& kf : B.keyframes) grids.emplace_back(kf, K.width, K.height);
    for (int f = 0; f < n; ++f) {
      const Submap& F = map.submap(f);
      if (F.source == SubmapSource::kBack || !map.Connected(b, f)) continue;
      const Sim3 S_bf = map.ToGlobal(b).Inverse() * map.ToGlobal(f);
      std::unordered_map<int64_t, int> kf_index;
      for (size_t i = 0; i < F.keyframes.size(); ++i) kf_index[F.keyframes[i].id] = int(i);
      std::vector<Eigen::Vector3d> X(F.points.size());
      std::vector<const uint8_t*> desc(F.points.size());
      std::vector<double> max_dist(F.points.size(), 0.0);  // back-frame units
      for (size_t i = 0; i < F.points.size(); ++i) {
        X[i] = S_bf * F.points[i].position;
        desc[i] = PointDescriptor(F, F.points[i], kf_index);
        max_dist[i] = S_bf.scale() * MaxDistance(F, F.points[i], kf_index, level_scale);
      }
      for (size_t k = 0; k < B.keyframes.size(); ++k) {
        const Keyframe& kf = B.keyframes[k];
        const KeypointGrid& g = grids[k];
        // keypoint -> (distance, front point) of its best claim
        std::unordered_map<int, std::pair<int, int64_t>> claims;
        for (size_t i = 0; i < F.points.size(); ++i) {
          if (!desc[i]) continue;
          const Eigen::Vector3d c = kf.T_cw * X[i];
          if (c.z() <= 1e-9) continue;
          const double u = K.fx * c.x() / c.z() + K.cx, v = K.fy * c.y() / c.z() + K.cy;
          if (u < 0 || v < 0 || u >= K.width || v >= K.height) continue;
          // ORB-SLAM's scale prediction: the level the point should appear at
          // from this distance; outside the pyramid's range it is not searched.
          const double dist = c.norm();
          if (max_dist[i] <= 0 || dist > 1.2 * max_dist[i] || dist < 0.8 * max_dist[i] / level_scale[kLevels - 1])
            continue;
          const int pred = std::clamp(int(std::ceil(std::log(max_dist[i] / dist) / std::log(1.2))), 0, kLevels - 1);
          const double r = o.front_search_px * level_scale[pred];
          int best = o.front_search_max_hamming + 1, best_kp = -1;
          const int x0 = std::max(0, int((u - max_r) / kCell)), x1 = std::min(g.cols - 1, int((u + max_r) / kCell));
          const int y0 = std::max(0, int((v - max_r) / kCell)), y1 = std::min(g.rows - 1, int((v + max_r) / kCell));
          for (int cy = y0; cy <= y1; ++cy) {
            for (int cx = x0; cx <= x1; ++cx) {
              for (int kp : g.cells[size_t(cy) * g.cols + cx]) {
                const int level = Octave(kf, kp);
                if (level < pred - 1 || level > pred) continue;
                const double du = kf.keypoints[kp].x() - u, dv = kf.keypoints[kp].y() - v;
                if (du * du + dv * dv > r * r) continue;
                const int dist = DescriptorDistance(desc[i], kf.descriptors.ptr<uint8_t>(kp));
                if (dist < best) best = dist, best_kp = kp;
              }
            }
          }
          if (best_kp < 0) continue;
          const auto it = claims.find(best_kp);
          if (it == claims.end() || best < it->second.first) claims[best_kp] = {best, F.points[i].id};
        }
        for (const auto& [kp, claim] : claims)
          out.push_back({b, kf.id, kp, uint8_t(Octave(kf, kp)), f, claim.second});
      }
    }
  }
  return out;
}

}  // namespace rumi
