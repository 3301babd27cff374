#include "manager/front_point_search.h"

#include <algorithm>
#include <cmath>

#include "common/orb_extractor.h"

namespace rumi {
namespace {

constexpr int kCell = 16;  // keypoint grid cell (px)
// ORB pyramid of front and back alike (OrbExtractorOptions defaults).
constexpr int kLevels = 8;
constexpr double kLevelFactor = 1.2;

double LevelScale(int level) { return std::pow(kLevelFactor, level); }

// Octaves may be absent (a valid submap): level 0 then.
int Octave(const Keyframe& kf, int kp) { return kp < int(kf.octaves.size()) ? kf.octaves[kp] : 0; }

}  // namespace

KeyframeSearch::KeyframeSearch(const Keyframe& kf, const CameraIntrinsics& camera, bool mapped)
    : kf_(kf), camera_(camera) {
  cols_ = std::max(1, (camera.width + kCell - 1) / kCell);
  rows_ = std::max(1, (camera.height + kCell - 1) / kCell);
  cells_.resize(size_t(cols_) * rows_);
  const cv::Mat& d = kf.descriptors;
  if (d.type() != CV_8U || d.cols != 32 || d.rows != int(kf.keypoints.size())) return;
  for (int i = 0; i < d.rows; ++i) {
    if ((kf.point_ids[i] >= 0) != mapped || !HasDescriptor(d.ptr<uint8_t>(i))) continue;
    const int cx = int(kf.keypoints[i].x()) / kCell, cy = int(kf.keypoints[i].y()) / kCell;
    if (cx < 0 || cy < 0 || cx >= cols_ || cy >= rows_) continue;
    cells_[size_t(cy) * cols_ + cx].push_back(i);
  }
}

int KeyframeSearch::Match(const Eigen::Vector3d& X, const uint8_t* desc, double max_distance, double radius_px,
                          int max_hamming, int* hamming, const Se3* T_cw) const {
  if (!desc || max_distance <= 0) return -1;
  const CameraIntrinsics& K = camera_;
  const Eigen::Vector3d c = (T_cw ? *T_cw : kf_.T_cw) * X;
  if (c.z() <= 1e-9) return -1;
  const double u = K.fx * c.x() / c.z() + K.cx, v = K.fy * c.y() / c.z() + K.cy;
  if (u < 0 || v < 0 || u >= K.width || v >= K.height) return -1;
  // ORB-SLAM's scale prediction: the level the point should appear at from
  // this distance; outside the pyramid's range it is not searched.
  const double dist = c.norm();
  if (dist > 1.2 * max_distance || dist < 0.8 * max_distance / LevelScale(kLevels - 1)) return -1;
  const int pred =
      std::clamp(int(std::ceil(std::log(max_distance / dist) / std::log(kLevelFactor))), 0, kLevels - 1);
  const double r = radius_px * LevelScale(pred);
  int best = max_hamming + 1, best_kp = -1;
  const int x0 = std::max(0, int((u - r) / kCell)), x1 = std::min(cols_ - 1, int((u + r) / kCell));
  const int y0 = std::max(0, int((v - r) / kCell)), y1 = std::min(rows_ - 1, int((v + r) / kCell));
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      for (int kp : cells_[size_t(cy) * cols_ + cx]) {
        const int level = Octave(kf_, kp);
        if (level < pred - 1 || level > pred) continue;
        const double du = kf_.keypoints[kp].x() - u, dv = kf_.keypoints[kp].y() - v;
        if (du * du + dv * dv > r * r) continue;
        const int d = DescriptorDistance(desc, kf_.descriptors.ptr<uint8_t>(kp));
        if (d < best) best = d, best_kp = kp;
      }
    }
  }
  if (hamming) *hamming = best;
  return best_kp;
}

const uint8_t* PointDescriptor(const Submap& s, const MapPoint& p, const std::unordered_map<int64_t, int>& kf_index) {
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

double PointMaxDistance(const Submap& s, const MapPoint& p, const std::unordered_map<int64_t, int>& kf_index) {
  for (const auto& ob : p.observations) {
    const auto it = kf_index.find(ob.keyframe_id);
    if (it == kf_index.end()) continue;
    const Keyframe& kf = s.keyframes[it->second];
    const int level = ob.keypoint_index >= 0 && ob.keypoint_index < int(kf.octaves.size())
                          ? std::min<int>(kf.octaves[ob.keypoint_index], kLevels - 1)
                          : 0;
    return (kf.T_cw * p.position).norm() * LevelScale(level);
  }
  return 0;
}

std::vector<CrossObservation> SearchFrontPoints(const GlobalMap& map, const ManagerOptions& o) {
  std::vector<CrossObservation> out;
  if (o.front_search_px <= 0) return out;
  const int n = int(map.size());
  for (int b = 0; b < n; ++b) {
    const Submap& B = map.submap(b);
    if (B.source != SubmapSource::kBack) continue;
    std::vector<KeyframeSearch> searches;
    searches.reserve(B.keyframes.size());
    for (const Keyframe& kf : B.keyframes) searches.emplace_back(kf, B.camera, /*mapped=*/false);
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
        max_dist[i] = S_bf.scale() * PointMaxDistance(F, F.points[i], kf_index);
      }
      for (size_t k = 0; k < B.keyframes.size(); ++k) {
        const Keyframe& kf = B.keyframes[k];
        // keypoint -> (distance, front point) of its best claim
        std::unordered_map<int, std::pair<int, int64_t>> claims;
        for (size_t i = 0; i < F.points.size(); ++i) {
          int best = 0;
          const int kp = searches[k].Match(X[i], desc[i], max_dist[i], o.front_search_px,
                                           o.front_search_max_hamming, &best);
          if (kp < 0) continue;
          const auto it = claims.find(kp);
          if (it == claims.end() || best < it->second.first) claims[kp] = {best, F.points[i].id};
        }
        for (const auto& [kp, claim] : claims)
          out.push_back({b, kf.id, kp, uint8_t(Octave(kf, kp)), f, claim.second});
      }
    }
  }
  return out;
}

}  // namespace rumi
