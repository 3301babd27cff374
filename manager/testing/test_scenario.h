#pragma once
// The three-submap scenario shared by the manager's tests (header-only, test
// code): front A (frames 0-40), back (30-80), front B (70-110), each in its
// own random Sim(3) frame; frames 41-69 are lost by the front. And the
// helpers of the tests that write and read the manager's files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/testing/temp_dir.h"
#include "common/timestamp.h"
#include "common/trajectory.h"
#include "manager/testing/synthetic_submaps.h"

namespace rumi::testing {

struct Scenario {
  SyntheticScene scene;
  SyntheticSubmap front_a, back, front_b;
  Sim3 S_aw, S_bw, S_fbw;  // world -> A, world -> back, world -> front B
};

// pose_noise: keyframe and frame poses off the truth by ~1 cm / 0.1 deg, as
// estimated poses are (keypoints are always projected from the truth).
// back_on_odd_frames: back keyframes on frames 31, 33, ..., 79 only, so that no
// back keyframe shares a timestamp with a front keyframe (even frames); the
// fronts still have tracked FrameRecords for them (as with the sampler's
// every-`inter` frames against the front's own keyframe choice).
inline Scenario MakeScenario(uint32_t seed = 3, double pixel_noise = 1.0, int num_points = 1200,
                             bool pose_noise = true, bool back_on_odd_frames = false) {
  Scenario s;
  SyntheticSceneOptions so;
  so.num_points = num_points;
  so.seed = seed;
  s.scene = MakeSyntheticScene(so);
  s.S_aw = RandomSim3(seed * 11 + 1);
  s.S_bw = RandomSim3(seed * 11 + 2);
  s.S_fbw = RandomSim3(seed * 11 + 3);

  SyntheticSubmapOptions a;
  a.id = 1;
  a.source = SubmapSource::kFront;
  a.first_frame = 0;
  a.last_frame = 40;
  a.keyframe_step = 2;
  a.S_lw = s.S_aw;
  a.pixel_noise = pixel_noise;
  a.max_octave = 3;
  a.pose_noise_m = pose_noise ? 0.01 : 0.0;
  a.pose_noise_rad = pose_noise ? 0.002 : 0.0;
  a.point_id_offset = 1000000;
  a.seed = seed * 11 + 4;
  s.front_a = MakeSyntheticSubmap(s.scene, a);
  // The front lost frames 41-69: recorded in A's frame list as lost.
  for (int f = 41; f <= 69; ++f) {
    FrameRecord r;
    r.timestamp = s.scene.timestamps[f];
    r.state = TrackingState::kLost;
    r.submap_id = -1;
    s.front_a.submap.frames.push_back(r);
  }

  SyntheticSubmapOptions b = a;
  b.id = 1;
  b.source = SubmapSource::kBack;
  b.first_frame = back_on_odd_frames ? 31 : 30;
  b.last_frame = back_on_odd_frames ? 79 : 80;
  b.keyframe_step = back_on_odd_frames ? 2 : 1;
  b.S_lw = s.S_bw;
  b.max_octave = 0;
  b.frame_records = false;
  b.point_id_offset = 2000000;
  b.seed = seed * 11 + 5;
  s.back = MakeSyntheticSubmap(s.scene, b);

  SyntheticSubmapOptions c = a;
  c.id = 2;
  c.first_frame = 70;
  c.last_frame = 110;
  c.S_lw = s.S_fbw;
  c.point_id_offset = 3000000;
  c.seed = seed * 11 + 6;
  s.front_b = MakeSyntheticSubmap(s.scene, c);
  return s;
}

namespace fs = std::filesystem;
using rumi::TempDir;  // common/testing/temp_dir.h

struct TumRow {
  Timestamp t;
  Eigen::Vector3d p;
  Eigen::Quaterniond q;
};

// A TUM trajectory the manager wrote, by the one trajectory reader.
inline std::vector<TumRow> ReadTum(const std::string& path) {
  std::vector<TumRow> rows;
  for (const StampedPose& p : ReadTumTrajectory(path)) rows.push_back({p.t, p.T_wc.translation(), p.T_wc.rotation()});
  return rows;
}

inline nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// Frame index of every row (exact ns), and the position RMSE / max rotation
// error against the truth after one Sim(3).
inline void ExpectMatchesTruth(const Scenario& s, const std::vector<TumRow>& rows, int first, int last) {
  ASSERT_EQ(int(rows.size()), last - first + 1);
  std::vector<Eigen::Vector3d> est, truth;
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].t, s.scene.timestamps[first + i]) << i;
    est.push_back(rows[i].p);
    truth.push_back(s.scene.T_wc[first + i].translation());
  }
  const UmeyamaResult u = UmeyamaAlign(est, truth, true);
  ASSERT_TRUE(u.ok);
  EXPECT_LT(u.rmse, 0.03);  // 1 cm pose noise over ~11 m
  double max_rot = 0;
  for (size_t i = 0; i < rows.size(); ++i)
    max_rot = std::max(max_rot, RotationAngle(u.transform.rotation() * rows[i].q *
                                              s.scene.T_wc[first + i].rotation().conjugate()));
  // Catches a written quaternion in the wrong order / direction (errors of
  // 0.1 rad and more); the scenario's own pose noise (0.002 rad per axis)
  // reaches 0.0153 at its worst row when no welding BA smooths it.
  EXPECT_LT(max_rot, 0.025);
}

inline double Sim3RotationError(const Sim3& a, const Sim3& b) {
  return RotationAngle(a.rotation() * b.rotation().conjugate());
}

}  // namespace rumi::testing
