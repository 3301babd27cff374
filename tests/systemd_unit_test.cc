// The unit template as systemd reads it: `systemd-analyze verify` on
// configs/systemd/rumid@.service (ExecStart pointed at the rumid just built)
// must pass without a single warning, and the unit must hold what the
// service needs (notify, watchdog, restarts, its own user, state and config
// folders, hardening).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/testing/process.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using rumi::test::Slurp;

const std::string kUnit = std::string(RUMI_SOURCE_DIR) + "/configs/systemd/rumid@.service";

std::string Rumid() { return rumi::test::BinPath("rumid"); }

// Output (stdout + stderr) and exit code of `systemd-analyze verify`.
int Verify(const std::string& unit_text, const fs::path& dir, const std::string& name, std::string* output) {
  fs::create_directories(dir);
  std::ofstream(dir / "rumid@.service") << unit_text;
  const fs::path log = dir / "verify.log";
  const int code = rumi::test::RunLogged("systemd-analyze verify " + (dir / name).string(), log);
  *output = Slurp(log);
  return code;
}

TEST(SystemdUnit, VerifiesCleanlyAndHoldsWhatTheServiceNeeds) {
  RUMI_REQUIRE(std::system("command -v systemd-analyze > /dev/null 2>&1") == 0,
               "systemd-analyze is not installed (Debian package systemd; scripts/setup.sh installs it)");
  std::string unit = Slurp(kUnit);
  ASSERT_FALSE(unit.empty()) << kUnit;
  const std::string exec = "/usr/local/bin/rumid";
  ASSERT_NE(unit.find(exec), std::string::npos);
  unit.replace(unit.find(exec), exec.size(), Rumid());
  const rumi::TempDir tmp;
  const fs::path dir = tmp.path();
  std::string out;
  EXPECT_EQ(Verify(unit, dir / "ok", "rumid@robot1.service", &out), 0) << out;
  EXPECT_EQ(out, "") << "systemd-analyze warned";
  for (const char* line :
       {"Type=notify", "WatchdogSec=", "Restart=on-failure", "User=rumi", "StateDirectory=rumi/%i",
        "ConfigurationDirectory=rumi", "ProtectSystem=strict", "NoNewPrivileges=yes", "KillMode=mixed",
        "DeviceAllow=char-video4linux rw", "ExecReload=/bin/kill -HUP $MAINPID", "--config /etc/rumi/%i.yaml"}) {
    EXPECT_NE(unit.find(line), std::string::npos) << line;
  }
  // Least privilege, as systemd scores it (issue #50: <= 3.0; 5.5 before
  // the capability bounding set, ProtectProc= and the system-call filter).
  {
    const fs::path unit_path = dir / "score" / "rumid@robot1.service";
    fs::create_directories(unit_path.parent_path());
    std::ofstream(unit_path) << unit;
    const std::string text =
        rumi::test::RunCommand("systemd-analyze security --offline=true " + unit_path.string()).out;
    const size_t at = text.find("Overall exposure level for");
    ASSERT_NE(at, std::string::npos) << text;
    const double score = std::atof(text.c_str() + text.find(": ", at) + 2);
    std::printf("systemd-analyze security: %.1f\n", score);
    EXPECT_LE(score, 3.0) << text.substr(at);
    for (const char* line : {"CapabilityBoundingSet=\n", "SystemCallFilter=@system-service", "ProtectProc=invisible"})
      EXPECT_NE(unit.find(line), std::string::npos) << line;
  }
  // The check can fail: a misspelt key and a missing executable are reported.
  std::string bad = unit;
  bad.replace(bad.find("Type=notify"), 11, "Typ=notify");
  EXPECT_NE(Verify(bad, dir / "bad", "rumid@robot1.service", &out), -1);
  EXPECT_NE(out.find("Unknown key"), std::string::npos) << out;
  std::string missing = unit;
  missing.replace(missing.find(Rumid()), Rumid().size(), "/nonexistent/rumid");
  EXPECT_NE(Verify(missing, dir / "missing", "rumid@robot1.service", &out), 0) << out;
}

}  // namespace
