#include "manager/merge_verify.h"

#include <gtest/gtest.h>

#include "manager/merge.h"
#include "manager/sim3_alignment.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

struct Fixture {
  testing::Scenario s = testing::MakeScenario();
  std::vector<KeyframePair> pairs;
  std::vector<FramePair> frame_pairs;
  Sim3 S_true;  // front A's frame -> back frame
  Fixture() {
    const Submap& F = s.front_a.submap;
    const Submap& B = s.back.submap;
    const SearchSet set = BuildSearchSet({&F}, {&B}, 10);
    pairs = PairKeyframes(F, B, set, 100000);
    frame_pairs = PairTrackedFrames(F, B, set, 100000, pairs, 3);
    S_true = s.S_bw * s.S_aw.Inverse();
  }
  MergeVerification Verify(const Sim3& S, int inliers = 200, double rmse = 1.0, ManagerOptions o = {},
                           int kept = -1) const {
    return VerifyMerge(s.front_a.submap, s.back.submap, pairs, frame_pairs, S, inliers, kept < 0 ? inliers : kept,
                       rmse, o);
  }
};

TEST(MergeVerify, TheTrueSim3Passes) {
  const Fixture f;
  ASSERT_EQ(f.pairs.size(), 5u);
  const MergeVerification v = f.Verify(f.S_true);
  EXPECT_TRUE(v.ok) << v.why;
  EXPECT_EQ(v.pose_pairs, int(f.pairs.size() + f.frame_pairs.size()));
  EXPECT_EQ(v.agreeing_pairs, v.pose_pairs);
  EXPECT_LT(v.median_angle_deg, 0.5);  // pose noise 0.002 rad per axis and side
  EXPECT_LT(v.median_offset_ratio, 0.02);
}

TEST(MergeVerify, EachCheckRejectsWhatItGuards) {
  const Fixture f;
  // A Sim(3) 20 % off in scale (about the back scene): paired centres move apart.
  const Sim3 scaled = Sim3(1.2, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) * f.S_true;
  MergeVerification v = f.Verify(scaled);
  EXPECT_FALSE(v.ok);
  EXPECT_EQ(v.check, "pose_pairs") << v.why;
  EXPECT_GT(v.median_offset_ratio, 0.1);
  // 10 degrees about the back frame's origin: the paired rotations disagree.
  const Sim3 turned =
      Sim3(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitY())),
           Eigen::Vector3d::Zero()) *
      f.S_true;
  v = f.Verify(turned);
  EXPECT_EQ(v.check, "pose_pairs") << v.why;
  EXPECT_GT(v.median_angle_deg, 9.0);
  // Too few inliers, too large an RMSE.
  v = f.Verify(f.S_true, 19, 1.0);
  EXPECT_EQ(v.check, "inliers") << v.why;
  // Inliers the refinement pulled away from: at least half must still agree
  // (the harmful merge of 2026-11-28 kept 14 of 42; right merges keep
  // 88-98 %).
  v = f.Verify(f.S_true, 42, 1.0, {}, 14);
  EXPECT_EQ(v.check, "kept") << v.why;
  EXPECT_NE(v.why.find("14 of 42 inliers still agree after refinement, under 50 %"), std::string::npos) << v.why;
  v = f.Verify(f.S_true, 100, 1.0, {}, 40);
  EXPECT_EQ(v.check, "kept") << v.why;
  EXPECT_NE(v.why.find("40 of 100 inliers still agree after refinement, under 50 %"), std::string::npos) << v.why;
  EXPECT_TRUE(f.Verify(f.S_true, 100, 1.0, {}, 88).ok);
  v = f.Verify(f.S_true, 200, 3.82);
  EXPECT_EQ(v.check, "rmse") << v.why;
  // A merge may carry a few bad pairs (a front frame tracked badly) when the
  // majority agrees; all pairs must agree when the ratio asks for it.
  ManagerOptions o;
  o.verify_max_pose_angle_deg = 0.25;  // some pairs are noisier than this
  v = f.Verify(f.S_true, 200, 1.0, o);
  EXPECT_LT(v.agreeing_pairs, v.pose_pairs);
  o.verify_min_agreeing_ratio = 0.0;
  o.verify_min_agreeing_pairs = v.agreeing_pairs;
  EXPECT_TRUE(f.Verify(f.S_true, 200, 1.0, o).ok);
  o.verify_min_agreeing_ratio = 1.0;
  EXPECT_FALSE(f.Verify(f.S_true, 200, 1.0, o).ok);
}

// The paper's merge accepts any inlier ratio > 0.1. A back submap whose
// cameras are wrong but whose points still line up with the front's in part
// (a broken SfM model) gets a Sim(3) from the points; verification must
// refuse to commit it, and must still commit the right one.
TEST(MergeVerify, MergePairRejectsAWrongBackSubmapAndKeepsTheRightOne) {
  const testing::Scenario s = testing::MakeScenario();
  {
    GlobalMap map;
    const int a = map.AddSubmap(s.front_a.submap);
    const int k = map.AddSubmap(s.back.submap);
    const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
    const MergeReport r = MergePair(&map, a, k, set, ManagerOptions());
    EXPECT_TRUE(r.merged) << r.reason;
    EXPECT_TRUE(r.rejected_by.empty());
    EXPECT_EQ(r.agreeing_pairs, r.pose_pairs);
  }
  // Broken model: every back camera is displaced by a quarter of the scene
  // radius along its own optical axis, the points kept: the 3D common points
  // still give a good Sim(3), the paired poses do not agree with it.
  Submap broken = s.back.submap;
  std::vector<Eigen::Vector3d> pts;
  for (const MapPoint& p : broken.points) pts.push_back(p.position);
  const double radius = SceneRadius(pts);
  for (Keyframe& kf : broken.keyframes) {
    Se3 T_wc = kf.T_wc();
    T_wc.translation() += T_wc.R().col(2) * 0.25 * radius;
    kf.T_cw = T_wc.Inverse();
  }
  // Verification off; on; on with only the pose check left.
  for (int mode : {0, 1, 2}) {
    GlobalMap map;
    const int a = map.AddSubmap(s.front_a.submap);
    const int k = map.AddSubmap(broken);
    const SearchSet set = BuildSearchSet({&map.submap(a)}, {&map.submap(k)}, 10);
    ManagerOptions o;
    o.verify_merges = mode > 0;
    if (mode == 2) {
      o.verify_max_rmse_px = 1000;
      o.verify_min_inliers = 0;
      o.verify_min_kept_ratio = 0;
    }
    const MergeReport r = MergePair(&map, a, k, set, o);
    if (mode == 0) {
      EXPECT_TRUE(r.merged) << "without verification the broken model merges: " << r.reason;
    } else {
      EXPECT_FALSE(r.merged);
      // The refinement, pulled by the displaced cameras, leaves none of the
      // RANSAC's 3D inliers in place; without that check the poses catch it.
      EXPECT_EQ(r.rejected_by, mode == 1 ? "kept" : "pose_pairs") << r.reason;
      EXPECT_FALSE(map.Connected(a, k));
      EXPECT_TRUE(map.fused().empty());
    }
    EXPECT_TRUE(r.refined);
  }
}

}  // namespace
}  // namespace rumi
