#include "manager/session_replay.h"

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) v.push_back(line);
  return v;
}

// The three-submap scenario as a saved session.
class SessionReplay : public ::testing::Test {
 protected:
  SessionReplay() {
    spdlog::set_level(spdlog::level::warn);  // as rumi-merge-replay: its log would mix with the rows
    for (const Submap* s : {&s_.front_a.submap, &s_.back.submap, &s_.front_b.submap}) {
      std::string why;
      EXPECT_GE(raw_.AddSubmap(*s, &why), 0) << why;
    }
    o_.service.out_dir = dir_.str();
  }
  // Replays, returns the lines printed.
  std::vector<std::string> Replay() {
    std::string why;
    ::testing::internal::CaptureStdout();
    EXPECT_TRUE(ReplaySession(raw_, o_, &why)) << why;
    return Lines(::testing::internal::GetCapturedStdout());
  }

  const testing::Scenario s_ = testing::MakeScenario();
  GlobalMap raw_;
  TempDir dir_;
  SessionReplayOptions o_;
};

TEST_F(SessionReplay, RebuildsAfterEveryNSubmapsAndAtTheEnd) {
  o_.rebuild_every = 2;
  const std::vector<std::string> lines = Replay();
  ASSERT_EQ(lines.size(), 3u) << ::testing::PrintToString(lines);  // the header, after 2 submaps, after the last
  EXPECT_EQ(lines[0].rfind("rebuild\tsubmaps\tkeyframes\t", 0), 0u) << lines[0];
  EXPECT_EQ(lines[1].rfind("1\t2\t", 0), 0u) << lines[1];
  EXPECT_EQ(lines[2].rfind("2\t3\t", 0), 0u) << lines[2];
  EXPECT_TRUE(std::filesystem::exists(dir_ / "map.rumi"));  // the last rebuild saves the map files
}

TEST_F(SessionReplay, ResendsTheFrontSubmapsWhileTheyGrow) {
  const size_t finished_only = Replay().size();
  EXPECT_EQ(finished_only, 4u);
  o_.resend_interval_s = 0.5;
  o_.resend_min_keyframes = 2;
  o_.bake = true;
  const std::vector<std::string> lines = Replay();
  EXPECT_GT(lines.size(), finished_only);
  EXPECT_EQ(lines.back().rfind(std::to_string(lines.size() - 1) + "\t3\t", 0), 0u) << lines.back();
}

}  // namespace
}  // namespace rumi
