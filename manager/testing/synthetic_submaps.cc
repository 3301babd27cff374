#include "manager/testing/synthetic_submaps.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <unordered_map>

#include "manager/submap_index.h"

namespace rumi {

SyntheticScene MakeSyntheticScene(const SyntheticSceneOptions& o) {
  SyntheticScene s;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.fx = s.camera.fy = 500.0;
  s.camera.cx = 319.5;
  s.camera.cy = 239.5;
  std::mt19937 rng(o.seed);
  const double x_end = 0.1 * std::max(1, o.num_frames - 1);
  std::uniform_real_distribution<double> ux(-4.0, x_end + 4.0), uy(-2.5, 2.5), uz(4.0, 9.0);
  s.points.reserve(o.num_points);
  for (int i = 0; i < o.num_points; ++i) s.points.emplace_back(ux(rng), uy(rng), uz(rng));
  for (int i = 0; i < o.num_frames; ++i) {
    s.timestamps.push_back(o.first_timestamp + Timestamp(i) * o.frame_period_ns);
    const Eigen::Vector3d c(0.1 * i, 0.2 * std::sin(0.15 * i), 0.3 * std::sin(0.07 * i));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * std::sin(0.1 * i), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.05 * std::cos(0.13 * i), Eigen::Vector3d::UnitX()));
    s.T_wc.emplace_back(q, c);
  }
  return s;
}

SyntheticSubmap MakeSyntheticSubmap(const SyntheticScene& scene, const SyntheticSubmapOptions& o) {
  SyntheticSubmap out;
  Submap& m = out.submap;
  m.id = o.id;
  m.source = o.source;
  m.camera = scene.camera;
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::uniform_int_distribution<int> octave(0, std::max(0, o.max_octave));
  // Estimated poses are off the truth; keypoints come from the truth.
  auto NoisyPose = [&](const Se3& T_wc) {
    const Eigen::Vector3d w = o.pose_noise_rad * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d dc = o.pose_noise_m * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const double a = w.norm();
    const Eigen::Quaterniond dq = a > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(a, w / a)) : Eigen::Quaterniond::Identity();
    return Se3(dq * T_wc.rotation(), T_wc.translation() + dc);
  };

  const int n = int(scene.points.size());
  std::vector<char> detected(n);
  for (int i = 0; i < n; ++i) detected[i] = u01(rng) < o.detect_prob;

  // Observations per scene point; points seen by fewer than 2 keyframes are
  // not triangulated (their keypoints keep point id -1).
  struct Obs {
    int kf;
    int kp;
  };
  std::vector<std::vector<Obs>> obs(n);
  for (int f = o.first_frame; f <= o.last_frame; f += o.keyframe_step) {
    Keyframe kf;
    kf.id = int64_t(m.keyframes.size());
    kf.timestamp = scene.timestamps[f];
    kf.T_cw = o.S_lw.TransformPose(NoisyPose(scene.T_wc[f])).Inverse();
    const Se3 T_cw_world = scene.T_wc[f].Inverse();
    for (int i = 0; i < n; ++i) {
      if (!detected[i]) continue;
      Eigen::Vector2d px;
      if (!ProjectPinhole(scene.camera, T_cw_world * scene.points[i], &px)) continue;
      px += o.pixel_noise * Eigen::Vector2d(noise(rng), noise(rng));
      if (px.x() < 0 || px.y() < 0 || px.x() >= scene.camera.width || px.y() >= scene.camera.height) continue;
      obs[i].push_back({int(m.keyframes.size()), int(kf.keypoints.size())});
      kf.keypoints.emplace_back(float(px.x()), float(px.y()));
      kf.octaves.push_back(uint8_t(octave(rng)));
      kf.point_ids.push_back(i);  // scene index for now, replaced below
    }
    const int clutter = int(o.clutter_ratio * kf.keypoints.size());
    for (int c = 0; c < clutter; ++c) {
      kf.keypoints.emplace_back(float(u01(rng) * scene.camera.width), float(u01(rng) * scene.camera.height));
      kf.octaves.push_back(uint8_t(octave(rng)));
      kf.point_ids.push_back(-1);
    }
    m.keyframes.push_back(std::move(kf));
  }
  // Shuffled ids so that equal ids across submaps mean nothing.
  std::vector<int64_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::unordered_map<int, int64_t> id_of;
  for (int i = 0; i < n; ++i) {
    if (obs[i].size() < 2) continue;
    MapPoint p;
    p.id = o.point_id_offset + perm[i];
    const double sigma = o.point_noise_m * o.S_lw.scale();
    p.position = o.S_lw * scene.points[i] + sigma * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    for (const Obs& ob : obs[i]) p.observations.push_back({m.keyframes[ob.kf].id, ob.kp});
    id_of[i] = p.id;
    m.points.push_back(std::move(p));
    out.scene_point.push_back(i);
  }
  for (Keyframe& kf : m.keyframes) {
    for (int64_t& pid : kf.point_ids) {
      if (pid < 0) continue;
      const auto it = id_of.find(int(pid));
      pid = it == id_of.end() ? -1 : it->second;
    }
  }
  if (o.frame_records) {
    for (int f = o.first_frame; f <= o.last_frame; ++f) {
      FrameRecord r;
      r.timestamp = scene.timestamps[f];
      r.state = TrackingState::kTracking;
      r.submap_id = o.id;
      r.T_wc = o.S_lw.TransformPose(NoisyPose(scene.T_wc[f]));
      m.frames.push_back(r);
    }
  }
  return out;
}

