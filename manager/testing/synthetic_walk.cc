#include "manager/testing/synthetic_walk.h"

#include <cmath>

#include "manager/global_map.h"

namespace rumi {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<uint8_t> Flipped(const std::vector<uint8_t>& d, int flips, std::mt19937* rng) {
  std::vector<uint8_t> out = d;
  for (int f = 0; f < flips; ++f) {
    const int bit = int((*rng)() % 256);
    out[size_t(bit >> 3)] ^= uint8_t(1 << (bit & 7));
  }
  return out;
}

}  // namespace

std::vector<std::vector<uint8_t>> SceneDescriptors(size_t n, std::mt19937* rng) {
  std::vector<std::vector<uint8_t>> proto(400, std::vector<uint8_t>(32));
  for (auto& p : proto)
    for (auto& b : p) b = uint8_t((*rng)());
  std::vector<std::vector<uint8_t>> out(n);
  for (auto& d : out) d = Flipped(proto[(*rng)() % proto.size()], 40, rng);
  return out;
}

Walk MakeWalk(const std::vector<Eigen::Vector3d>& scene, std::vector<std::vector<uint8_t>> descriptors,
              const WalkOptions& o) {
  Walk w;
  w.scene = scene;
  w.descriptor = std::move(descriptors);
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> px(0.0, 0.7);
  Submap& s = w.submap;
  s.id = 0;
  s.source = SubmapSource::kFront;
  s.camera = {640, 480, 500, 500, 319.5, 239.5};
  const Timestamp t0 = 1000 * kNsPerSecond;
  // Drift accumulates along the walk: D_k maps true world -> estimated.
  Sim3 D;
  const Sim3 step(1.0 + o.scale_per_kf, Eigen::Quaterniond(Eigen::AngleAxisd(o.yaw_per_kf, Eigen::Vector3d::UnitZ())),
                  Eigen::Vector3d(o.shift_per_kf, 0, 0));
  std::map<std::pair<int, int>, int64_t>& point_of = w.point_of;
  std::vector<std::pair<int, double>> visits(scene.size(), {0, -1.0});  // per scene point: visit, last seen
  for (int k = 0; k < o.keyframes; ++k) {
    const double t = 0.25 * k;
    const Se3 T_wc = o.pose(t);
    w.T_wc_true.push_back(T_wc);
    w.drift.push_back(D);
    Keyframe kf;
    kf.id = k;
    kf.timestamp = t0 + int64_t(t * 1e9);
    // The estimated pose: the true one carried by the drift (rigid part).
    const Sim3 est = D * Sim3(T_wc);
    kf.T_cw = Se3(est.rotation(), est.translation()).Inverse();
    cv::Mat desc(0, 32, CV_8U);
    for (size_t p = 0; p < scene.size(); ++p) {
      const Eigen::Vector3d X_c = T_wc.Inverse() * scene[p];
      if (X_c.z() < 0.3 || X_c.z() > 8) continue;
      const double u = s.camera.fx * X_c.x() / X_c.z() + s.camera.cx, v = s.camera.fy * X_c.y() / X_c.z() + s.camera.cy;
      if (u < 0 || v < 0 || u > s.camera.width - 1 || v > s.camera.height - 1) continue;
      auto& [visit, last_seen] = visits[p];
      if (last_seen >= 0 && t - last_seen > o.forget_s) ++visit;
      last_seen = t;
      auto [it, fresh] = point_of.try_emplace({int(p), visit}, int64_t(s.points.size()));
      if (fresh) {
        MapPoint mp;
        mp.id = it->second;
        mp.position = D * scene[p];
        mp.descriptor = cv::Mat(1, 32, CV_8U, w.descriptor[p].data()).clone();
        s.points.push_back(mp);
      }
      s.points[size_t(it->second)].observations.push_back({kf.id, int32_t(kf.keypoints.size())});
      kf.keypoints.emplace_back(float(u + px(rng)), float(v + px(rng)));
      kf.octaves.push_back(0);
      kf.point_ids.push_back(it->second);
      const std::vector<uint8_t> d = Flipped(w.descriptor[p], 8, &rng);
      desc.push_back(cv::Mat(1, 32, CV_8U, const_cast<uint8_t*>(d.data())));
    }
    kf.descriptors = desc;
    s.keyframes.push_back(kf);
    FrameRecord f;
    f.timestamp = kf.timestamp;
    f.state = TrackingState::kTracking;
    f.submap_id = 0;
    f.T_wc = kf.T_cw.Inverse();
    s.frames.push_back(f);
    D = step * D;
  }
  return w;
}

double KeyframeAte(const Walk& w, const GlobalMap& map) {
  std::vector<Eigen::Vector3d> est, gt;
  for (size_t k = 0; k < w.T_wc_true.size(); ++k) {
    est.push_back(map.ToGlobal(0) * map.submap(0).keyframes[k].T_wc().translation());
    gt.push_back(w.T_wc_true[k].translation());
  }
  return UmeyamaAlign(est, gt, true).rmse;
}

std::vector<Eigen::Vector3d> Room(std::mt19937* rng) {
  std::uniform_real_distribution<double> a(0, 2 * kPi), h(-1.2, 1.2), r(3.6, 4.4);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 3000; ++i) {
    const double th = a(*rng), rr = r(*rng);
    pts.emplace_back(rr * std::cos(th), rr * std::sin(th), h(*rng));
  }
  return pts;
}

Se3 RoomPose(double t) {
  const double th = 2 * kPi * t / 24.0;
  const Eigen::Vector3d c(std::cos(th), std::sin(th), 0);
  // Looking out (z along the radius), y down, x along the walk.
  Eigen::Matrix3d R;
  R.col(2) = c;
  R.col(1) = Eigen::Vector3d(0, 0, -1);
  R.col(0) = R.col(1).cross(R.col(2));
  return Se3(R, c);
}

Walk MakeRoomWalk(WalkOptions o, uint32_t seed) {
  std::mt19937 rng(seed);
  if (!o.pose) o.pose = RoomPose;
  std::vector<Eigen::Vector3d> room = Room(&rng);
  return MakeWalk(room, SceneDescriptors(3000, &rng), o);
}

}  // namespace rumi
