#include "manager/merge_audit.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

struct Fixture {
  testing::Scenario s = testing::MakeScenario();
  GlobalMap raw;
  Trajectory gt;
  Sim3 S_true;  // front A -> back
  Fixture() {
    raw.AddSubmap(s.front_a.submap);
    raw.AddSubmap(s.back.submap);
    for (size_t i = 0; i < s.scene.timestamps.size(); ++i) gt.push_back({s.scene.timestamps[i], s.scene.T_wc[i]});
    S_true = s.S_bw * s.S_aw.Inverse();
  }
  MergeAttempt Attempt(const Sim3& S, bool merged) const {
    MergeAttempt m;
    m.a = "front#1";
    m.b = "back#1";
    m.merged = merged;
    m.has_transform = true;
    m.S_ba = S;
    return m;
  }
};

TEST(MergeAudit, ARightMergeIsHarmlessAWrongOneHarmful) {
  const Fixture f;
  const Sim3 wrong = Sim3(1.5, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) * f.S_true;
  const auto rows = AuditMerges(f.raw, {f.Attempt(f.S_true, true), f.Attempt(wrong, false)}, f.gt);
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& r : rows) {
    EXPECT_TRUE(r.note.empty()) << r.note;
    EXPECT_EQ(r.a_frames, 41u);  // A's tracked frames 0-40, all within near_s of the back's span
    EXPECT_EQ(r.b_frames, f.s.back.submap.keyframes.size());
    ASSERT_TRUE(r.ate_a && r.ate_b && r.ate_joint && r.ate_a_joint);
    EXPECT_LT(*r.ate_a, 0.03);  // pose noise 1 cm
    EXPECT_LT(*r.ate_b, 0.03);
  }
  EXPECT_TRUE(rows[0].accepted);
  EXPECT_FALSE(rows[0].harmful) << *rows[0].ate_joint << " vs " << *rows[0].ate_a << ", " << *rows[0].ate_b;
  EXPECT_LT(*rows[0].ate_joint, 0.03);
  EXPECT_FALSE(rows[1].accepted);
  EXPECT_TRUE(rows[1].harmful);  // what rejecting it avoided
  EXPECT_GT(*rows[1].ate_joint, 5 * *rows[0].ate_joint);
}

// A back submap that is broken in itself (its second half 2 m off) merged
// with the right Sim(3) for its first half: as bad joined as alone, yet it
// puts its error into the map.
TEST(MergeAudit, ABrokenBackSubmapIsHarmfulEvenWhenNoWorseJoined) {
  Fixture f;
  Submap& back = f.raw.submap(1);
  for (size_t k = back.keyframes.size() / 2; k < back.keyframes.size(); ++k)
    back.keyframes[k].T_cw = back.keyframes[k].T_cw * Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2, 0, 0));
  MergeAuditOptions o;
  auto rows = AuditMerges(f.raw, {f.Attempt(f.S_true, true)}, f.gt, o);
  ASSERT_EQ(rows.size(), 1u);
  ASSERT_TRUE(rows[0].ate_a && rows[0].ate_b && rows[0].ate_joint);
  EXPECT_GT(*rows[0].ate_b, 10 * *rows[0].ate_a);
  EXPECT_GT(*rows[0].ate_joint, o.front_ratio * *rows[0].ate_a);
  EXPECT_TRUE(rows[0].harmful);
  // By the first rule alone it would pass: joined no worse than 1.5 x the back alone.
  EXPECT_LT(*rows[0].ate_joint, o.joint_ratio * *rows[0].ate_b);
  o.front_ratio = 1e9;
  rows = AuditMerges(f.raw, {f.Attempt(f.S_true, true)}, f.gt, o);
  EXPECT_FALSE(rows[0].harmful);
}

