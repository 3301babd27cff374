#include "common/submap.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "common/orb_extractor.h"

namespace rumi {

const char* ToString(TrackingState s) {
  switch (s) {
    case TrackingState::kInitializing: return "initializing";
    case TrackingState::kTracking: return "tracking";
    case TrackingState::kLost: return "lost";
    case TrackingState::kCoarse: return "coarse";
  }
  return "unknown";
}

size_t TrackedFrames(const Submap& s) {
  size_t n = 0;
  for (const FrameRecord& r : s.frames) n += r.state == TrackingState::kTracking ? 1 : 0;
  return n;
}

int DropWeakPoints(Submap* submap, int min_observations) {
  std::unordered_set<int64_t> weak;
  std::vector<MapPoint> kept;
  kept.reserve(submap->points.size());
  for (MapPoint& p : submap->points) {
    if (static_cast<int>(p.observations.size()) < min_observations) weak.insert(p.id);
    else kept.push_back(std::move(p));
  }
  submap->points = std::move(kept);
  if (weak.empty()) return 0;
  for (Keyframe& kf : submap->keyframes)
    for (int64_t& id : kf.point_ids)
      if (id >= 0 && weak.count(id)) id = -1;
  return static_cast<int>(weak.size());
}

Submap SubmapUntil(const Submap& s, Timestamp t) {
  Submap out;
  out.id = s.id;
  out.source = s.source;
  out.camera = s.camera;
  std::unordered_set<int64_t> kept_keyframes;
  for (const Keyframe& kf : s.keyframes)
    if (kf.timestamp <= t) {
      out.keyframes.push_back(kf);
      kept_keyframes.insert(kf.id);
    }
  std::unordered_set<int64_t> kept_points;
  for (const MapPoint& p : s.points) {
    MapPoint q;
    for (const MapPoint::Observation& o : p.observations)
      if (kept_keyframes.count(o.keyframe_id)) q.observations.push_back(o);
    if (q.observations.empty()) continue;
    q.id = p.id;
    q.position = p.position;
    q.descriptor = p.descriptor;
    kept_points.insert(p.id);
    out.points.push_back(std::move(q));
  }
  for (Keyframe& kf : out.keyframes)
    for (int64_t& id : kf.point_ids)
      if (id >= 0 && !kept_points.count(id)) id = -1;
  for (const FrameRecord& f : s.frames)
    if (f.timestamp <= t) out.frames.push_back(f);
  for (const OdometryPose& o : s.odometry)
    if (o.timestamp <= t) out.odometry.push_back(o);
  return out;
}

int CompleteTracks(Submap* submap, double max_px, double ratio) {
  const CameraIntrinsics& cam = submap->camera;
  if (!(max_px > 0) || cam.fx <= 0 || cam.fy <= 0) return 0;
  // Free keypoints per keyframe, bucketed in cells of max_px.
  auto cell_of = [&](double x, double y) {
    return (static_cast<int64_t>(std::floor(x / max_px)) << 32) ^ static_cast<uint32_t>(std::floor(y / max_px));
  };
  std::vector<std::unordered_map<int64_t, std::vector<int>>> free(submap->keyframes.size());
  std::unordered_map<int64_t, size_t> kf_index;
  for (size_t k = 0; k < submap->keyframes.size(); ++k) {
    const Keyframe& kf = submap->keyframes[k];
    kf_index[kf.id] = k;
    // Keypoints with a descriptor are ORB corners added for the manager
    // (back/keyframe_orb.h), not features the point's track was built from.
    const bool described = kf.descriptors.type() == CV_8U && kf.descriptors.cols == 32 &&
                           kf.descriptors.rows == static_cast<int>(kf.keypoints.size());
    for (size_t i = 0; i < kf.keypoints.size() && i < kf.point_ids.size(); ++i)
      if (kf.point_ids[i] < 0 && !(described && HasDescriptor(kf.descriptors.ptr<uint8_t>(static_cast<int>(i)))))
        free[k][cell_of(kf.keypoints[i].x(), kf.keypoints[i].y())].push_back(static_cast<int>(i));
  }
  struct Claim {
    double d2;
    size_t point, kf;
    int keypoint;
  };
  std::vector<Claim> claims;
  std::vector<char> observed(submap->keyframes.size());
  for (size_t p = 0; p < submap->points.size(); ++p) {
    const MapPoint& mp = submap->points[p];
    std::fill(observed.begin(), observed.end(), 0);
    for (const auto& o : mp.observations) {
      const auto it = kf_index.find(o.keyframe_id);
      if (it != kf_index.end()) observed[it->second] = 1;
    }
    for (size_t k = 0; k < submap->keyframes.size(); ++k) {
      if (observed[k] || free[k].empty()) continue;
      const Eigen::Vector3d xc = submap->keyframes[k].T_cw * mp.position;
      if (xc.z() <= 1e-9) continue;
      const double u = cam.fx * xc.x() / xc.z() + cam.cx, v = cam.fy * xc.y() / xc.z() + cam.cy;
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      const int64_t cx = static_cast<int64_t>(std::floor(u / max_px)), cy = static_cast<int64_t>(std::floor(v / max_px));
      Claim best{max_px * max_px, p, k, -1};
      double second_d2 = std::numeric_limits<double>::infinity();  // no rival in reach
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dx = -1; dx <= 1; ++dx) {
          const auto it = free[k].find(((cx + dx) << 32) ^ static_cast<uint32_t>(cy + dy));
          if (it == free[k].end()) continue;
          for (int i : it->second) {
            const Eigen::Vector2f& kp = submap->keyframes[k].keypoints[i];
            const double d2 = (kp.x() - u) * (kp.x() - u) + (kp.y() - v) * (kp.y() - v);
            if (d2 > max_px * max_px) continue;
            if (best.keypoint < 0 || d2 < best.d2) {
              if (best.keypoint >= 0) second_d2 = best.d2;
              best.d2 = d2, best.keypoint = i;
            } else if (d2 < second_d2) {
              second_d2 = d2;
            }
          }
        }
      // Two free keypoints in reach and neither clearly nearer: ambiguous.
      if (best.keypoint >= 0 && best.d2 > ratio * ratio * second_d2) continue;
      if (best.keypoint >= 0) claims.push_back(best);
    }
  }
  std::sort(claims.begin(), claims.end(), [](const Claim& a, const Claim& b) { return a.d2 < b.d2; });
  int added = 0;
  for (const Claim& c : claims) {
    Keyframe& kf = submap->keyframes[c.kf];
    if (kf.point_ids[c.keypoint] >= 0) continue;  // a closer claim took it
    kf.point_ids[c.keypoint] = submap->points[c.point].id;
    submap->points[c.point].observations.push_back({kf.id, c.keypoint});
    ++added;
  }
  return added;
}

}  // namespace rumi
