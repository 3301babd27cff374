#include "manager/merge.h"

#include <gtest/gtest.h>

#include "common/logging.h"
#include "manager/global_trajectory.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

// Global keyframe centres and true centres of every keyframe of `members`.
double AlignedCentreRmse(const GlobalMap& map, const testing::Scenario& s, const std::vector<int>& members,
                         double* max_rot_err) {
  std::vector<Eigen::Vector3d> est, truth;
  std::vector<Eigen::Quaterniond> q_est, q_truth;
  for (int i : members) {
    for (const Keyframe& kf : map.submap(i).keyframes) {
      const int f = int((kf.timestamp - s.scene.timestamps[0]) / 33333333);
      const Se3 T = map.ToGlobal(i).TransformPose(kf.T_wc());
      est.push_back(T.translation());
      q_est.push_back(T.rotation());
      truth.push_back(s.scene.T_wc[f].translation());
      q_truth.push_back(s.scene.T_wc[f].rotation());
    }
  }
  const UmeyamaResult u = UmeyamaAlign(est, truth, true);
  EXPECT_TRUE(u.ok);
  *max_rot_err = 0;
  for (size_t i = 0; i < est.size(); ++i)
    *max_rot_err = std::max(*max_rot_err, RotationAngle(u.transform.rotation() * q_est[i] * q_truth[i].conjugate()));
  return u.rmse;
}

TEST(Merge, ChainsFrontAThroughBackToFrontB) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  const int b = map.AddSubmap(s.front_b.submap);
  const int k = map.AddSubmap(s.back.submap);
  double rot = 0;
  // Before: three frames of reference, far from one rigid-similar picture.
  const double rmse_before = AlignedCentreRmse(map, s, {a, k, b}, &rot);
  EXPECT_GT(rmse_before, 0.5);

  ManagerOptions welding;
  welding.welding_ba = true;
  const auto reports = MergeAll(&map, welding);
  int merged = 0;
  for (const auto& r : reports) merged += r.merged;
  EXPECT_EQ(merged, 2);
  EXPECT_TRUE(map.Connected(a, b));  // no shared frame between A and B
  for (const auto& r : reports) {
    if (!r.merged) continue;
    EXPECT_EQ(r.keyframe_pairs, 5);
    EXPECT_GT(r.inlier_ratio, 0.8);
    EXPECT_GT(r.fused_points, 50);
    EXPECT_GT(r.welding.window_keyframes, 5);
    EXPECT_LE(r.welding.final_rmse_px, r.welding.initial_rmse_px + 1e-9);
    EXPECT_LT(r.welding.final_rmse_px, 2.0);
  }
  // After: all keyframes agree with the truth up to one Sim(3); the scene
  // spans 11 m.
  const double rmse_after = AlignedCentreRmse(map, s, {a, k, b}, &rot);
  spdlog::info("chain: keyframe centre RMSE after one Sim(3): {:.4f} m before merging, {:.4f} m after, "
               "max rotation error {:.5f} rad",
               rmse_before, rmse_after, rot);
  EXPECT_LT(rmse_after, 0.03);
  EXPECT_LT(rot, 0.015);  // pose noise 0.002 rad per axis: max over 93 keyframes ~0.01
  // A and B alone (the pair that never shared an image) too.
  EXPECT_LT(AlignedCentreRmse(map, s, {a, b}, &rot), 0.03);

  // Frame records of non-keyframes through the Sim(3) as well.
  const auto traj = ComputeGlobalTrajectory(map);
  EXPECT_EQ(traj.size(), 111u);
}

