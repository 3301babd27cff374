#include "common/run_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/eval_table.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

constexpr Timestamp kT0 = 1305031102 * kNsPerSecond;  // TUM-like epoch
constexpr Timestamp kDt = 100000000;                  // 0.1 s

std::vector<Timestamp> Frames(int n) {
  std::vector<Timestamp> f;
  for (int i = 0; i < n; ++i) f.push_back(kT0 + i * kDt);
  return f;
}

// Non-degenerate ground truth: a rising circle.
Trajectory GroundTruth(int n) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double a = 0.07 * i;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
    gt.push_back({kT0 + i * kDt, Se3(q, Eigen::Vector3d(2 * std::cos(a), 2 * std::sin(a), 0.02 * i))});
  }
  return gt;
}

// The same poses in a frame of another scale: est = S_est_gt * gt.
Trajectory Transformed(const Trajectory& gt, int first, int last) {
  const Sim3 S(0.5, Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())),
               Eigen::Vector3d(4, -1, 7));
  Trajectory est;
  for (int i = first; i <= last; ++i) est.push_back({gt[i].t, S.TransformPose(gt[i].T_wc)});
  return est;
}

RunMetricsInput BaseInput() {
  RunMetricsInput in;
  in.sequence = "seq";
  in.frames = Frames(101);  // 10 s
  in.ground_truth = GroundTruth(101);
  return in;
}

TEST(RunMetrics, RatesByTimeAndByFrames) {
  RunMetricsInput in = BaseInput();
  in.front = Transformed(in.ground_truth, 20, 69);  // 4.9 s of 10, 50 frames
  // Merged: two pieces with a gap; the gap counts in the covered duration.
  in.merged = Transformed(in.ground_truth, 10, 29);
  const Trajectory tail = Transformed(in.ground_truth, 60, 79);
  in.merged.insert(in.merged.end(), tail.begin(), tail.end());
  const RunMetricsReport r = ComputeRunMetrics(in);
  EXPECT_EQ(r.frames, 101u);
  EXPECT_NEAR(r.duration_s, 10.0, 1e-12);
  EXPECT_NEAR(r.front.rate_time, 0.49, 1e-12);
  EXPECT_NEAR(r.front.rate_frames, 50.0 / 101.0, 1e-12);
  EXPECT_NEAR(r.merged.rate_time, 0.69, 1e-12);
  EXPECT_NEAR(r.merged.rate_frames, 40.0 / 101.0, 1e-12);
  // Exact copies up to a Sim(3): ATE zero after alignment, alignment recovered.
  ASSERT_TRUE(r.front.ate_rmse.has_value());
  EXPECT_LT(*r.front.ate_rmse, 1e-9);
  EXPECT_EQ(r.front.ate_pairs, 50u);
  ASSERT_TRUE(r.front.S_gt_est.has_value());
  EXPECT_NEAR(r.front.S_gt_est->scale(), 2.0, 1e-9);
  ASSERT_TRUE(r.merged.ate_rmse.has_value());
  EXPECT_LT(*r.merged.ate_rmse, 1e-9);
}

TEST(RunMetrics, KnownAteInGroundTruthUnits) {
  RunMetricsInput in = BaseInput();
  // Ground truth moved by +-e along z, alternating: Sim(3) cannot absorb it,
  // so the RMSE is ~e in metres even though the estimate has scale 0.5.
  const double e = 0.05;
  Trajectory noisy = in.ground_truth;
  for (size_t i = 0; i < noisy.size(); ++i) noisy[i].T_wc.translation().z() += (i % 2 ? e : -e);
  in.front = Transformed(noisy, 0, 100);
  in.merged = in.front;
  const RunMetricsReport r = ComputeRunMetrics(in);
  ASSERT_TRUE(r.front.ate_rmse.has_value());
  EXPECT_NEAR(*r.front.ate_rmse, e, 0.02 * e);
  EXPECT_NEAR(r.front.rate_time, 1.0, 1e-12);
  EXPECT_NEAR(r.front.rate_frames, 1.0, 1e-12);
}

