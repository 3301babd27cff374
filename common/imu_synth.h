#pragma once
// IMU samples synthesised from a ground-truth trajectory, for the simulated
// robot: the gyro is the body angular rate between nearby poses, the
// accelerometer the specific force (acceleration minus gravity, in the body
// frame) from finite differences, each with white noise and a constant bias.
// The body is the camera (the sim has no extrinsics).
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/geometry.h"
#include "common/pose_buffer.h"
#include "common/timestamp.h"

namespace rumi {

struct ImuSynthOptions {
  double gyro_noise = 0.002;   // rad/s per sample (white)
  double accel_noise = 0.02;   // m/s^2 per sample
  double gyro_bias = 0.005;    // rad/s, each axis, constant
  double accel_bias = 0.05;    // m/s^2
  Eigen::Vector3d gravity_world = Eigen::Vector3d(0, 0, -9.81);
  uint64_t seed = 1;
};

class ImuSynth {
 public:
  // poses: T_wc in time order (at least 2).
  ImuSynth(std::vector<std::pair<Timestamp, Se3>> poses, const ImuSynthOptions& o = {});
  bool covers(Timestamp t) const;
  // The sample at t (the trajectory's time): accel, gyro in the body frame.
  // rate: the trajectory played at rate x its recorded speed (a robot
  // walking slower turns slower: rates scale by it, accelerations by its square).
  void Sample(Timestamp t, float accel[3], float gyro[3], double rate = 1.0);

 private:
  Se3 PoseAt(Timestamp t) const;  // clamped to the trajectory's span

  PoseBuffer poses_;
  ImuSynthOptions o_;
  std::mt19937_64 rng_;
  Eigen::Vector3d bg_, ba_;
};

}  // namespace rumi