TEST(Merge, WeldingMovesOnlyTheWindowAndKeepsBackFixed) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  const int k = map.AddSubmap(s.back.submap);
  const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
  ManagerOptions o;
  o.welding_ba = true;
  // A dense synthetic view: with the default 15 every keyframe of A is
  // covisible with the seeds. A high threshold leaves the start of A out.
  o.welding_min_covisible = 300;
  const auto window = WeldingWindow(map.submap(a), {15, 16, 17, 18, 19}, o.welding_min_covisible);
  EXPECT_FALSE(window.count(0));
  EXPECT_TRUE(window.count(15));
  EXPECT_EQ(WeldingWindow(map.submap(a), {15}, 15).size(), s.front_a.submap.keyframes.size());
  const auto r = MergePair(&map, a, k, set, o);
  ASSERT_TRUE(r.merged) << r.reason;
  EXPECT_LT(r.welding.window_keyframes, 21);
  EXPECT_GT(r.welding.fixed_keyframes, 0);
  // The smaller submap (A, 21 keyframes) moved into the back's frame.
  EXPECT_TRUE(map.ToGlobal(k).Matrix().isApprox(Eigen::Matrix4d::Identity()));
  // Back data untouched.
  for (size_t i = 0; i < s.back.submap.keyframes.size(); ++i)
    EXPECT_TRUE(map.submap(k).keyframes[i].T_cw.Matrix().isApprox(s.back.submap.keyframes[i].T_cw.Matrix()));
  // A's first keyframes (far from the back, frames 0..) are outside the
  // welding window: their local poses are unchanged.
  EXPECT_TRUE(map.submap(a).keyframes[0].T_cw.Matrix().isApprox(s.front_a.submap.keyframes[0].T_cw.Matrix()));
  // Fused points coincide in the global frame.
  for (const FusedPoint& f : map.fused()) {
    const auto& fp = map.submap(f.dup).points;
    const auto& bp = map.submap(f.kept).points;
    const auto fi = std::find_if(fp.begin(), fp.end(), [&](const MapPoint& p) { return p.id == f.dup_point; });
    const auto bi = std::find_if(bp.begin(), bp.end(), [&](const MapPoint& p) { return p.id == f.kept_point; });
    ASSERT_TRUE(fi != fp.end() && bi != bp.end());
    EXPECT_LT((map.ToGlobal(f.dup) * fi->position - map.ToGlobal(f.kept) * bi->position).norm(), 1e-6);
  }
  // A second attempt is refused: already connected.
  const auto again = MergePair(&map, a, k, set, ManagerOptions());
  EXPECT_FALSE(again.merged);
  EXPECT_EQ(again.reason, "already connected");
}

// By default no welding BA runs: the front keeps every local pose, the merge
// is its Sim(3) and the fused points.
TEST(Merge, WeldingIsOffByDefault) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  const int k = map.AddSubmap(s.back.submap);
  const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
  const auto r = MergePair(&map, a, k, set, ManagerOptions());
  ASSERT_TRUE(r.merged) << r.reason;
  EXPECT_GT(r.fused_points, 50);
  EXPECT_FALSE(r.welding.applied);
  EXPECT_EQ(r.welding.window_keyframes, 0);
  for (size_t i = 0; i < s.front_a.submap.keyframes.size(); ++i)
    EXPECT_TRUE(map.submap(a).keyframes[i].T_cw.Matrix().isApprox(s.front_a.submap.keyframes[i].T_cw.Matrix()));
}

// A welding solve that moves a keyframe further than welding_max_shift x the
// scene radius is not applied: the merge stands on its Sim(3).
TEST(Merge, WeldingThatMovesKeyframesTooFarIsNotApplied) {
  const auto s = testing::MakeScenario();
  for (const double max_shift : {0.05, 1e-12}) {
    GlobalMap map;
    const int a = map.AddSubmap(s.front_a.submap);
    const int k = map.AddSubmap(s.back.submap);
    const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
    ManagerOptions o;
    o.welding_ba = true;
    o.welding_max_shift = max_shift;
    const auto r = MergePair(&map, a, k, set, o);
    ASSERT_TRUE(r.merged) << r.reason;
    EXPECT_GT(r.welding.window_keyframes, 5);
    EXPECT_GT(r.welding.max_shift_ratio, 0.0);
    EXPECT_LT(r.welding.max_shift_ratio, 0.05);  // a right merge moves keyframes by little
    EXPECT_EQ(r.welding.reverted, max_shift < 0.05);
    bool moved = false;
    for (size_t i = 0; i < s.front_a.submap.keyframes.size(); ++i)
      moved |= !map.submap(a).keyframes[i].T_cw.Matrix().isApprox(s.front_a.submap.keyframes[i].T_cw.Matrix());
    EXPECT_EQ(moved, !r.welding.reverted);
    EXPECT_EQ(r.welding.applied, !r.welding.reverted);
    EXPECT_TRUE(map.Connected(a, k));
  }
}