// A merge the alignment refuses still has a candidate Sim(3); the audit
// measures it, so a run says what refusing it cost. Here the right merge,
// refused by an inlier-ratio bar nothing can pass: audited, not harmful.
TEST(MergeAudit, AnAttemptRefusedByTheAlignmentIsAuditedWithItsCandidate) {
  const Fixture f;
  GlobalMap map;
  const int a = map.AddSubmap(f.s.front_a.submap);
  const int b = map.AddSubmap(f.s.back.submap);
  ManagerOptions o;
  o.min_inlier_ratio = 1.0;
  const MergeReport r =
      MergePair(&map, a, b, BuildSearchSet({&map.submap(a)}, {&map.submap(b)}, 10), o);
  ASSERT_FALSE(r.merged);
  EXPECT_FALSE(r.refined);
  EXPECT_TRUE(r.aligned);
  EXPECT_EQ(r.rejected_by, "alignment");
  EXPECT_NE(r.reason.find("inlier ratio"), std::string::npos) << r.reason;
  EXPECT_LT((r.S_bf_initial.Matrix() - f.S_true.Matrix()).norm(), 0.05 * f.S_true.Matrix().norm());

  const auto attempts = AttemptsOf({r});
  ASSERT_EQ(attempts.size(), 1u);
  EXPECT_FALSE(attempts[0].merged);
  EXPECT_TRUE(attempts[0].S_ba.Matrix().isApprox(r.S_bf_initial.Matrix()));
  const auto rows = AuditMerges(f.raw, attempts, f.gt);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].accepted);
  EXPECT_EQ(rows[0].rejected_by, "alignment");
  ASSERT_TRUE(rows[0].ate_joint) << rows[0].note;
  EXPECT_FALSE(rows[0].harmful) << *rows[0].ate_joint;

  // One refused before any Sim(3) (too few common points) is not an attempt to audit.
  GlobalMap map2;
  const int a2 = map2.AddSubmap(f.s.front_a.submap), b2 = map2.AddSubmap(f.s.back.submap);
  o = ManagerOptions();
  o.min_common_points = 1000000;
  const MergeReport r2 =
      MergePair(&map2, a2, b2, BuildSearchSet({&map2.submap(a2)}, {&map2.submap(b2)}, 10), o);
  EXPECT_FALSE(r2.aligned);
  EXPECT_TRUE(r2.rejected_by.empty());
  EXPECT_TRUE(AttemptsOf({r2}).empty());
}

TEST(MergeAudit, MissingSubmapsAndTruthAreNotedNotThrown) {
  const Fixture f;
  MergeAttempt m = f.Attempt(f.S_true, true);
  m.b = "back#7";
  auto rows = AuditMerges(f.raw, {m}, f.gt);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].note, "submap not in the raw map");
  EXPECT_FALSE(rows[0].harmful);
  rows = AuditMerges(f.raw, {f.Attempt(f.S_true, true)}, {});
  EXPECT_EQ(rows[0].note, "no ground truth");
}

TEST(MergeAudit, ReadsTheManagersMergeReports) {
  const TempDir tmp;
  const std::filesystem::path dir = tmp.Create();
  const auto path = (dir / "manager_stats.json").string();
  std::ofstream(path) << R"j({"merge_reports": [
    {"kind": "merge", "front": "front#1", "back": "back#1", "merged": true, "reason": "", "rejected_by": "",
     "S_bf": {"s": 2.0, "q_xyzw": [0, 0, 0, 1], "t": [1, 2, 3]}},
    {"kind": "merge", "front": "front#2", "back": "back#1", "merged": false, "reason": "too few keyframe pairs"},
    {"kind": "merge", "front": "front#3", "back": "back#1", "merged": false, "reason": "verification (rmse): x",
     "rejected_by": "rmse", "S_bf": {"s": 1.0, "q_xyzw": [0, 0, 0, 1], "t": [0, 0, 0]}},
    {"kind": "merge", "front": "front#4", "back": "back#1", "merged": false, "reason": "too few inliers (18 < 20)",
     "rejected_by": "alignment", "S_bf_initial": {"s": 3.0, "q_xyzw": [0, 0, 0, 1], "t": [0, 0, 0]}}]})j";
  const auto a = ReadMergeAttempts(path);
  ASSERT_EQ(a.size(), 3u);  // the attempt without a Sim(3) is not audited
  EXPECT_TRUE(a[0].merged);
  EXPECT_DOUBLE_EQ(a[0].S_ba.scale(), 2.0);
  EXPECT_DOUBLE_EQ(a[0].S_ba.translation().y(), 2.0);
  EXPECT_EQ(a[1].a, "front#3");
  EXPECT_EQ(a[1].rejected_by, "rmse");
  EXPECT_EQ(a[2].rejected_by, "alignment");  // the candidate the alignment refused
  EXPECT_DOUBLE_EQ(a[2].S_ba.scale(), 3.0);
  std::ofstream(path) << R"({"merges": 3})";
  EXPECT_THROW(ReadMergeAttempts(path), std::runtime_error);
  std::ofstream(path) << "{not json";
  try {
    ReadMergeAttempts(path);
    ADD_FAILURE() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rumi