TEST(RunMetrics, EmptyTrajectoryHasRateZeroAndNullRmse) {
  RunMetricsInput in = BaseInput();
  in.merged = Transformed(in.ground_truth, 0, 50);
  const RunMetricsReport r = ComputeRunMetrics(in);
  EXPECT_EQ(r.front.rate_time, 0.0);
  EXPECT_EQ(r.front.rate_frames, 0.0);
  EXPECT_FALSE(r.front.ate_rmse.has_value());
  EXPECT_EQ(r.front.ate_note, "empty trajectory");
  const nlohmann::json j = nlohmann::json::parse(FormatRunMetricsJson(r));
  EXPECT_TRUE(j["front_ate_rmse"].is_null());
  EXPECT_TRUE(j["merged_ate_rmse"].is_number());
  EXPECT_TRUE(j["front_ms_mean"].is_null());  // no timings given
}

TEST(RunMetrics, NoGroundTruthGivesNullRmse) {
  RunMetricsInput in = BaseInput();
  in.front = Transformed(in.ground_truth, 0, 100);
  in.merged = in.front;
  in.ground_truth.clear();
  const RunMetricsReport r = ComputeRunMetrics(in);
  EXPECT_FALSE(r.front.ate_rmse.has_value());
  EXPECT_FALSE(r.merged.ate_rmse.has_value());
  EXPECT_NEAR(r.front.rate_time, 1.0, 1e-12);
  const RunMetrics parsed = ParseRunMetrics(FormatRunMetricsJson(r), "test");
  EXPECT_FALSE(parsed.front_rmse.has_value());
  EXPECT_FALSE(parsed.merged_rmse.has_value());
}

TEST(RunMetrics, TooFewPairsGivesNullRmseWithReason) {
  RunMetricsInput in = BaseInput();
  in.front = Transformed(in.ground_truth, 3, 4);  // 2 poses: no Sim(3)
  const RunMetricsReport r = ComputeRunMetrics(in);
  EXPECT_FALSE(r.front.ate_rmse.has_value());
  EXPECT_FALSE(r.front.ate_note.empty());
  EXPECT_NEAR(r.front.rate_time, 0.01, 1e-12);
}

TEST(RunMetrics, JsonHasEveryKeyAndParsesInEvalTable) {
  RunMetricsInput in = BaseInput();
  in.front = Transformed(in.ground_truth, 0, 59);
  in.merged = Transformed(in.ground_truth, 0, 100);
  for (int i = 1; i <= 20; ++i) in.front_ms.push_back(i);
  in.counts = {3, 12.5, 2, 140, 120, 2, 3, 90};
  const RunMetricsReport r = ComputeRunMetrics(in);
  EXPECT_DOUBLE_EQ(*r.front_ms_mean, 10.5);
  EXPECT_DOUBLE_EQ(*r.front_ms_median, 10.5);
  EXPECT_DOUBLE_EQ(*r.front_ms_p95, 19.0);
  const std::string text = FormatRunMetricsJson(r);
  const nlohmann::json j = nlohmann::json::parse(text);
  for (const char* k :
       {"frames", "duration_s", "front_tracking_rate_time", "front_tracking_rate_frames",
        "merged_tracking_rate_time", "merged_tracking_rate_frames", "front_ate_rmse",
        "merged_ate_rmse", "front_ms_mean", "front_ms_median", "front_ms_p95", "back_windows",
        "back_seconds", "merges", "saved_frames", "saved_frames_postculled", "submaps_front",
        "submaps_back", "front_saved_frames"}) {
    ASSERT_TRUE(j.contains(k)) << k;
    EXPECT_TRUE(j[k].is_number()) << k;
  }
  EXPECT_EQ(j["sequence"], "seq");
  EXPECT_EQ(j["back_windows"], 3);
  EXPECT_EQ(j["submaps_back"], 3);
  EXPECT_EQ(j["saved_frames_postculled"], 120);
  const RunMetrics m = ParseRunMetrics(text, "metrics.json");
  EXPECT_EQ(m.sequence, "seq");
  EXPECT_NEAR(m.front_rate, 0.59, 1e-12);
  EXPECT_NEAR(m.merged_rate, 1.0, 1e-12);
  EXPECT_EQ(m.merged_frames, 140);
  EXPECT_EQ(m.po_frames, 120);
  EXPECT_EQ(m.front_frames, 90);
  ASSERT_TRUE(m.merged_rmse.has_value());
  EXPECT_TRUE(j["losses"].is_null());  // not computed: no loss-to-merge key
  EXPECT_FALSE(m.loss_to_merge_s.has_value());
}