TEST(Merge, SmallerComponentMovesEvenWithSeveralSubmaps) {
  // A (7 keyframes) merges into the back (17): A moves. Then B (41) meets the
  // component {A, back} (24): that whole component moves into B's frame.
  auto s = testing::MakeScenario();
  SyntheticSubmapOptions o;
  o.pose_noise_m = 0.01;
  o.pose_noise_rad = 0.002;
  o.max_octave = 3;
  auto make = [&](SubmapSource src, int64_t id, int first, int last, int step, uint32_t seed) {
    o.source = src;
    o.id = id;
    o.first_frame = first;
    o.last_frame = last;
    o.keyframe_step = step;
    o.S_lw = RandomSim3(seed);
    o.point_id_offset = seed * 1000000;
    o.seed = seed;
    o.frame_records = src == SubmapSource::kFront;
    return MakeSyntheticSubmap(s.scene, o).submap;
  };
  GlobalMap map;
  const int a = map.AddSubmap(make(SubmapSource::kFront, 1, 0, 40, 6, 21));
  const int b = map.AddSubmap(make(SubmapSource::kFront, 2, 70, 110, 1, 22));
  const int k = map.AddSubmap(make(SubmapSource::kBack, 1, 30, 80, 3, 23));
  ASSERT_EQ(map.submap(a).keyframes.size(), 7u);
  ASSERT_EQ(map.submap(k).keyframes.size(), 17u);
  const auto reports = MergeAll(&map, ManagerOptions());
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_TRUE(reports[0].merged) << reports[0].reason;
  EXPECT_TRUE(reports[1].merged) << reports[1].reason;
  EXPECT_TRUE(reports[0].front_moved);
  EXPECT_FALSE(reports[1].front_moved);
  EXPECT_TRUE(map.Connected(a, b));
  EXPECT_TRUE(map.ToGlobal(b).Matrix().isApprox(Eigen::Matrix4d::Identity()));
  EXPECT_FALSE(map.ToGlobal(k).Matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-3));
  double rot = 0;
  EXPECT_LT(AlignedCentreRmse(map, s, {a, k, b}, &rot), 0.03);
  EXPECT_LT(rot, 0.015);
}

