#include "common/imu_synth.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <stdexcept>

namespace rumi {

ImuSynth::ImuSynth(std::vector<std::pair<Timestamp, Se3>> poses, const ImuSynthOptions& o) : o_(o), rng_(o.seed) {
  for (const auto& [t, T] : poses) poses_.Add(t, T);
  if (poses_.size() < 2) throw std::runtime_error("imu synthesis needs at least 2 ground-truth poses");
  bg_ = Eigen::Vector3d::Constant(o_.gyro_bias);
  ba_ = Eigen::Vector3d::Constant(o_.accel_bias);
}

bool ImuSynth::covers(Timestamp t) const { return t >= poses_.first_time() && t <= poses_.last_time(); }

Se3 ImuSynth::PoseAt(Timestamp t) const { return *poses_.At(std::clamp(t, poses_.first_time(), poses_.last_time())); }

void ImuSynth::Sample(Timestamp t, float accel[3], float gyro[3], double rate) {
  const Timestamp h = 10'000'000;  // 10 ms differences: smoother than 30 Hz poses need
  // Near the trajectory's ends the window moves inside it (a clamped pose
  // would read as a jolt).
  if (poses_.last_time() - poses_.first_time() > 2 * h) t = std::clamp(t, poses_.first_time() + h, poses_.last_time() - h);
  const Se3 p0 = PoseAt(t - h), p1 = PoseAt(t), p2 = PoseAt(t + h);
  const double dt = 2e-2;
  // Body rate: R1^T R2 over 2h, as an angle-axis.
  const Eigen::AngleAxisd d(p0.rotation().conjugate() * p2.rotation());
  const Eigen::Vector3d w = d.axis() * d.angle() / dt * rate;
  const Eigen::Vector3d a_world =
      (p2.translation() - 2 * p1.translation() + p0.translation()) / (1e-2 * 1e-2) * (rate * rate);
  Eigen::Vector3d f = p1.rotation().conjugate() * (a_world - o_.gravity_world);
  std::normal_distribution<double> ng(0, o_.gyro_noise), na(0, o_.accel_noise);
  for (int i = 0; i < 3; ++i) {
    gyro[i] = static_cast<float>(w[i] + bg_[i] + ng(rng_));
    accel[i] = static_cast<float>(f[i] + ba_[i] + na(rng_));
  }
}

}  // namespace rumi
