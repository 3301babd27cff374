#include "common/process/supervisor.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/process/process_info.h"
#include "common/process/subprocess.h"
#include "common/testing/process.h"
#include "common/testing/temp_dir.h"
#include "common/testing/test_child.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using rumi::test::WaitFor;

// The children of these tests.
int Child(const std::string& mode) {
  if (mode == "notify") {  // reports like a rumi process, then waits to be stopped
    rumi::Notifier n(0.0);
    n.Status("hello");
    n.Heartbeat({{"process", "test"}, {"frames", 42}});
    n.Ready();
    ::pause();
    return 0;
  }
  if (mode == "supervise-sleep") {  // a supervisor whose child must die with it
    rumi::Supervisor sup(rumi::SupervisorOptions{});
    rumi::ChildSpec c;
    c.name = "sleeper";
    c.argv = {"sleep", "60"};
    const int i = sup.Add(c);
    std::string why;
    if (!sup.Start(i, &why)) return 9;
    std::ofstream(std::getenv("RUMI_TEST_PIDFILE")) << sup.info(i).pid << "\n";
    ::pause();
    return 0;
  }
  return 99;
}
RUMI_TEST_CHILD_MODES(Child);

const auto& Seconds = rumi::test::SecondsSince;

bool Gone(pid_t pid) { return !rumi::ProcessRunning(pid); }

rumi::ChildSpec Shell(const std::string& name, const std::string& script) {
  rumi::ChildSpec c;
  c.name = name;
  c.argv = {"sh", "-c", script};
  return c;
}

// Polls until cond or the time is up.
template <typename F>
bool PollUntil(rumi::Supervisor* sup, F cond, double seconds, std::vector<rumi::Supervisor::Exit>* exits = nullptr) {
  const auto t0 = Clock::now();
  while (!cond() && Seconds(t0) < seconds) {
    for (const auto& e : sup->Poll(0.02))
      if (exits) exits->push_back(e);
  }
  return cond();
}

TEST(Supervisor, CrashedChildRestartsWithGrowingBackoffThenGivesUp) {
  rumi::SupervisorOptions o;
  o.restart = true;
  o.backoff_initial_s = 0.05;
  o.backoff_max_s = 1.0;
  o.crash_loop_starts = 3;
  o.crash_loop_window_s = 60;
  rumi::Supervisor sup(o);
  const int i = sup.Add(Shell("crasher", "exit 1"));
  std::string why;
  ASSERT_TRUE(sup.Start(i, &why)) << why;
  std::vector<rumi::Supervisor::Exit> exits;
  ASSERT_TRUE(PollUntil(&sup, [&] { return sup.info(i).state == rumi::ChildState::kGaveUp; }, 20, &exits));
  // Started once plus 3 restarts; the 4th crash is one too many.
  EXPECT_EQ(sup.info(i).starts, 4);
  EXPECT_EQ(sup.info(i).crashes, 4);
  ASSERT_EQ(exits.size(), 4u);
  for (size_t k = 0; k < 3; ++k) EXPECT_TRUE(exits[k].will_restart) << k;
  EXPECT_TRUE(exits[3].gave_up);
  EXPECT_DOUBLE_EQ(sup.info(i).backoff_s, 0.2);  // 0.05, 0.1, 0.2: doubled each time
  // No busy loop: once given up, it stays down.
  sup.Poll(0.2);
  EXPECT_EQ(sup.info(i).starts, 4);
}

TEST(Supervisor, DoneIsFinishedAndBadInputIsNotRestarted) {
  rumi::SupervisorOptions o;
  o.restart = true;
  o.backoff_initial_s = 0.01;
  rumi::Supervisor sup(o);
  const int done = sup.Add(Shell("done", "exit 0"));
  const int bad = sup.Add(Shell("bad", "exit 2"));
  const int cli = sup.Add(Shell("cli", "exit 109"));
  std::string why;
  for (int i : {done, bad, cli}) ASSERT_TRUE(sup.Start(i, &why)) << why;
  ASSERT_TRUE(PollUntil(&sup, [&] { return !sup.AnyRunning(); }, 10));
  sup.Poll(0.1);
  EXPECT_EQ(sup.info(done).state, rumi::ChildState::kExited);
  EXPECT_EQ(sup.info(bad).state, rumi::ChildState::kGaveUp);
  EXPECT_EQ(sup.info(cli).state, rumi::ChildState::kGaveUp);
  for (int i : {done, bad, cli}) EXPECT_EQ(sup.info(i).starts, 1);
}