// Over the frames the front tracked (aligned on them alone, as the issue's
// "0.0117 against 0.0100 m"), the merged ATE shows what merging did to the
// front's own frames, whatever the frames it added.
TEST(RunMetrics, MergedAteOverTheFrontsFramesAndTheAuditInJson) {
  RunMetricsInput in = BaseInput();
  in.front = Transformed(in.ground_truth, 20, 100);
  in.merged = Transformed(in.ground_truth, 0, 100);
  RunMetricsReport r = ComputeRunMetrics(in);
  ASSERT_TRUE(r.merged_ate_front_frames.has_value());
  EXPECT_LT(*r.merged_ate_front_frames, 1e-9);
  for (int i = 0; i < 20; ++i) in.merged[i].T_wc.translation().x() += 1.0;  // added frames misplaced
  r = ComputeRunMetrics(in);
  EXPECT_GT(*r.merged.ate_rmse, 0.1);
  EXPECT_LT(*r.merged_ate_front_frames, 1e-9);
  for (int i = 20; i < 40; ++i) in.merged[i].T_wc.translation().x() += 0.5;  // the front's frames bent
  r = ComputeRunMetrics(in);
  EXPECT_GT(*r.merged_ate_front_frames, 0.05);

  MergeAuditRow good{"merge", "front#0", "back#0", true, "", "", 40, 20, 0.01, 0.01, 0.011, 0.0105, false, ""};
  MergeAuditRow bad{"merge", "front#0", "back#1", false, "verification (pose_pairs): x", "pose_pairs", 40, 20,
                    0.01, 0.01, 0.2, 0.15, true, ""};
  MergeAuditRow harm = good;
  harm.harmful = true;
  r.merge_audit = {good, bad, harm};
  r.merge_audit_done = true;
  const nlohmann::json j = nlohmann::json::parse(FormatRunMetricsJson(r));
  EXPECT_EQ(j["merges_rejected"], 1);
  EXPECT_EQ(j["merges_harmful"], 1);
  EXPECT_EQ(j["merges_rejected_harmful"], 1);
  ASSERT_EQ(j["merge_audit"].size(), 3u);
  EXPECT_EQ(j["merge_audit"][1]["rejected_by"], "pose_pairs");
  EXPECT_FALSE(j["merge_audit"][0].contains("reason"));
  EXPECT_TRUE(j["merged_ate_front_frames"].is_number());
  // Frames any component poses: two components over frames 20-100 of 101.
  EXPECT_FALSE(j.contains("components_tracking_rate_frames"));
  in.components = {Transformed(in.ground_truth, 20, 60), Transformed(in.ground_truth, 50, 100)};
  r = ComputeRunMetrics(in);
  ASSERT_TRUE(r.components_rate_frames.has_value());
  EXPECT_NEAR(*r.components_rate_frames, 81.0 / 101.0, 1e-9);
  // Without an audit the keys are absent (not zeros that claim one was done).
  r.merge_audit_done = false;
  EXPECT_FALSE(nlohmann::json::parse(FormatRunMetricsJson(r)).contains("merges_harmful"));
}

TEST(RunMetrics, RejectsTooFewFrames) {
  RunMetricsInput in = BaseInput();
  in.frames.resize(1);
  EXPECT_THROW(ComputeRunMetrics(in), std::runtime_error);
}

TEST(RunMetrics, Percentiles) {
  EXPECT_FALSE(Median({}).has_value());
  EXPECT_DOUBLE_EQ(*Median({3, 1, 2}), 2);
  EXPECT_DOUBLE_EQ(*Median({4, 1, 2, 3}), 2.5);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank({5, 1, 4, 2, 3}, 95), 5);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank({5, 1, 4, 2, 3}, 40), 2);
  EXPECT_DOUBLE_EQ(*PercentileNearestRank({5, 1, 4, 2, 3}, 0), 1);
}