void AttachPointDescriptors(SyntheticSubmap* s, size_t num_scene_points, uint32_t scene_seed, int flips,
                            uint32_t seed) {
  std::mt19937 scene_rng(scene_seed), rng(seed);
  cv::Mat scene(int(num_scene_points), 32, CV_8U);
  for (int i = 0; i < scene.rows; ++i)
    for (int j = 0; j < 32; ++j) scene.at<uint8_t>(i, j) = uint8_t(scene_rng() & 0xff);
  for (size_t i = 0; i < s->submap.points.size(); ++i) {
    cv::Mat d = scene.row(s->scene_point[i]).clone();
    for (int k = 0; k < flips; ++k) {
      const int bit = int(rng() % 256);
      d.at<uint8_t>(0, bit / 8) ^= uint8_t(1 << (bit % 8));
    }
    s->submap.points[i].descriptor = d;
  }
}

SyntheticSubmap MakeSyntheticFront(const SyntheticScene& scene, int64_t id, int first, int last, const Sim3& S,
                                   uint32_t seed) {
  SyntheticSubmapOptions o;
  o.id = id;
  o.first_frame = first;
  o.last_frame = last;
  o.keyframe_step = 2;
  o.S_lw = S;
  o.max_octave = 3;
  o.pose_noise_m = 0.01;
  o.pose_noise_rad = 0.002;
  o.point_id_offset = 1000000 * (id + 1);
  o.seed = seed;
  return MakeSyntheticSubmap(scene, o);
}

void AttachSyntheticOdometry(const SyntheticScene& scene, const Se3& T_ow, double bias, double noise_m,
                             uint32_t seed, Submap* s) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise_m);
  const Eigen::Vector3d origin = T_ow * scene.T_wc[0].translation();
  s->odometry.clear();
  for (const FrameRecord& f : s->frames) {
    const auto it = std::find(scene.timestamps.begin(), scene.timestamps.end(), f.timestamp);
    if (it == scene.timestamps.end()) continue;
    const Se3 T = T_ow * scene.T_wc[it - scene.timestamps.begin()];
    const Eigen::Vector3d p = T.translation() + bias * (T.translation() - origin) + Eigen::Vector3d(n(rng), n(rng), n(rng));
    s->odometry.push_back({f.timestamp, Se3(T.rotation(), p)});
  }
}

Sim3 RandomSim3(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double s = std::exp(std::log(3.0) * u(rng));
  Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
  if (q.norm() < 1e-3) q = Eigen::Quaterniond::Identity();
  return Sim3(s, q.normalized(), Eigen::Vector3d(5 * u(rng), 5 * u(rng), 5 * u(rng)));
}

}  // namespace rumi