TEST(Supervisor, NotifyMessagesOfAChildLandInItsInfo) {
  rumi::SupervisorOptions o;
  o.notify_name = "rumi-supervisor-test-" + std::to_string(::getpid());
  rumi::Supervisor sup(o);
  rumi::ChildSpec c;
  c.name = "reporter";
  c.argv = rumi::testing::ChildArgv();
  c.env = {rumi::testing::ChildEnv("notify")};
  const int i = sup.Add(c);
  std::string why;
  ASSERT_TRUE(sup.Start(i, &why)) << why;
  ASSERT_TRUE(PollUntil(&sup, [&] { return sup.info(i).ready; }, 10));
  EXPECT_EQ(sup.info(i).status_line, "hello");
  EXPECT_EQ(sup.info(i).status.value("frames", 0), 42);
  EXPECT_LT(sup.info(i).heartbeat_age_s(), 10.0);
  sup.StopAll({i}, 5);
  EXPECT_FALSE(sup.AnyRunning());
}

TEST(Supervisor, StopAllStopsInOrderAndKillsWhatIgnoresSigterm) {
  const rumi::TempDir tmp;
  const fs::path dir = tmp.Create();
  rumi::Supervisor sup(rumi::SupervisorOptions{});
  const std::string order = (dir / "order").string();
  const int polite = sup.Add(Shell("polite", "trap 'echo polite >> " + order + "; exit 0' TERM; while :; do sleep 0.05; done"));
  const int stubborn = sup.Add(Shell("stubborn", "trap '' TERM; sleep 30 & echo $! > " + (dir / "bg").string() +
                                                     "; while :; do sleep 0.05; done"));
  std::string why;
  ASSERT_TRUE(sup.Start(polite, &why)) << why;
  ASSERT_TRUE(sup.Start(stubborn, &why)) << why;
  WaitFor([&] { return fs::exists(dir / "bg"); }, 5, std::chrono::milliseconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // both traps set
  pid_t bg = 0;
  std::ifstream(dir / "bg") >> bg;
  ASSERT_GT(bg, 0);
  const auto t0 = Clock::now();
  sup.StopAll({polite, stubborn}, 1.0);
  const double s = Seconds(t0);
  EXPECT_LT(s, 3.0);
  EXPECT_FALSE(sup.AnyRunning());
  std::ifstream in(order);
  std::string first;
  in >> first;
  EXPECT_EQ(first, "polite");
  EXPECT_TRUE(WIFSIGNALED(sup.info(stubborn).last_status));  // killed at the deadline
  EXPECT_TRUE(WaitFor([&] { return Gone(bg); }, 3, std::chrono::milliseconds(10)))
      << "a grandchild in the stubborn child's group survived";
}

// PR_SET_PDEATHSIG: a supervisor killed with SIGKILL leaves no orphan.
TEST(Supervisor, ChildrenDieWithASupervisorThatIsKilled) {
  const rumi::TempDir tmp;
  const fs::path pidfile = tmp.Create() / "sleeper.pid";
  rumi::SpawnOptions so;
  so.argv = rumi::testing::ChildArgv();
  so.env = {rumi::testing::ChildEnv("supervise-sleep"), "RUMI_TEST_PIDFILE=" + pidfile.string()};
  std::string why;
  const pid_t helper = rumi::SpawnChild(so, &why);
  ASSERT_GT(helper, 0) << why;
  pid_t sleeper = 0;
  WaitFor([&] { return std::ifstream(pidfile) >> sleeper, sleeper != 0; }, 10, std::chrono::milliseconds(10));
  ASSERT_GT(sleeper, 0);
  ASSERT_FALSE(Gone(sleeper));
  ::kill(helper, SIGKILL);
  ::waitpid(helper, nullptr, 0);
  EXPECT_TRUE(WaitFor([&] { return Gone(sleeper); }, 5, std::chrono::milliseconds(10))) << "orphan left behind";
}

}  // namespace
