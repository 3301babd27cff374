#pragma once
// Deterministic test payloads shared by the ipc tests and the benchmark: the
// same id always gives the same window / submap, so a receiver can rebuild
// what it should have got and compare bit for bit.
#include <random>

#include "common/submap.h"
#include "common/window.h"

namespace rumi {
namespace ipc_test {

inline ImageWindow MakeWindow(int64_t id, int frames, int width = 64, int height = 48) {
  ImageWindow w;
  w.id = id;
  w.camera.width = width;
  w.camera.height = height;
  w.camera.fx = 500.0 + id;
  w.camera.k1 = -0.25;
  w.camera.p2 = 1e-4 * static_cast<double>(id % 7);
  for (int f = 0; f < frames; ++f) {
    WindowFrame wf;
    wf.timestamp = 1305031102175304000LL + id * 1000000000LL + f * 33333333LL;
    wf.front_state = f % 3 == 1 ? TrackingState::kLost : TrackingState::kTracking;
    wf.set = static_cast<SampleSet>(1 + f % 3);
    wf.front_submap_id = id * 10 + f / 4;
    wf.image.create(height, width, CV_8UC1);
    for (int y = 0; y < height; ++y) {
      uint8_t* row = wf.image.ptr<uint8_t>(y);
      for (int x = 0; x < width; ++x) row[x] = static_cast<uint8_t>(id * 31 + f * 7 + x + 3 * y);
    }
    w.frames.push_back(wf);
  }
  return w;
}

inline Submap MakeSubmap(int64_t id, int keyframes = 6, int points = 40, int frames = 30) {
  std::mt19937_64 rng(static_cast<uint64_t>(id) * 7919 + 1);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  auto pose = [&]() {
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    return Se3(q.normalized(), Eigen::Vector3d(u(rng), u(rng), u(rng)));
  };
  Submap s;
  s.id = id;
  s.source = id % 2 ? SubmapSource::kBack : SubmapSource::kFront;
  s.camera = {640, 480, 517.3 + id, 516.5, 318.6, 255.3};
  for (int k = 0; k < keyframes; ++k) {
    Keyframe kf;
    kf.id = k * 3 + id;
    kf.timestamp = 1305031102175304000LL + k * 33333333LL + id;
    kf.T_cw = pose();
    const int n = 5 + k * 3;
    for (int i = 0; i < n; ++i) {
      kf.keypoints.emplace_back(static_cast<float>(u(rng) * 100), static_cast<float>(u(rng) * 80));
      kf.octaves.push_back(static_cast<uint8_t>(i % 8));
      kf.point_ids.push_back(i % 4 == 0 ? -1 : i + 100 * k);
    }
    if (k % 3 != 2) {  // some keyframes without descriptors
      kf.descriptors.create(n, 32, CV_8UC1);
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < 32; ++c) kf.descriptors.at<uint8_t>(r, c) = static_cast<uint8_t>(rng());
    }
    s.keyframes.push_back(kf);
  }
  for (int p = 0; p < points; ++p) {
    MapPoint mp;
    mp.id = 1000 + p;
    mp.position = Eigen::Vector3d(u(rng), u(rng), u(rng));
    if (p % 5 != 0) {
      mp.descriptor.create(1, 32, CV_8UC1);
      for (int c = 0; c < 32; ++c) mp.descriptor.at<uint8_t>(0, c) = static_cast<uint8_t>(rng());
    } else if (p % 10 == 0) {
      mp.descriptor.create(1, 128, CV_32FC1);  // SIFT-like float descriptor
      for (int c = 0; c < 128; ++c) mp.descriptor.at<float>(0, c) = static_cast<float>(u(rng));
    }
    for (int o = 0; o < p % 4; ++o) mp.observations.push_back({o * 3 + id, p + o});
    s.points.push_back(mp);
  }
  for (int f = 0; f < frames; ++f) {
    FrameRecord fr;
    fr.timestamp = 1305031102175304000LL + f * 33333333LL;
    fr.state = static_cast<TrackingState>(f % 4);
    fr.submap_id = id;
    fr.T_wc = pose();
    s.frames.push_back(fr);
    if (f % 2 == 0) s.odometry.push_back({fr.timestamp, pose()});  // the pose source may skip frames
  }
  return s;
}

}  // namespace ipc_test
}  // namespace rumi
