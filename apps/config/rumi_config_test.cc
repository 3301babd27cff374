#include "apps/config/rumi_config.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

namespace rumi {
namespace {

namespace fs = std::filesystem;
const std::string kConfigs = std::string(RUMI_SOURCE_DIR) + "/configs";

std::string ErrorOf(const std::string& yaml) {
  try {
    LoadRumiConfigString(yaml, "c.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// Every shipped config loads as every process loads it: all sections, strictly.
TEST(RumiConfig, EveryShippedConfigLoadsStrictly) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kConfigs)) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().string());
    const RumiConfig c = LoadRumiConfig(e.path().string());
    EXPECT_TRUE(c.has_camera);
    ++n;
  }
  EXPECT_GE(n, 8);
  const RumiConfig d = LoadRumiConfig(kConfigs + "/daemon.yaml");
  EXPECT_EQ(d.source.kind, "capture");
  EXPECT_EQ(d.daemon.child_output, "journal");
}

// A typo anywhere fails every process, not only the one owning the section.
TEST(RumiConfig, ATypoInAnySectionIsAnError) {
  for (const std::string section :
       {"camera", "source", "front", "sampler", "publisher", "back", "manager", "ipc", "daemon"}) {
    const std::string e = ErrorOf(section + ":\n  no_such_key: 1\n");
    EXPECT_NE(e.find("c.yaml: unknown key: '" + section + ".no_such_key'"), std::string::npos) << e;
  }
  EXPECT_NE(ErrorOf("mangaer: {}\n").find("'mangaer'"), std::string::npos);
  EXPECT_NE(ErrorOf("log_level: loud\n").find("log_level"), std::string::npos);
  EXPECT_NE(ErrorOf("manager: {rebuild_max_duty: 2}\n").find("manager.rebuild_max_duty"), std::string::npos);
  EXPECT_NE(ErrorOf("manager: {map_save_max_duty: 0}\n").find("manager.map_save_max_duty"), std::string::npos);
  EXPECT_NE(ErrorOf("publisher: {queue_capacity: 0}\n").find("publisher.queue_capacity"), std::string::npos);
  EXPECT_NE(ErrorOf("daemon: {child_output: syslog}\n").find("daemon.child_output"), std::string::npos);
  EXPECT_NE(ErrorOf("source: {kind: vhs}\n").find("source.kind"), std::string::npos);
  EXPECT_NE(ErrorOf("back: {peer_timeout_s: 0}\n").find("back.peer_timeout_s"), std::string::npos);
}

TEST(RumiConfig, ProductionRuntimeOptionsAreInYaml) {
  const RumiConfig c = LoadRumiConfigString(
      "publisher: {queue_capacity: 8, resend_interval_s: 1.5}\n"
      "manager: {rebuild_interval_s: 2, rebuild_max_duty: 0.25, search_n: 4, map_save_interval_s: 120}\n"
      "back: {wait_for_consumer_s: 5, max_queue_windows: 3}\n"
      "source: {kind: capture, path: 'http://10.0.0.2:81/stream', stall_timeout_s: 2}\n"
      "daemon: {stop_timeout_s: 5, child_output: files}\n");
  EXPECT_EQ(c.publisher.queue_capacity, 8);
  EXPECT_EQ(c.publisher.resend_interval_s, 1.5);
  EXPECT_EQ(c.manager_loop.rebuild_interval_s, 2);
  EXPECT_EQ(c.manager_loop.rebuild_max_duty, 0.25);
  EXPECT_EQ(c.manager_loop.map_save_interval_s, 120);
  EXPECT_EQ(c.manager.search_n, 4);
  EXPECT_EQ(c.back.wait_for_consumer_s, 5);
  EXPECT_EQ(c.source.path, "http://10.0.0.2:81/stream");
  EXPECT_EQ(c.daemon.stop_timeout_s, 5);
}

// Two specs share `manager:`: no key may be declared by both, or one would
// silently win.
TEST(RumiConfig, SectionsSharedBySpecsDeclareEachKeyOnce) {
  std::set<std::string> keys;
  for (const auto& k : ManagerOptions::Spec().Keys()) EXPECT_TRUE(keys.insert(k).second) << k;
  for (const auto& k : ManagerLoopOptions::Spec().Keys()) EXPECT_TRUE(keys.insert(k).second) << k;
}

TEST(RumiConfig, DescribeListsEverySectionAndChangesAreFound) {
  const auto info = DescribeRumiConfig(RumiConfig());
  std::set<std::string> sections;
  size_t options = 0;
  for (const auto& s : info) {
    sections.insert(s.section);
    options += s.options.size();
  }
  EXPECT_EQ(sections, (std::set<std::string>{"", "camera", "source", "front", "sampler", "publisher", "back",
                                             "manager", "grid", "dds", "ipc", "daemon", "view"}));
  EXPECT_GT(options, 150u);
  RumiConfig a, b;
  b.log_level = "debug";
  b.front.orb.num_levels = 4;  // nested: front.orb.num_levels
  b.manager_loop.rebuild_interval_s = 3;
  EXPECT_EQ(ChangedSections(a, b), (std::vector<std::string>{"log_level", "front", "manager"}));
  EXPECT_TRUE(ChangedSections(a, a).empty());
}

}  // namespace
}  // namespace rumi

namespace rumi {
namespace {

std::string SetError(const std::string& file, const std::vector<std::string>& sets) {
  try {
    LoadRumiConfig(file, sets);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// `--set KEY=VALUE` reaches the options through the file's reader: over the
// file's value, with its range, its type and its unknown-key check (the
// per-main overrides it replaced had ranges of their own, and none at all
// for some).
TEST(RumiConfig, CommandLineSetsAreReadAsTheFileIs) {
  const std::string file = ::testing::TempDir() + "/sets_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(file) << "manager:\n  rebuild_interval_s: 5\nback:\n  wait_for_producer_s: 7\n";
  const RumiConfig c = LoadRumiConfig(
      file, {"manager.rebuild_interval_s=0.2", "publisher.wait_for_consumers_s=0", "back.keep_workspaces=true",
             "front.init_backfill=false"});
  EXPECT_DOUBLE_EQ(c.manager_loop.rebuild_interval_s, 0.2);  // over the file's 5
  EXPECT_DOUBLE_EQ(c.back.wait_for_producer_s, 7);           // the file's, untouched
  EXPECT_DOUBLE_EQ(c.publisher.wait_for_consumers_s, 0);
  EXPECT_TRUE(c.back.keep_workspaces);
  EXPECT_FALSE(c.front.init_backfill);
  // Without a file: over the defaults.
  EXPECT_DOUBLE_EQ(LoadRumiConfig("", {"manager.rebuild_max_duty=0.5"}).manager_loop.rebuild_max_duty, 0.5);
  // Refused as the file's keys are, naming the key.
  EXPECT_NE(SetError(file, {"manager.rebuild_max_duty=2"}).find("manager.rebuild_max_duty"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager.wait_for_producers_s=86401"}).find("outside"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager.no_such=1"}).find("manager.no_such"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager.rebuild_interval_s=abc"}).find("wrong type"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager"}).find("KEY=VALUE"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager.rebuild_interval_s.x=1"}).find("not a section"), std::string::npos);
  EXPECT_NE(SetError(file, {"manager.rebuild_interval_s=[1, 2]"}).find("single value"), std::string::npos);
  std::remove(file.c_str());
}

}  // namespace
}  // namespace rumi
