#include "common/process/signals.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "common/process/subprocess.h"
#include "common/testing/process.h"
#include "common/testing/temp_dir.h"
#include "common/testing/test_child.h"

namespace {

namespace fs = std::filesystem;

// A process that reacts like every rumi main: it notes a stop request and a
// reload in files, and keeps running (finishing its work) after a stop.
int Child(const std::string& mode) {
  if (mode != "signals") return 99;
  const std::string dir = std::getenv("RUMI_TEST_DIR");
  rumi::ProcessSignals::Install();
  int reloads = 0;
  rumi::ReloadOnHangup reload([&] { std::ofstream(dir + "/reload") << ++reloads << "\n"; });
  std::ofstream(dir + "/ready") << "1\n";
  bool noted = false;
  for (;;) {
    if (!noted && rumi::ProcessSignals::stop()->load()) {
      std::ofstream(dir + "/stopping") << rumi::ProcessSignals::stop_signal() << "\n";
      noted = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}
RUMI_TEST_CHILD_MODES(Child);

bool WaitFor(const fs::path& p, double seconds) {
  return rumi::test::WaitFor([&] { return fs::exists(p); }, seconds, std::chrono::milliseconds(10));
}

TEST(ProcessSignals, FirstSigtermStopsSecondKillsHangupReloads) {
  const rumi::TempDir tmp;
  const fs::path dir = tmp.Create();
  rumi::SpawnOptions so;
  so.argv = rumi::testing::ChildArgv();
  so.env = {rumi::testing::ChildEnv("signals"), "RUMI_TEST_DIR=" + dir.string()};
  std::string why;
  const pid_t pid = rumi::SpawnChild(so, &why);
  ASSERT_GT(pid, 0) << why;
  ASSERT_TRUE(WaitFor(dir / "ready", 10));
  ::kill(pid, SIGHUP);
  ASSERT_TRUE(WaitFor(dir / "reload", 10));
  ::kill(pid, SIGTERM);
  ASSERT_TRUE(WaitFor(dir / "stopping", 10));
  int sig = 0;
  std::ifstream(dir / "stopping") >> sig;
  EXPECT_EQ(sig, SIGTERM);
  int status = 0;
  EXPECT_EQ(::waitpid(pid, &status, WNOHANG), 0) << "the first SIGTERM must let it finish its work";
  ::kill(pid, SIGTERM);  // the second one ends it at once
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << status;
}

}  // namespace
