#include "manager/global_trajectory.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "manager/merge.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

int FrameOf(const testing::Scenario& s, Timestamp t) {
  return int((t - s.scene.timestamps[0]) / 33333333);
}

TEST(GlobalTrajectory, EveryFrameOfTheChainInOneFrame) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  const int b = map.AddSubmap(s.front_b.submap);
  const int k = map.AddSubmap(s.back.submap);
  // Unmerged: the largest component is the back submap alone (51 keyframes).
  EXPECT_EQ(ComputeGlobalTrajectory(map).size(), 51u);
  MergeAll(&map, ManagerOptions());
  const auto traj = ComputeGlobalTrajectory(map);
  ASSERT_EQ(traj.size(), 111u);
  std::vector<Eigen::Vector3d> est, truth;
  for (const auto& p : traj) {
    const int f = FrameOf(s, p.timestamp);
    est.push_back(p.T_wc.translation());
    truth.push_back(s.scene.T_wc[f].translation());
    // Source: front keyframes/frames where tracked, the back where lost.
    if (f <= 40) EXPECT_EQ(p.submap, a) << f;
    else if (f < 70) EXPECT_EQ(p.submap, k) << f;
    else EXPECT_EQ(p.submap, b) << f;
    EXPECT_EQ(p.from_back, p.submap == k);
  }
  const UmeyamaResult u = UmeyamaAlign(est, truth, true);
  ASSERT_TRUE(u.ok);
  EXPECT_LT(u.rmse, 0.03);  // 11 m of travel, 1 cm pose noise
  // Orientation too (catches a pose transformed without its rotation).
  double max_rot = 0;
  for (const auto& p : traj)
    max_rot = std::max(max_rot, RotationAngle(u.transform.rotation() * p.T_wc.rotation() *
                                              s.scene.T_wc[FrameOf(s, p.timestamp)].rotation().conjugate()));
  EXPECT_LT(max_rot, 0.015);  // pose noise 0.002 rad per axis, max over 111 frames
}

TEST(GlobalTrajectory, WritesTum) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  map.AddSubmap(s.front_a.submap);
  const auto traj = ComputeGlobalTrajectory(map);
  const TempDir dir;
  dir.Create();
  const std::string path = dir / "traj.txt";
  WriteTumTrajectory(path, ToTrajectory(traj));
  std::ifstream in(path);
  std::string line;
  int n = 0;
  std::getline(in, line);
  EXPECT_EQ(line[0], '#');  // header
  std::getline(in, line);
  ++n;
  // "t tx ty tz qx qy qz qw", t exact from ns.
  EXPECT_EQ(line.substr(0, line.find(' ')), FormatSeconds(s.scene.timestamps[0]));
  double v[8];
  ASSERT_EQ(std::sscanf(line.c_str(), "%lf %lf %lf %lf %lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5],
                        &v[6], &v[7]),
            8);
  EXPECT_NEAR(v[1], traj[0].T_wc.translation().x(), 1e-6);
  EXPECT_NEAR(v[7], traj[0].T_wc.rotation().w(), 1e-6);
  while (std::getline(in, line)) ++n;
  EXPECT_EQ(n, int(traj.size()));
  try {
    WriteTumTrajectory("/nonexistent-dir/x.txt", ToTrajectory(traj));
    ADD_FAILURE() << "wrote into a missing folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.txt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rumi