TEST(RunMetrics, ParsesFrontFramesAndSamples) {
  std::istringstream frames(
      "# t state submap ms\n"
      "1305031102.100000000 initializing -1 3.5\n"
      "1305031102.200000000 tracking 0 12.25 9 0 9\n"
      "\n"
      "1305031102.300000000 2 0\n"
      "1305031102.400000000 lost -1 0 0 1\n");
  const auto f = ParseFrontFrames(frames, "front_frames.txt");
  ASSERT_EQ(f.size(), 4u);
  EXPECT_FALSE(f[1].skipped);
  EXPECT_TRUE(f[3].skipped);
  EXPECT_EQ(f[0].t, kT0 + kDt);
  EXPECT_EQ(f[0].state, TrackingState::kInitializing);
  EXPECT_EQ(f[1].state, TrackingState::kTracking);
  EXPECT_EQ(f[1].submap_id, 0);
  EXPECT_DOUBLE_EQ(*f[1].ms, 12.25);
  EXPECT_EQ(f[1].wall, Timestamp{9'000'000'000});  // 7th column: wall_s
  EXPECT_FALSE(f[0].wall.has_value());
  EXPECT_EQ(f[2].state, TrackingState::kLost);
  EXPECT_FALSE(f[2].ms.has_value());

  std::istringstream samples("1305031102.1 S1 0\n1305031102.2 2 0\n1305031102.3 s3 1\n");
  const auto s = ParseFrontSamples(samples, "front_samples.txt");
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].set, 1);
  EXPECT_EQ(s[1].set, 2);
  EXPECT_EQ(s[2].set, 3);
  EXPECT_EQ(s[2].window_id, 1);
}

TEST(RunMetrics, BadRunFilesNameFileAndLine) {
  std::istringstream bad_state("1.0 tracking 0 1\n2.0 flying 0 1\n");
  try {
    ParseFrontFrames(bad_state, "front_frames.txt");
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("front_frames.txt:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("flying"), std::string::npos) << e.what();
  }
  std::istringstream bad_skip("1.0 lost -1 0 0 yes\n");
  EXPECT_THROW(ParseFrontFrames(bad_skip, "f"), std::runtime_error);
  std::istringstream bad_wall("1.0 lost -1 0 0 0 noon\n");
  EXPECT_THROW(ParseFrontFrames(bad_wall, "f"), std::runtime_error);
  std::istringstream unsorted("2.0 tracking 0\n1.0 tracking 0\n");
  EXPECT_THROW(ParseFrontFrames(unsorted, "f"), std::runtime_error);
  std::istringstream bad_set("1.0 4 0\n");
  EXPECT_THROW(ParseFrontSamples(bad_set, "s"), std::runtime_error);
  EXPECT_THROW(ReadFrontFrames("/nonexistent/front_frames.txt"), std::runtime_error);
}

TEST(RunMetrics, ReadsStatsFiles) {
  const TempDir tmp;
  const std::filesystem::path dir = tmp.Create();
  const std::string back = (dir / "back_stats.json").string();
  const std::string manager = (dir / "manager_stats.json").string();
  const std::string broken = (dir / "broken.json").string();
  std::ofstream(back) << R"({"windows": 4, "seconds": 81.5})";
  std::ofstream(manager) << R"({"merges": 3, "saved_frames": 200, "saved_frames_postculled": 150,
                               "submaps_front": 2, "submaps_back": 4})";
  std::ofstream(broken) << R"({"windows": "four", "seconds": 1})";
  RunCounts c;
  ReadBackStats(back, &c);
  ReadManagerStats(manager, &c);
  EXPECT_EQ(c.back_windows, 4);
  EXPECT_DOUBLE_EQ(c.back_seconds, 81.5);
  EXPECT_EQ(c.merges, 3);
  EXPECT_EQ(c.saved_frames, 200);
  EXPECT_EQ(c.saved_frames_postculled, 150);
  EXPECT_EQ(c.submaps_front, 2);
  EXPECT_EQ(c.submaps_back, 4);
  try {
    ReadBackStats(broken, &c);
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'windows'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadManagerStats(back, &c), std::runtime_error);  // keys missing
}

}  // namespace
}  // namespace rumi
