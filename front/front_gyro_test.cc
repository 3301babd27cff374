// The gyro prior on the real KITTI excerpt, with an IMU synthesised from its
// ground truth (noise, an uncalibrated bias, the IMU turned against the
// camera): a gap in the frames bridged, the bias learnt, a gyro that
// disagrees with vision switched off without costing tracking.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "common/testing/require.h"
#include "common/imu_synth.h"
#include "front/front.h"
#include "front/testing/front_test_util.h"

namespace rumi {
namespace {

// The IMU sits turned against the camera (imu_T_bc) and reads
// bias + noise on every axis, 200 Hz over the whole excerpt.
struct SynthImu {
  Se3 T_bc = Se3(Eigen::Quaterniond(Eigen::AngleAxisd(2.0, Eigen::Vector3d(0.3, -1, 0.5).normalized())),
                 Eigen::Vector3d(0.05, 0, -0.1));
  Eigen::Vector3d bias = Eigen::Vector3d(0.04, -0.03, 0.05);
};

std::vector<ImuSample> MakeImu(const TestSequence& seq, const SynthImu& s) {
  std::vector<std::pair<Timestamp, Se3>> poses;
  for (const Frame& f : seq.frames) poses.push_back({f.timestamp, *f.T_wc_gt});
  ImuSynthOptions o;
  o.gyro_bias = o.accel_bias = 0;
  ImuSynth synth(poses, o);  // camera-frame rates, noise only
  std::vector<ImuSample> out;
  for (Timestamp t = poses.front().first; t <= poses.back().first; t += 5'000'000) {
    float a[3], g[3];
    synth.Sample(t, a, g);
    ImuSample x;
    x.t = t;
    x.gyro = s.T_bc.rotation() * Eigen::Vector3d(g[0], g[1], g[2]) + s.bias;
    out.push_back(x);
  }
  return out;
}

struct Played {
  std::vector<FrameRecord> records;
  Front::GyroStats gyro;
  size_t submaps = 0;
};

// Frames [skip_from, skip_to) never reach the front (lost on the link); the
// IMU keeps coming. gyro: how the samples are turned into what the front hears.
Played Play(const TestSequence& seq, int frames, int skip_from, int skip_to, FrontOptions o,
         const std::vector<ImuSample>& imu) {
  o.local_mapping_thread = false;
  o.local_ba_max_time_s = 60;  // no wall-clock cut: same result on a loaded CI machine
  Front front(o, seq.camera);
  ImuReplay replay(imu);
  Played r;
  for (int i = 0; i < frames; ++i) {
    if (i >= skip_from && i < skip_to) continue;
    for (const ImuSample& s : replay.Until(seq.frames[i].timestamp)) front.AddImu(s.t, s.gyro);
    r.records.push_back(front.Track(seq.frames[i].timestamp, seq.frames[i].image));
  }
  front.Finish();
  r.gyro = front.gyro_stats();
  r.submaps = front.FinishedSubmaps().size();
  return r;
}

TEST(FrontGyro, BridgesAGapInTheFramesAndLearnsTheBias) {
  auto seq = LoadKitti(80);
  RUMI_REQUIRE(seq, "KITTI excerpt not found");
  const SynthImu s;
  FrontOptions o;
  o.imu_T_bc = s.T_bc;
  // 0.5 s of frames lost on the link (about 3.5 m driven).
  const Played run = Play(*seq, 80, 36, 41, o, MakeImu(*seq, s));
  EXPECT_EQ(run.gyro.bridged, 1);
  EXPECT_FALSE(run.gyro.disabled);
  EXPECT_EQ(run.submaps, 1u) << "one submap: no relocalisation, no restart";
  int tracked_after = 0, after = 0;
  for (const FrameRecord& r : run.records)
    if (r.timestamp > seq->frames[36].timestamp) {
      ++after;
      tracked_after += r.state == TrackingState::kTracking;
    }
  EXPECT_EQ(tracked_after, after) << "every frame after the gap tracked, the first one included";
  EXPECT_GT(run.gyro.predicted, 60);
  const AteSummary ate = Ate(run.records, seq->frames);
  EXPECT_GE(ate.pairs, 65u);
  EXPECT_LT(ate.Percent(), 1.5);
  // The bias was learnt from the tracked rotation (a car turns little: about
  // 0.01 rad/s of it stays).
  EXPECT_GT(run.gyro.bias_updates, 30);
  EXPECT_LT((run.gyro.bias - s.bias).norm(), 0.015) << run.gyro.bias.transpose();
}

TEST(FrontGyro, AGyroThatDisagreesWithVisionIsSwitchedOff) {
  auto seq = LoadKitti(60);
  RUMI_REQUIRE(seq, "KITTI excerpt not found");
  // A broken sensor: a steady 1.5 rad/s roll that never happened.
  std::vector<ImuSample> imu = MakeImu(*seq, SynthImu());
  for (ImuSample& x : imu) x.gyro = Eigen::Vector3d(1.5, 0, 0);
  const Played broken = Play(*seq, 60, -1, -1, FrontOptions(), imu);
  FrontOptions off;
  off.gyro_prior = false;
  const Played none = Play(*seq, 60, -1, -1, off, imu);
  EXPECT_TRUE(broken.gyro.disabled);
  EXPECT_EQ(none.gyro.predicted, 0);
  auto tracked = [](const Played& r) {
    int n = 0;
    for (const FrameRecord& x : r.records) n += x.state == TrackingState::kTracking;
    return n;
  };
  EXPECT_GE(tracked(broken), tracked(none) - 2) << "the broken gyro cost tracking";
  EXPECT_EQ(broken.submaps, none.submaps);
}

}  // namespace
}  // namespace rumi
