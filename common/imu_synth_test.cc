#include "common/imu_synth.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace rumi {
namespace {

// A body turning at 0.5 rad/s about its own z while standing still: the gyro
// reads 0.5 on z, the accelerometer reads -gravity in the body frame.
TEST(ImuSynth, ConstantTurnAtRest) {
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (int i = 0; i <= 100; ++i) {
    const double t = i * 0.033;
    poses.push_back({SecondsToNs(t), Se3(Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitZ())),
                                         Eigen::Vector3d(1, 2, 3))});
  }
  ImuSynthOptions o;
  o.gyro_noise = o.accel_noise = o.gyro_bias = o.accel_bias = 0;
  ImuSynth imu(poses, o);
  float a[3], g[3];
  imu.Sample(SecondsToNs(1.0), a, g);
  EXPECT_NEAR(g[2], 0.5, 1e-3);
  EXPECT_NEAR(g[0], 0, 1e-3);
  EXPECT_NEAR(std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), 9.81, 1e-2);
  EXPECT_NEAR(a[2], 9.81, 1e-2);  // z stays up: the specific force points up
}

TEST(ImuSynth, AcceleratingAlongXReadsTheAcceleration) {
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (int i = 0; i <= 300; ++i) {
    const double t = i * 0.01;
    poses.push_back({SecondsToNs(t), Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5 * 2.0 * t * t, 0, 0))});
  }
  ImuSynthOptions o;
  o.gyro_noise = o.accel_noise = o.gyro_bias = o.accel_bias = 0;
  ImuSynth imu(poses, o);
  float a[3], g[3];
  imu.Sample(SecondsToNs(1.5), a, g);
  EXPECT_NEAR(a[0], 2.0, 1e-3);
  EXPECT_NEAR(a[2], 9.81, 1e-3);
  // Played at half speed: a quarter of the acceleration, gravity unchanged.
  imu.Sample(SecondsToNs(1.5), a, g, 0.5);
  EXPECT_NEAR(a[0], 0.5, 1e-3);
  EXPECT_NEAR(a[2], 9.81, 1e-3);
}

// A robot-sim playing a sequence slower than recorded: the body turns slower.
TEST(ImuSynth, PlayedSlowerTurnsSlower) {
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (int i = 0; i <= 100; ++i) {
    const double t = i * 0.033;
    poses.push_back({SecondsToNs(t), Se3(Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitZ())),
                                         Eigen::Vector3d::Zero())});
  }
  ImuSynthOptions o;
  o.gyro_noise = o.accel_noise = o.gyro_bias = o.accel_bias = 0;
  ImuSynth imu(poses, o);
  float a[3], g[3];
  imu.Sample(SecondsToNs(1.0), a, g, 0.5);
  EXPECT_NEAR(g[2], 0.25, 1e-3);
}

}  // namespace
}  // namespace rumi