TEST(Merge, PairsBackKeyframesWithTrackedFrontFrames) {
  const auto s = testing::MakeScenario(3, 1.0, 1200, true, /*back_on_odd_frames=*/true);
  for (const Keyframe& bk : s.back.submap.keyframes) {
    for (const Submap* f : {&s.front_a.submap, &s.front_b.submap})
      for (const Keyframe& fk : f->keyframes) ASSERT_NE(bk.timestamp, fk.timestamp);
  }
  auto fill = [&](GlobalMap* map) {
    return std::vector<int>{map->AddSubmap(s.front_a.submap), map->AddSubmap(s.back.submap),
                            map->AddSubmap(s.front_b.submap)};
  };
  // Keyframe-keyframe pairing alone: nothing to pair, nothing merges.
  {
    GlobalMap map;
    const auto ids = fill(&map);
    ManagerOptions o;
    o.pair_tracked_frames = false;
    const auto reports = MergeAll(&map, o);
    ASSERT_EQ(reports.size(), 2u);
    for (const auto& r : reports) {
      EXPECT_FALSE(r.merged);
      EXPECT_EQ(r.keyframe_pairs, 0);
      EXPECT_EQ(r.frame_pairs, 0);
    }
    EXPECT_FALSE(map.Connected(ids[0], ids[1]));
  }
  // With tracked frames: back keyframes 31..39 pair with A's frames, 71..79
  // with B's, and the whole chain merges.
  GlobalMap map;
  const auto ids = fill(&map);
  double rot = 0;
  EXPECT_GT(AlignedCentreRmse(map, s, ids, &rot), 0.5);
  const auto reports = MergeAll(&map, ManagerOptions());
  int merged = 0;
  for (const auto& r : reports) {
    merged += r.merged;
    EXPECT_TRUE(r.merged) << r.reason;
    EXPECT_EQ(r.keyframe_pairs, 0);
    EXPECT_EQ(r.frame_pairs, 5);
    EXPECT_GT(r.common_points, 100);
    EXPECT_GT(r.inlier_ratio, 0.8);
    EXPECT_LT(r.welding.final_rmse_px, 2.0);
  }
  EXPECT_EQ(merged, 2);
  EXPECT_TRUE(map.Connected(ids[0], ids[2]));
  const double rmse = AlignedCentreRmse(map, s, ids, &rot);
  spdlog::info("frame pairs: keyframe centre RMSE after one Sim(3) {:.4f} m, max rotation error {:.5f} rad", rmse,
               rot);
  EXPECT_LT(rmse, 0.03);
  EXPECT_LT(rot, 0.015);
  // The global trajectory (all frame records) against the truth, one Sim(3).
  // Frames 42, 44, ..., 68: lost by the front and not back keyframes.
  const auto traj = ComputeGlobalTrajectory(map);
  ASSERT_EQ(traj.size(), 111u - 14u);
  std::vector<Eigen::Vector3d> est, truth;
  for (const GlobalPose& p : traj) {
    const int f = int((p.timestamp - s.scene.timestamps[0]) / 33333333);
    ASSERT_EQ(s.scene.timestamps[f], p.timestamp);
    est.push_back(p.T_wc.translation());
    truth.push_back(s.scene.T_wc[f].translation());
  }
  const UmeyamaResult u = UmeyamaAlign(est, truth, true);
  ASSERT_TRUE(u.ok);
  EXPECT_LT(u.rmse, 0.03);
}

TEST(Merge, RejectsBackSubmapOfAnotherScene) {
  auto s = testing::MakeScenario();
  // Same timestamps, different world: pairs exist, M_com is random.
  const auto other = testing::MakeScenario(99);
  GlobalMap map;
  const int a = map.AddSubmap(s.front_a.submap);
  const int k = map.AddSubmap(other.back.submap);
  const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
  const auto r = MergePair(&map, a, k, set, ManagerOptions());
  EXPECT_EQ(r.keyframe_pairs, 5);
  EXPECT_FALSE(r.merged);
  EXPECT_FALSE(r.reason.empty());
  EXPECT_FALSE(map.Connected(a, k));
  EXPECT_TRUE(map.ToGlobal(a).Matrix().isApprox(Eigen::Matrix4d::Identity()));
  EXPECT_TRUE(map.fused().empty());
}

TEST(Merge, TransformSubmapKeepsReprojection) {
  const auto s = testing::MakeScenario();
  Submap m = s.front_a.submap;
  TransformSubmap(RandomSim3(77), &m);
  // Projection of a point into a keyframe is invariant under a similarity.
  const auto& kf0 = s.front_a.submap.keyframes[3];
  const auto& kf1 = m.keyframes[3];
  for (size_t p = 0; p < 20; ++p) {
    const Eigen::Vector3d a = kf0.T_cw * s.front_a.submap.points[p].position;
    const Eigen::Vector3d b = kf1.T_cw * m.points[p].position;
    EXPECT_LT((a.hnormalized() - b.hnormalized()).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace rumi
