#include "manager/merge_replay.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "common/trajectory.h"
#include "manager/map_file.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

bool Has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// The three-submap scenario saved as a manager's raw submaps.
class MergeReplay : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(dir_.path());
    std::string why;
    ASSERT_TRUE(SaveSubmaps({&s_.front_a.submap, &s_.back.submap, &s_.front_b.submap}, raw_, &why)) << why;
    o_.map_path = raw_;
  }
  // Replays, returns what it printed.
  std::string Replay(const MergeReplayOptions& o, bool expect_ok = true, std::string* why = nullptr) {
    GlobalMap map;
    std::string w;
    EXPECT_TRUE(LoadReplayMap(o.map_path, o.back_pose_jump_ratio, true, &map, &w)) << w;
    ::testing::internal::CaptureStdout();
    EXPECT_EQ(ReplayMerges(&map, o, &w), expect_ok) << w;
    if (why) *why = w;
    return ::testing::internal::GetCapturedStdout();
  }

  const testing::Scenario s_ = testing::MakeScenario();
  TempDir dir_;
  const std::string raw_ = dir_ / "map.rumi.raw";
  MergeReplayOptions o_;
};

TEST_F(MergeReplay, LoadsTheRawSubmapsOrSaysWhy) {
  GlobalMap map;
  std::string why;
  ASSERT_TRUE(LoadReplayMap(raw_, 0, true, &map, &why)) << why;
  EXPECT_EQ(map.size(), 3u);
  const std::string bad = dir_ / "bad.rumi.raw";
  std::ofstream(bad) << "not a map";
  EXPECT_FALSE(LoadReplayMap(bad, 0, true, &map, &why));
  EXPECT_EQ(why.rfind("cannot load " + bad + ": ", 0), 0u) << why;
}

TEST_F(MergeReplay, MergesTheScenarioAndWritesTheTrajectory) {
  o_.trajectory_path = dir_ / "merged.txt";
  const std::string printed = Replay(o_);
  EXPECT_TRUE(Has(printed, "loop closure: ")) << printed;
  EXPECT_TRUE(Has(printed, "front#1 + back#1: merged=true")) << printed;
  EXPECT_TRUE(Has(printed, "post-culling: keyframes ")) << printed;
  EXPECT_TRUE(Has(printed, "submaps=3 components=1 largest_component_frames=111\n")) << printed;
  EXPECT_FALSE(Has(printed, "audit ")) << printed;
  EXPECT_EQ(ReadTumTrajectory(o_.trajectory_path).size(), 111u);
}

TEST_F(MergeReplay, AuditsAgainstTheGroundTruth) {
  Trajectory gt;
  for (size_t i = 0; i < s_.scene.timestamps.size(); ++i) gt.push_back({s_.scene.timestamps[i], s_.scene.T_wc[i]});
  o_.groundtruth_path = dir_ / "gt.txt";
  WriteTumTrajectory(o_.groundtruth_path, gt);
  o_.post_culling = false;
  const std::string printed = Replay(o_);
  EXPECT_TRUE(Has(printed, "audit ")) << printed;
  EXPECT_TRUE(Has(printed, "accepted=true")) << printed;
  EXPECT_FALSE(Has(printed, "post-culling")) << printed;
}

TEST_F(MergeReplay, AMissingGroundTruthIsAnError) {
  o_.groundtruth_path = dir_ / "no_such_gt.txt";
  std::string why;
  Replay(o_, false, &why);
  EXPECT_TRUE(Has(why, "no_such_gt.txt")) << why;
}

}  // namespace
}  // namespace rumi
