#include "ipc/daemon_status.h"

#include "common/process/process_info.h"

#include <gtest/gtest.h>

#include <sstream>
#include <vector>

namespace rumi {
namespace {

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string x; std::getline(ss, x, ',');) out.push_back(x);
  return out;
}

TEST(DaemonStatus, CsvGivesEachChildsPrivateAndSharedMemory) {
  const nlohmann::json st = {
      {"uptime_s", 60},
      {"rumid", {{"rss_mib", 9}, {"fds", 8}}},
      {"children",
       {{{"name", "rumi-front"}, {"rss_mib", 250.4}, {"private_mib", 99.6}, {"shared_mib", 84}, {"fds", 10}},
        {{"name", "rumi-manager"}, {"rss_mib", 400}, {"private_mib", 390}, {"shared_mib", 2}, {"fds", 14}}}}};
  const std::string csv = DaemonStatusCsv(st, true);
  const size_t nl = csv.find('\n');
  ASSERT_NE(nl, std::string::npos);
  const std::vector<std::string> h = Split(csv.substr(0, nl));
  const std::vector<std::string> v = Split(csv.substr(nl + 1, csv.size() - nl - 2));
  ASSERT_EQ(h.size(), v.size());
  auto at = [&](const std::string& name) {
    for (size_t i = 0; i < h.size(); ++i)
      if (h[i] == name) return v[i];
    return std::string("missing");
  };
  EXPECT_EQ(h.front(), "uptime_s");
  EXPECT_EQ(at("front_rss_mib"), "250.4");
  EXPECT_EQ(at("front_private_mib"), "99.6");
  EXPECT_EQ(at("front_shared_mib"), "84");
  EXPECT_EQ(at("manager_private_mib"), "390");
  EXPECT_EQ(at("back_private_mib"), "");  // no such child: empty, not a number
  // The new columns come last, so scripts reading older columns by position still work.
  EXPECT_EQ(h[h.size() - 6], "front_private_mib");
  EXPECT_EQ(h[h.size() - 7], "windows_joined");

  const std::string text = FormatDaemonStatus(st, true);
  EXPECT_NE(text.find("rumi-front 250 MiB (100 private, 10 fds)"), std::string::npos) << text;
}

// rumi status: a rumid that is gone, or another process under its old pid,
// is not running; one that stopped writing status.json is stale (#50.5: a
// stale file read as "running").
TEST(DaemonStatus, LivenessFromPidIdentityAndTheLastWrite) {
  const ProcessId me = SelfProcessId();
  nlohmann::json st = {{"pid", int(me.pid)},       {"pid_start_ticks", me.start_ticks}, {"state", "running"},
                       {"updated_unix_s", 1000.0}, {"status_interval_s", 1.0}};
  DaemonLiveness l = CheckDaemonLiveness(st, 1003.0);
  EXPECT_TRUE(l.alive);
  EXPECT_FALSE(l.stale);
  EXPECT_DOUBLE_EQ(l.age_s, 3.0);
  l = CheckDaemonLiveness(st, 1011.0);  // 11 s: over max(10 s, 5 intervals)
  EXPECT_TRUE(l.alive);
  EXPECT_TRUE(l.stale);
  st["status_interval_s"] = 5.0;  // 25 s allowed
  EXPECT_FALSE(CheckDaemonLiveness(st, 1011.0).stale);
  st["pid_start_ticks"] = me.start_ticks + 1;  // the pid reused by another process
  EXPECT_FALSE(CheckDaemonLiveness(st, 1001.0).alive);
  st["pid_start_ticks"] = me.start_ticks;
  st["state"] = "stopped";
  EXPECT_FALSE(CheckDaemonLiveness(st, 1001.0).alive);
  EXPECT_FALSE(CheckDaemonLiveness(st, 2000.0).stale);  // not running is not stale
  st = {{"pid", int(me.pid)}, {"state", "running"}};  // an older file: pid only, no time
  l = CheckDaemonLiveness(st, 1001.0);
  EXPECT_TRUE(l.alive);
  EXPECT_FALSE(l.stale);
}

}  // namespace
}  // namespace rumi
