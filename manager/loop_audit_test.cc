#include "manager/loop_audit.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "manager/sim3_json.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

TEST(LoopAudit, JudgesEachLoopAgainstTheTruth) {
  // Two cameras 1 m apart along x, the second turned 30 deg about y.
  Trajectory gt;
  const Timestamp t0 = 1000 * kNsPerSecond, t1 = 1030 * kNsPerSecond;
  const Se3 A(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0));
  const Se3 B(Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitY()).toRotationMatrix(), Eigen::Vector3d(1, 0, 0));
  gt.push_back({t0, A});
  gt.push_back({t1, B});
  // The loop: query at t1 (B), match at t0 (A). True p_q = T_qm p_m.
  const Se3 T_qm = B.Inverse() * A;
  const auto loop = [&](const Sim3& S_qm, bool closed) {
    return nlohmann::json{{"query", "front#1"}, {"query_keyframe", 7},   {"query_time_s", 1030.0},
                          {"match", "front#0"}, {"match_keyframe", 2},   {"match_time_s", 1000.0},
                          {"closed", closed},   {"S_qm", Sim3ToJson(S_qm)}, {"depth", 1.0}};
  };
  const Sim3 right(0.4, T_qm.rotation(), 0.4 * T_qm.translation());  // a monocular scale: only directions count
  const Sim3 turned(0.4, Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())) * T_qm.rotation(),
                    0.4 * T_qm.translation());
  nlohmann::json stats = {{"loops", {loop(right, true), loop(turned, true), loop(turned, false)}}};
  nlohmann::json bare = loop(right, true);
  bare.erase("S_qm");
  stats["loops"].push_back(bare);
  nlohmann::json close = loop(turned, true);
  close["depth"] = 10.0;  // the cameras 0.4 apart at a depth of 10: no direction
  stats["loops"].push_back(close);
  nlohmann::json off_gt = loop(right, true);
  off_gt["query_time_s"] = 1015.0;  // no ground truth there
  stats["loops"].push_back(off_gt);
  testing::TempDir dir;
  std::filesystem::create_directories(dir.str());
  const std::string path = dir / "manager_stats.json";
  std::ofstream(path) << stats.dump();
  const std::vector<LoopAuditRow> rows = AuditLoops(path, gt);
  ASSERT_EQ(rows.size(), 6u);
  EXPECT_TRUE(rows[0].right);
  EXPECT_FALSE(rows[0].harmful);
  EXPECT_NEAR(*rows[0].rotation_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(*rows[0].direction_error_deg, 0.0, 1e-4);
  EXPECT_EQ(rows[0].query, "front#1");
  EXPECT_EQ(rows[0].match_keyframe, 2);
  EXPECT_FALSE(rows[1].right);
  EXPECT_TRUE(rows[1].harmful);
  EXPECT_NEAR(*rows[1].rotation_error_deg, 11.46, 0.05);
  EXPECT_FALSE(rows[2].harmful);  // as wrong, but not closed
  EXPECT_FALSE(rows[3].rotation_error_deg.has_value());
  EXPECT_FALSE(rows[3].harmful);
  EXPECT_FALSE(rows[3].note.empty());
  EXPECT_TRUE(rows[4].rotation_error_deg.has_value());
  EXPECT_FALSE(rows[4].direction_error_deg.has_value());
  EXPECT_TRUE(rows[4].harmful);  // judged by its rotation alone
  EXPECT_FALSE(rows[5].rotation_error_deg.has_value());
  EXPECT_NE(rows[5].note.find("no ground truth"), std::string::npos);

  std::ofstream(path) << nlohmann::json{{"merges", 0}}.dump();  // an older manager
  EXPECT_TRUE(AuditLoops(path, gt).empty());
  std::ofstream(path) << "{ not json";
  EXPECT_THROW(AuditLoops(path, gt), std::runtime_error);
  EXPECT_THROW(AuditLoops(dir / "absent.json", gt), std::runtime_error);
}

}  // namespace
}  // namespace rumi
