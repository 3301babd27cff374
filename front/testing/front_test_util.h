#pragma once
// Test helpers: a QVGA camera, the first frames of the real KITTI 03 excerpt, ATE (Sim3)
// of tracked records against the frames' ground truth.
#include <opencv2/core.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/dataset.h"
#include "common/geometry.h"
#include "common/submap.h"

namespace rumi {

// The rat robot's ESP32-CAM at 320x240 (configs/rat_robot.yaml's guess),
// with radial distortion k1 (0: none).
inline PinholeCameraOptions QvgaCamera(double k1 = 0) {
  PinholeCameraOptions c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 245;
  c.cx = 159.5;
  c.cy = 119.5;
  c.k1 = k1;
  return c;
}

struct TestSequence {
  PinholeCamera camera;
  std::vector<Frame> frames;
};

inline std::optional<TestSequence> LoadKitti(int max_frames) {
  DatasetOptions o;
  o.kind = DatasetKind::kKitti;
  o.path = std::string(RUMI_SHARED_DATA_DIR) + "/kitti03_first400";
  std::unique_ptr<FrameSource> src;
  try {
    src = OpenDataset(o);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  TestSequence s;
  s.camera = src->camera();
  Frame f;
  while (static_cast<int>(s.frames.size()) < max_frames && src->Next(&f)) s.frames.push_back(f);
  return s;
}

struct AteSummary {
  size_t pairs = 0;
  double rmse = 0, path = 0;
  double Percent() const { return path > 0 ? 100.0 * rmse / path : 1e9; }
};

// Tracked records (one submap) against ground truth by exact timestamp.
inline AteSummary Ate(const std::vector<FrameRecord>& recs, const std::vector<Frame>& frames) {
  std::map<Timestamp, Se3> gt;
  for (const Frame& f : frames)
    if (f.T_wc_gt) gt[f.timestamp] = *f.T_wc_gt;
  std::vector<Eigen::Vector3d> est, ref;
  for (const FrameRecord& r : recs) {
    if (r.state != TrackingState::kTracking) continue;
    auto it = gt.find(r.timestamp);
    if (it == gt.end()) continue;
    est.push_back(r.T_wc.translation());
    ref.push_back(it->second.translation());
  }
  AteSummary s;
  s.pairs = est.size();
  if (est.size() < 3) return s;
  const UmeyamaResult u = UmeyamaAlign(est, ref, true);
  if (!u.ok) return s;
  s.rmse = u.rmse;
  for (size_t i = 1; i < ref.size(); ++i) s.path += (ref[i] - ref[i - 1]).norm();
  return s;
}

}  // namespace rumi
