#include "common/imu.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/imu_synth.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle();
}

TEST(GyroIntegrator, AConstantTurnIntegratesToItsAngle) {
  GyroIntegrator g;
  for (int i = 0; i <= 200; ++i) g.Add(SecondsToNs(i * 0.005), Eigen::Vector3d(0, 0, 0.8));
  const auto R = g.Rotation(SecondsToNs(0.1234), SecondsToNs(0.6234));
  ASSERT_TRUE(R.has_value());
  const Eigen::Quaterniond want(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  EXPECT_LT(AngleBetween(*R, want), 1e-9);
  // The bias is taken off the rate.
  const auto Rb = g.Rotation(SecondsToNs(0.1), SecondsToNs(0.6), Eigen::Vector3d(0, 0, 0.2));
  ASSERT_TRUE(Rb.has_value());
  EXPECT_LT(AngleBetween(*Rb, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))), 1e-9);
  // An empty span is the identity.
  EXPECT_LT(AngleBetween(*g.Rotation(SecondsToNs(0.3), SecondsToNs(0.3)), Eigen::Quaterniond::Identity()), 1e-12);
}

TEST(GyroIntegrator, NoRotationWhereSamplesAreMissing) {
  GyroIntegrator g;  // max_gap_s 0.05
  for (int i = 0; i <= 40; ++i) g.Add(SecondsToNs(i * 0.005), Eigen::Vector3d(0.1, 0, 0));
  for (int i = 60; i <= 100; ++i) g.Add(SecondsToNs(i * 0.005), Eigen::Vector3d(0.1, 0, 0));
  EXPECT_TRUE(g.Rotation(SecondsToNs(0.05), SecondsToNs(0.19)).has_value());
  EXPECT_FALSE(g.Rotation(SecondsToNs(0.15), SecondsToNs(0.35)).has_value()) << "a 100 ms hole inside";
  EXPECT_FALSE(g.Rotation(SecondsToNs(0.45), SecondsToNs(0.7)).has_value()) << "past the newest sample";
  EXPECT_FALSE(g.Rotation(SecondsToNs(-0.2), SecondsToNs(0.1)).has_value()) << "before the oldest sample";
  EXPECT_FALSE(g.Rotation(SecondsToNs(0.1), SecondsToNs(0.05)).has_value()) << "backwards";
  // Out-of-order and non-finite samples are ignored.
  const size_t n = g.size();
  g.Add(SecondsToNs(0.1), Eigen::Vector3d(9, 9, 9));
  g.Add(SecondsToNs(0.6), Eigen::Vector3d(std::nan(""), 0, 0));
  EXPECT_EQ(g.size(), n);
}

TEST(GyroIntegrator, FollowsASynthesisedTrajectoryWithAVaryingAxis) {
  // A camera turning about a changing axis; the synthesised gyro (no noise,
  // no bias) integrated over a frame interval gives the frames' rotation.
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (int i = 0; i <= 90; ++i) {
    const double t = i / 30.0;
    const Eigen::Quaterniond q = Eigen::AngleAxisd(0.9 * t, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(0.3 * std::sin(2 * t), Eigen::Vector3d::UnitX());
    poses.push_back({SecondsToNs(t), Se3(q, Eigen::Vector3d(t, 0, 0))});
  }
  ImuSynthOptions o;
  o.gyro_noise = o.accel_noise = o.gyro_bias = o.accel_bias = 0;
  ImuSynth synth(poses, o);
  GyroIntegrator g;
  for (int k = 0; k <= 600; ++k) {
    const Timestamp t = SecondsToNs(k * 0.005);
    float a[3], w[3];
    synth.Sample(t, a, w);
    g.Add(t, Eigen::Vector3d(w[0], w[1], w[2]));
  }
  for (int i : {10, 40, 70}) {
    const auto R = g.Rotation(poses[i].first, poses[i + 1].first);
    ASSERT_TRUE(R.has_value());
    const Eigen::Quaterniond want = poses[i].second.rotation().conjugate() * poses[i + 1].second.rotation();
    EXPECT_LT(AngleBetween(*R, want), 0.03 * 0.9 / 30) << "frame " << i;  // within 3 % of the turn
  }
}

TEST(ImuCsv, RoundTripsAndNamesTheBadLine) {
  const TempDir tmp;
  const std::filesystem::path dir = tmp.Create();
  std::vector<ImuSample> v(3);
  for (int i = 0; i < 3; ++i) {
    v[i].t = 1'000'000'000'000 + i * 5'000'000;
    v[i].gyro = Eigen::Vector3d(0.1 * i, -0.2, 0.3);
    v[i].accel = Eigen::Vector3d(0, 0, 9.81 + i);
  }
  const std::string path = (dir / "imu.csv").string();
  std::ofstream(path) << FormatImuCsv(v, "test");
  const std::vector<ImuSample> r = ReadImuCsv(path);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[2].t, v[2].t);
  EXPECT_NEAR(r[2].gyro.x(), 0.2, 1e-9);
  EXPECT_NEAR(r[1].accel.z(), 10.81, 1e-9);

  auto expect_error = [&](const std::string& text, const std::string& want) {
    std::ofstream(path) << text;
    try {
      ReadImuCsv(path);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  expect_error("#t\n1000,0,0,0,0,0,9.8\n1000,0,0,0,0,0,9.8\n", "imu.csv:3: timestamps must increase");
  expect_error("1000,0,0,0,0,0\n", "imu.csv:1: expected 7 columns");
  expect_error("1000,0,x,0,0,0,9.8\n", "imu.csv:1: not a number");
  expect_error("1000,0,nan,0,0,0,9.8\n", "imu.csv:1: a value is not finite");
  expect_error("# nothing\n", "no IMU samples");
  std::filesystem::remove_all(dir);
  expect_error("", "IMU file not found");
}

}  // namespace
}  // namespace rumi
