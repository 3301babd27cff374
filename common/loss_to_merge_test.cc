#include "common/loss_to_merge.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/eval_table.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

constexpr Timestamp kT0 = 1'000'000'000'000, kDt = 100'000'000;  // 10 fps
constexpr Timestamp kWall0 = 1'800'000'000'000'000'000;          // the front's clock at frame 0

// One line per character: t tracking, c coarse, l lost, i initializing,
// s skipped; frame k is done at kWall0 + k x 0.1 s.
std::vector<FrontFrameLine> Lines(const std::string& states) {
  std::vector<FrontFrameLine> out;
  for (size_t k = 0; k < states.size(); ++k) {
    FrontFrameLine l;
    l.t = kT0 + Timestamp(k) * kDt;
    l.wall = kWall0 + Timestamp(k) * kDt;
    const char c = states[k];
    l.state = c == 't' ? TrackingState::kTracking
              : c == 'c' ? TrackingState::kCoarse
              : c == 'i' ? TrackingState::kInitializing
                         : TrackingState::kLost;
    l.skipped = c == 's';
    out.push_back(l);
  }
  return out;
}

BackSubmapTimes Back(int64_t id, std::vector<int> frames, std::optional<double> joined_after_s) {
  BackSubmapTimes b;
  b.id = id;
  for (int k : frames) b.keyframes.push_back(kT0 + k * kDt);
  if (joined_after_s) b.joined_wall = kWall0 + Timestamp(*joined_after_s * 1e9);
  return b;
}

TEST(LossToMerge, EveryLossAfterTheFirstTrackedFrameAndTheFirstBackSubmapThatJoined) {
  // Frames 0-1 start-up (not a loss); 4 skipped inside tracking (not a loss);
  // loss A 7-10 (lost, initializing); coarse counts as tracked; loss B 14-15 to the end.
  const auto lines = Lines("iittsttlliicctll");
  const std::vector<BackSubmapTimes> back = {
      Back(1, {2, 3}, 1.0),       // tracked frames only: merges no loss
      Back(2, {5, 7, 10}, 30.0),  // holds lost frames 7 and 10
      Back(3, {8}, 20.5),         // holds lost frame 8, joined earlier: this one merged loss A
      Back(4, {14, 15}, std::nullopt)};  // loss B's frames, never joined
  const auto losses = ComputeLossToMerge(lines, back);
  ASSERT_EQ(losses.size(), 2u);
  EXPECT_EQ(losses[0].first, kT0 + 7 * kDt);
  EXPECT_EQ(losses[0].last, kT0 + 10 * kDt);
  EXPECT_EQ(losses[0].frames, 4);
  ASSERT_TRUE(losses[0].seconds.has_value());
  EXPECT_NEAR(*losses[0].seconds, 20.5 - 0.7, 1e-9);  // from the first lost frame's wall time
  EXPECT_EQ(losses[0].back_submap, 3);
  EXPECT_EQ(losses[1].first, kT0 + 14 * kDt);
  EXPECT_EQ(losses[1].frames, 2);
  EXPECT_FALSE(losses[1].seconds.has_value());
  const LossToMergeSummary s = SummarizeLossToMerge(losses);
  EXPECT_EQ(s.losses, 2);
  EXPECT_EQ(s.merged, 1);
  EXPECT_NEAR(*s.p50_s, 19.8, 1e-9);
  EXPECT_NEAR(*s.max_s, 19.8, 1e-9);
  EXPECT_FALSE(SummarizeLossToMerge({}).p50_s.has_value());
}

TEST(LossToMerge, NoWallTimesNoFigures) {
  auto lines = Lines("ttll");
  lines[2].wall.reset();
  EXPECT_TRUE(ComputeLossToMerge(lines, {}).empty());
  EXPECT_TRUE(ComputeLossToMerge(Lines("iiii"), {}).empty());  // never tracked: no loss
}

class LossToMergeFiles : public ::testing::Test {
 protected:
  TempDir tmp_;
  fs::path dir_ = tmp_.Create();
  std::string Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
};

TEST_F(LossToMergeFiles, JoinsTheBacksKeyframesWithTheManagersJoinTimes) {
  const std::string back = Write("back_stats.json", R"({"per_window": [
      {"window_id": 0, "submaps": [7, 8], "submap_timestamps": [["1000.6", "1000.7"], ["1000.9"]]},
      {"window_id": 1, "status": "failed"}]})");
  const std::string manager = Write("manager_stats.json", R"({"back_submap_times": [
      {"id": 7, "received_wall_s": 1800000010.0, "joined_wall_s": 1800000012.5},
      {"id": 8, "received_wall_s": 1800000011.0, "joined_wall_s": null}]})");
  const auto b = ReadBackSubmapTimes(back, manager);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].id, 7);
  ASSERT_EQ(b[0].keyframes.size(), 2u);
  EXPECT_EQ(b[0].keyframes[1], kT0 + 7 * kDt);
  ASSERT_TRUE(b[0].joined_wall.has_value());
  EXPECT_NEAR(NsToSeconds(*b[0].joined_wall), 1800000012.5, 1e-6);
  EXPECT_FALSE(b[1].joined_wall.has_value());
  // An older manager without the key: no join times, no error.
  EXPECT_FALSE(ReadBackSubmapTimes(back, Write("old.json", "{}"))[0].joined_wall.has_value());
}

TEST_F(LossToMergeFiles, MalformedFilesNameTheFile) {
  const std::string ok_back = Write("b.json", R"({"per_window": []})");
  const std::string bad_manager = Write("m.json", R"({"back_submap_times": [{"id": "seven"}]})");
  try {
    ReadBackSubmapTimes(ok_back, bad_manager);
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("m.json"), std::string::npos) << e.what();
  }
  const std::string bad_back = Write("bb.json", R"({"per_window": [{"submaps": [1], "submap_timestamps": []}]})");
  EXPECT_THROW(ReadBackSubmapTimes(bad_back, Write("m2.json", "{}")), std::runtime_error);
  EXPECT_THROW(ReadBackSubmapTimes((dir_ / "missing.json").string(), bad_manager), std::runtime_error);
  EXPECT_THROW(ReadBackSubmapTimes(Write("nj.json", "{"), Write("m3.json", "{}")), std::runtime_error);
}

TEST(LossToMerge, MetricsJsonCarriesThemToTheTable) {
  RunMetricsReport r;
  r.sequence = "s";
  r.loss_to_merge = ComputeLossToMerge(Lines("ttllttll"), {Back(1, {2}, 5.2)});
  const nlohmann::json j = nlohmann::json::parse(FormatRunMetricsJson(r));
  EXPECT_EQ(j["losses"], 2);
  EXPECT_EQ(j["losses_merged"], 1);
  EXPECT_NEAR(j["loss_to_merge_p50_s"].get<double>(), 5.0, 1e-9);
  EXPECT_NEAR(j["loss_to_merge_max_s"].get<double>(), 5.0, 1e-9);
  ASSERT_EQ(j["loss_to_merge"].size(), 2u);
  EXPECT_TRUE(j["loss_to_merge"][1]["seconds"].is_null());
  EXPECT_EQ(j["loss_to_merge"][0]["back_submap"], 1);
  const RunMetrics m = ParseRunMetrics(FormatRunMetricsJson(r), "metrics.json");
  ASSERT_TRUE(m.loss_to_merge_s.has_value());
  ASSERT_EQ(m.loss_to_merge_s->size(), 2u);
  EXPECT_NEAR(*(*m.loss_to_merge_s)[0], 5.0, 1e-9);
}

}  // namespace
}  // namespace rumi
