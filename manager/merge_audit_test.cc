#include "manager/merge_audit.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "manager/test_scenario.h"

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
  const auto dir = std::filesystem::temp_directory_path() / ("rumi_merge_audit_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = (dir / "manager_stats.json").string();
  std::ofstream(path) << R"({"merge_reports": [
    {"kind": "merge", "front": "front#1", "back": "back#1", "merged": true, "reason": "", "rejected_by": "",
     "S_bf": {"s": 2.0, "q_xyzw": [0, 0, 0, 1], "t": [1, 2, 3]}},
    {"kind": "merge", "front": "front#2", "back": "back#1", "merged": false, "reason": "too few keyframe pairs"},
    {"kind": "merge", "front": "front#3", "back": "back#1", "merged": false, "reason": "verification (rmse): x",
     "rejected_by": "rmse", "S_bf": {"s": 1.0, "q_xyzw": [0, 0, 0, 1], "t": [0, 0, 0]}}]})";
  const auto a = ReadMergeAttempts(path);
  ASSERT_EQ(a.size(), 2u);  // the attempt without a Sim(3) is not audited
  EXPECT_TRUE(a[0].merged);
  EXPECT_DOUBLE_EQ(a[0].S_ba.scale(), 2.0);
  EXPECT_DOUBLE_EQ(a[0].S_ba.translation().y(), 2.0);
  EXPECT_EQ(a[1].a, "front#3");
  EXPECT_EQ(a[1].rejected_by, "rmse");
  std::ofstream(path) << R"({"merges": 3})";
  EXPECT_THROW(ReadMergeAttempts(path), std::runtime_error);
  std::ofstream(path) << "{not json";
  try {
    ReadMergeAttempts(path);
    ADD_FAILURE() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rumi
