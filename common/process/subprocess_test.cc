#include "common/process/subprocess.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

std::string TempPath(const std::string& name) {
  static const TempDir dir;  // removed at exit
  return (dir.Create() / name).string();
}

TEST(Subprocess, SuccessAndLog) {
  const std::string log = TempPath("ok.log");
  std::filesystem::remove(log);
  RunRequest r;
  r.argv = {"sh", "-c", "echo hello; echo oops >&2"};
  r.log_path = log;
  const RunResult res = RunProcess(r);
  EXPECT_EQ(res.status, RunStatus::kOk) << res.message;
  EXPECT_EQ(res.exit_code, 0);
  EXPECT_EQ(FileTail(log), "hello\noops\n");
  std::filesystem::remove(log);
}

TEST(Subprocess, ExtraEnvironmentOverridesAndKeepsTheRest) {
  const std::string log = TempPath("env.log");
  std::filesystem::remove(log);
  ::setenv("RUMI_RUNNER_TEST_KEEP", "kept", 1);
  ::setenv("RUMI_RUNNER_TEST_OVER", "old", 1);
  RunRequest r;
  r.argv = {"sh", "-c", "echo $RUMI_RUNNER_TEST_KEEP $RUMI_RUNNER_TEST_OVER $GLOG_logtostderr"};
  r.log_path = log;
  r.env = {"RUMI_RUNNER_TEST_OVER=new", "GLOG_logtostderr=1"};
  const RunResult res = RunProcess(r);
  EXPECT_EQ(res.status, RunStatus::kOk) << res.message;
  EXPECT_EQ(FileTail(log), "kept new 1\n");
  EXPECT_STREQ(::getenv("RUMI_RUNNER_TEST_OVER"), "old");  // ours untouched
  std::filesystem::remove(log);
}

TEST(Subprocess, NonZeroExitIsFailureWithLogTail) {
  const std::string log = TempPath("fail.log");
  std::filesystem::remove(log);
  RunRequest r;
  r.argv = {"sh", "-c", "echo 'no images found'; exit 3"};
  r.log_path = log;
  const RunResult res = RunProcess(r);
  EXPECT_EQ(res.status, RunStatus::kFailed);
  EXPECT_EQ(res.exit_code, 3);
  EXPECT_NE(res.message.find("code 3"), std::string::npos) << res.message;
  EXPECT_NE(res.message.find("no images found"), std::string::npos) << res.message;
  std::filesystem::remove(log);
}

TEST(Subprocess, MissingExecutableIsLaunchFailure) {
  RunRequest r;
  r.argv = {"/nonexistent/rumi-colmap-xyz", "mapper"};
  const RunResult res = RunProcess(r);
  EXPECT_EQ(res.status, RunStatus::kLaunchFailed);
  EXPECT_NE(res.message.find("/nonexistent/rumi-colmap-xyz"), std::string::npos) << res.message;
}

// Running, as opposed to gone or a zombie: a killed grandchild is reparented
// to PID 1, which may take its time to reap it.
bool Alive(pid_t pid) {
  if (::kill(pid, 0) != 0) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string comm_and_rest;
  if (!std::getline(stat, comm_and_rest)) return false;
  const size_t close = comm_and_rest.rfind(')');  // state follows "pid (comm) "
  return close == std::string::npos || close + 2 >= comm_and_rest.size() || comm_and_rest[close + 2] != 'Z';
}

TEST(Subprocess, TimeoutKillsTheWholeProcessGroup) {
  // The child starts a grandchild that would outlive a plain kill of the child.
  const std::string pid_file = TempPath("grandchild.pid");
  std::filesystem::remove(pid_file);
  RunRequest r;
  r.argv = {"sh", "-c", "sleep 30 & echo $! > " + pid_file + "; wait"};
  r.timeout_s = 1.0;  // long enough for a loaded machine to start the grandchild
  const auto t0 = std::chrono::steady_clock::now();
  const RunResult res = RunProcess(r);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(res.status, RunStatus::kTimeout);
  EXPECT_NE(res.message.find("timed out"), std::string::npos) << res.message;
  EXPECT_LT(s, 10.0);  // well before the 30 s sleep (not a speed check)
  pid_t grandchild = 0;
  std::ifstream(pid_file) >> grandchild;
  ASSERT_GT(grandchild, 0);
  // The grandchild is reparented to init, which reaps it; give it a moment.
  for (int i = 0; i < 100 && Alive(grandchild); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(Alive(grandchild));
  std::filesystem::remove(pid_file);
}

TEST(Subprocess, CancelStopsTheChild) {
  std::atomic<bool> cancel{false};
  RunRequest r;
  r.argv = {"sleep", "30"};
  r.cancel = &cancel;
  std::thread t([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    cancel = true;
  });
  const RunResult res = RunProcess(r);
  t.join();
  EXPECT_EQ(res.status, RunStatus::kCancelled);
}

TEST(Subprocess, ChildRunsAtIdlePriority) {
  const std::string log = TempPath("prio.log");
  std::filesystem::remove(log);
  RunRequest r;
  // Field 41 of /proc/self/stat is the scheduling policy (5 = SCHED_IDLE),
  // field 19 the nice value; cat reads its own stat.
  r.argv = {"cat", "/proc/self/stat"};
  r.log_path = log;
  r.low_priority = true;
  ASSERT_EQ(RunProcess(r).status, RunStatus::kOk);
  std::string stat = FileTail(log, 4096);
  // Skip "pid (comm)" which may contain spaces.
  stat = stat.substr(stat.rfind(')') + 2);
  std::istringstream ss(stat);
  std::vector<std::string> f((std::istream_iterator<std::string>(ss)), {});
  ASSERT_GT(f.size(), 38u);
  const int policy = std::stoi(f[38]);  // field 41 (1-based) after dropping 2
  const int nice = std::stoi(f[16]);    // field 19
  EXPECT_TRUE(policy == 5 || nice == 19) << "policy " << policy << " nice " << nice;
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace rumi
