// Cross-process test of rumi-manager: this test acts as the front and back
// producers on the shared-memory channels of a private instance.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include <sched.h>
#include <sys/mount.h>

#include "common/process/exit_codes.h"
#include "common/process/process_info.h"
#include "common/process/subprocess.h"
#include "common/testing/test_child.h"
#include "common/timestamp.h"
#include "ipc/channels.h"
#include "manager/map_file.h"
#include "manager/testing/test_scenario.h"
#include "tests/rumi_cli_util.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

using test::Slurp;

std::string ManagerBinary() { return test::BinPath("rumi-manager"); }

// Starts rumi-manager with its output appended to `log`.
pid_t Spawn(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> argv = {ManagerBinary()};
  argv.insert(argv.end(), args.begin(), args.end());
  return test::Start(argv, log, {}, /*append=*/true);
}

// Exit status, or -1 (child killed) when it does not end within timeout_s.
int WaitExit(pid_t pid, double timeout_s) { return test::WaitExit(pid, timeout_s, /*kill_on_timeout=*/true); }

// Waits until the manager (pid) is attached as consumer to both rings: a
// producer that closes before that would take its messages with it.
bool WaitAttached(SubmapSender* front, SubmapSender* back, pid_t pid, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    const RingStats f = front->ring().Stats(), b = back->ring().Stats();
    if (f.consumer_pid == uint64_t(pid) && f.consumer_alive && b.consumer_pid == uint64_t(pid) && b.consumer_alive)
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

std::vector<Timestamp> TumTimes(const std::string& path) {
  std::vector<Timestamp> t;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;  // the TUM writer's header
    Timestamp ns = 0;
    EXPECT_TRUE(ParseSecondsToNs(line.substr(0, line.find(' ')), &ns)) << line;
    t.push_back(ns);
  }
  return t;
}

// The full-disk scenario, run by a child process in a mount namespace of its
// own with the manager's folder on a 4 MiB tmpfs. Returns 0 when everything
// held, 77 when a tmpfs cannot be mounted here (no CAP_SYS_ADMIN), else the
// number of the check that failed (see the parent test).
int FullDiskScenario() {
  const fs::path dir = std::getenv("RUMI_TEST_DIR");
  const fs::path state = dir / "state";
  // A mount namespace of our own, with the mount that holds `dir` made
  // private first (so the tmpfs never shows outside; "/" is not a mount
  // point in a chroot, its /tmp may be), then the tmpfs.
  if (::unshare(CLONE_NEWNS) != 0) return 77;
  std::string holder = "/";
  {
    std::ifstream info("/proc/self/mountinfo");
    for (std::string line; std::getline(info, line);) {
      std::istringstream f(line);
      std::string id, parent, dev, root, point;
      f >> id >> parent >> dev >> root >> point;
      const std::string d = dir.string();
      if (point.size() > holder.size() && d.compare(0, point.size(), point) == 0 &&
          (d.size() == point.size() || d[point.size()] == '/'))
        holder = point;
    }
  }
  if (::mount(nullptr, holder.c_str(), nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
      ::mount("tmpfs", state.c_str(), "tmpfs", 0, "size=4m") != 0)
    return 77;
  IpcOptions ipc;
  ipc.instance = "fulldisk_" + std::to_string(::getpid());
  ipc.submap_slot_bytes = 4 << 20;
  const std::string log = (dir / "manager.log").string();
  const std::string cfg = (dir / "config.yaml").string();
  std::ofstream(cfg) << "ipc: {submap_slot_bytes: " << ipc.submap_slot_bytes << "}\nmanager: {rebuild_interval_s: 0.2, map_save_interval_s: 0}\n";
  const pid_t pid = Spawn({"--instance", ipc.instance, "--out", state.string(), "--daemon", "--config", cfg}, log);
  const auto s = testing::MakeScenario();
  SubmapSender front(ipc, SubmapSource::kFront);
  SubmapSender back(ipc, SubmapSource::kBack);
  if (!WaitAttached(&front, &back, pid, 20)) return 1;
  front.Send(s.front_a.submap);
  const fs::path map = state / "map.rumi";
  // "phases" is logged once the rebuild's writes are done.
  if (!test::WaitFor([&] { return fs::exists(map) && Slurp(log).find("rebuild 1 phases") != std::string::npos; }, 20))
    return 2;
  const std::string before = Slurp(map.string());
  {  // fill the disk
    std::ofstream filler(state / "filler", std::ios::binary);
    const std::string block(64 << 10, 'x');
    while (filler.write(block.data(), block.size())) {
    }
  }
  back.Send(s.back.submap);
  front.Send(s.front_b.submap);
  // The rebuild's save (not only the journal's) hit the full disk.
  if (!test::WaitFor(
          [&] {
            const std::string text = Slurp(log);
            const size_t at = text.find("map.rumi.raw.tmp");
            return at != std::string::npos && text.find("No space left on device", at) != std::string::npos;
          },
          20))
    return 3;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  if (!ProcessRunning(pid)) return 4;                  // the manager stays up
  if (Slurp(map.string()) != before) return 5;       // the previous map, intact
  GlobalMap loaded;
  std::string why;
  if (!LoadGlobalMap(map.string(), &loaded, &why) || loaded.size() != 1) return 6;
  fs::remove(state / "filler");  // room again: the manager saves on its own
  if (!test::WaitFor([&] { return Slurp(log).find("saved again") != std::string::npos; }, 30)) return 7;
  if (!LoadGlobalMap(map.string(), &loaded, &why) || loaded.size() != 3) return 8;
  ::kill(pid, SIGTERM);
  if (WaitExit(pid, 20) != kExitStopped) return 9;
  // A daemon manager leaves its channels for the next run; the test's are its own.
  for (const char* channel : {kFrontSubmapChannel, kBackSubmapChannel, kMapNoticeChannel})
    RemoveSegment(SegmentName(ipc.instance, channel));
  return 0;
}

int Child(const std::string& mode) { return mode == "full-disk" ? FullDiskScenario() : 99; }
RUMI_TEST_CHILD_MODES(Child);

class ManagerProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(ManagerBinary())) << ManagerBinary();
    instance_ = "test_" + std::to_string(::getpid());
    tmp_.Create();
    ipc_.instance = instance_;
  }
  void TearDown() override {
    for (const pid_t p : spawned_) {  // a failed assertion left it running
      int status = 0;
      if (::waitpid(p, &status, WNOHANG) == 0) {
        ::kill(p, SIGKILL);
        ::waitpid(p, &status, 0);
      }
    }
    for (const char* channel : {kFrontSubmapChannel, kBackSubmapChannel, kMapNoticeChannel})
      RemoveSegment(SegmentName(instance_, channel));
    if (HasFailure()) tmp_.Keep();  // the logs stay
  }
  std::vector<std::string> Args(const std::string& extra_wait = "15") const {
    return {"--instance", instance_, "--out", (dir_ / "out").string(), "--wait-for-producers", extra_wait,
            "--rebuild-interval", "0.2"};
  }
  pid_t Start(const std::vector<std::string>& args, const std::string& log) {
    const pid_t pid = Spawn(args, log);
    if (pid > 0) spawned_.push_back(pid);
    return pid;
  }
  std::vector<pid_t> spawned_;
  std::string instance_;
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
  IpcOptions ipc_;
};

TEST_F(ManagerProcess, MergesWhatTheProducersSendAndReloadsTheMap) {
  const auto s = testing::MakeScenario();
  const std::string log = (dir_ / "manager.log").string();
  const pid_t pid = Start(Args(), log);
  ASSERT_GT(pid, 0);
  {
    SubmapSender front(ipc_, SubmapSource::kFront);
    SubmapSender back(ipc_, SubmapSource::kBack);
    const bool attached = WaitAttached(&front, &back, pid, 10);
    EXPECT_TRUE(attached) << Slurp(log);
    // A malformed record first: logged, counted, survived.
    const std::string garbage = "RUMISMAP this is not a submap record";
    EXPECT_EQ(front.ring().PushCopy(garbage.data(), garbage.size()), PushStatus::kOk);
    EXPECT_EQ(front.Send(s.front_a.submap), PushStatus::kOk);
    EXPECT_EQ(back.Send(s.back.submap), PushStatus::kOk);
    EXPECT_EQ(front.Send(s.front_b.submap), PushStatus::kOk);
  }  // clean exit of both producers: channels closed
  ASSERT_EQ(WaitExit(pid, 20), 0) << Slurp(log);

  const fs::path out = dir_ / "out";
  const auto times = TumTimes((out / "merged.txt").string());
  ASSERT_EQ(times.size(), 111u) << Slurp(log);
  for (int f = 0; f <= 110; ++f) EXPECT_EQ(times[f], s.scene.timestamps[f]) << f;
  nlohmann::json j = nlohmann::json::parse(Slurp((out / "manager_stats.json").string()));
  EXPECT_GE(j["merges"].get<int>(), 2);
  EXPECT_EQ(j["components"], 1);
  EXPECT_EQ(j["submaps_front"], 2);
  EXPECT_EQ(j["submaps_back"], 1);
  EXPECT_EQ(j["saved_frames"], 93);
  EXPECT_LT(j["saved_frames_postculled"].get<int>(), 93);
  EXPECT_EQ(j["decode_errors"], 1);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find("undecodable submap"), std::string::npos) << text;
  ASSERT_TRUE(fs::exists(out / "map.rumi"));
  const int postculled = j["saved_frames_postculled"];

  // Second run on the same folder: reloads map.rumi; producers come and go
  // without sending anything.
  const pid_t pid2 = Start(Args(), log);
  ASSERT_GT(pid2, 0);
  {
    SubmapSender front(ipc_, SubmapSource::kFront);
    SubmapSender back(ipc_, SubmapSource::kBack);
    EXPECT_TRUE(WaitAttached(&front, &back, pid2, 10)) << Slurp(log);
  }
  ASSERT_EQ(WaitExit(pid2, 20), 0) << Slurp(log);
  j = nlohmann::json::parse(Slurp((out / "manager_stats.json").string()));
  EXPECT_EQ(j["base_submaps"], 3);
  EXPECT_EQ(j["saved_frames"], 93);
  EXPECT_EQ(j["saved_frames_postculled"], postculled);
  EXPECT_EQ(j["merges"], 2);
  EXPECT_EQ(j["components"], 1);
  EXPECT_EQ(TumTimes((out / "merged.txt").string()).size(), 111u);
  EXPECT_NE(Slurp(log).find("reloaded"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "map.rumi.bad"));
}

// Stopped while a producer still runs: what arrived is saved, and the exit
// code says the work was not done (it used to be 0).
TEST_F(ManagerProcess, SigtermSavesWhatArrivedAndSaysSo) {
  const auto s = testing::MakeScenario();
  const std::string log = (dir_ / "manager.log").string();
  const pid_t pid = Start(Args("0"), log);  // would wait forever for the back
  ASSERT_GT(pid, 0);
  SubmapSender front(ipc_, SubmapSource::kFront);
  SubmapSender back(ipc_, SubmapSource::kBack);
  ASSERT_TRUE(WaitAttached(&front, &back, pid, 10)) << Slurp(log);
  EXPECT_EQ(front.Send(s.front_a.submap), PushStatus::kOk);
  // Wait until the manager has read it, then stop it.
  for (int i = 0; i < 500 && front.ring().Stats().popped == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ::kill(pid, SIGTERM);
  ASSERT_EQ(WaitExit(pid, 20), kExitStopped) << Slurp(log);
  const fs::path out = dir_ / "out";
  EXPECT_EQ(TumTimes((out / "merged.txt").string()).size(), 41u) << Slurp(log);
  const auto j = nlohmann::json::parse(Slurp((out / "manager_stats.json").string()));
  EXPECT_EQ(j["submaps_front"], 1);
  EXPECT_TRUE(fs::exists(out / "map.rumi"));
}

TEST_F(ManagerProcess, AProducerThatDiesWithoutClosingCountsAsFinished) {
  const auto s = testing::MakeScenario();
  const std::string log = (dir_ / "manager.log").string();
  const pid_t pid = Start(Args(), log);
  ASSERT_GT(pid, 0);
  int pipefd[2];
  ASSERT_EQ(::pipe(pipefd), 0);
  const pid_t front_pid = ::fork();
  if (front_pid == 0) {  // a front that crashes after sending: no destructor, no close
    ::close(pipefd[0]);
    SubmapSender front(ipc_, SubmapSource::kFront);
    for (int i = 0; i < 1000 && front.ring().Stats().consumer_pid != uint64_t(pid); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const char ok = front.Send(s.front_a.submap) == PushStatus::kOk ? '1' : '0';
    for (int i = 0; i < 1000 && front.ring().Stats().popped == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    (void)!::write(pipefd[1], &ok, 1);
    ::_exit(0);
  }
  ::close(pipefd[1]);
  char ok = 0;
  EXPECT_EQ(::read(pipefd[0], &ok, 1), 1);
  ::close(pipefd[0]);
  EXPECT_EQ(ok, '1');
  int status = 0;
  ::waitpid(front_pid, &status, 0);
  {
    SubmapSender back(ipc_, SubmapSource::kBack);
    for (int i = 0; i < 1000 && back.ring().Stats().consumer_pid != uint64_t(pid); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(back.Send(s.back.submap), PushStatus::kOk);
  }
  ASSERT_EQ(WaitExit(pid, 20), 0) << Slurp(log);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find("died without closing"), std::string::npos) << text;
  const auto j = nlohmann::json::parse(Slurp((dir_ / "out" / "manager_stats.json").string()));
  EXPECT_EQ(j["merges"], 1);
  EXPECT_EQ(TumTimes((dir_ / "out" / "merged.txt").string()).size(), 81u);
}

TEST_F(ManagerProcess, ARestartedFrontIsReadAgain) {
  const auto s = testing::MakeScenario();
  const std::string log = (dir_ / "manager.log").string();
  const pid_t pid = Start(Args(), log);
  ASSERT_GT(pid, 0);
  {
    SubmapSender back(ipc_, SubmapSource::kBack);
    {
      SubmapSender front(ipc_, SubmapSource::kFront);
      ASSERT_TRUE(WaitAttached(&front, &back, pid, 10)) << Slurp(log);
      EXPECT_EQ(front.Send(s.front_a.submap), PushStatus::kOk);
    }  // the first front closes; the back is still open, so the manager goes on
    SubmapSender front(ipc_, SubmapSource::kFront);
    ASSERT_TRUE(WaitAttached(&front, &back, pid, 10)) << Slurp(log);
    EXPECT_EQ(front.Send(s.front_b.submap), PushStatus::kOk);
    EXPECT_EQ(back.Send(s.back.submap), PushStatus::kOk);
  }
  ASSERT_EQ(WaitExit(pid, 20), 0) << Slurp(log);
  const auto j = nlohmann::json::parse(Slurp((dir_ / "out" / "manager_stats.json").string()));
  EXPECT_EQ(j["messages_front"], 2);
  EXPECT_EQ(j["merges"], 2);
  EXPECT_EQ(TumTimes((dir_ / "out" / "merged.txt").string()).size(), 111u);
}

TEST_F(ManagerProcess, RefusesAConfigWithAnUnknownKey) {
  const std::string cfg = (dir_ / "bad.yaml").string();
  std::ofstream(cfg) << "manager:\n  search_n: 3\n  no_such_key: 1\nfront:\n  whatever: 2\n";
  const std::string log = (dir_ / "manager.log").string();
  std::vector<std::string> args = Args();
  args.push_back("--config");
  args.push_back(cfg);
  const pid_t pid = Start(args, log);
  EXPECT_EQ(WaitExit(pid, 10), 2);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find("bad.yaml"), std::string::npos) << text;
  EXPECT_NE(text.find("manager.no_such_key"), std::string::npos) << text;
  // Every section is checked, the other processes' too.
  EXPECT_NE(text.find("front.whatever"), std::string::npos) << text;
}

// A full disk at save time leaves the previous map intact and logs the
// error; the manager stays up and saves once there is room again.
TEST(ManagerFullDisk, PreviousMapStaysIntactAndTheManagerStaysUp) {
  ASSERT_TRUE(fs::exists(ManagerBinary())) << ManagerBinary();
  const TempDir tmp;
  const fs::path dir = tmp.path();
  fs::create_directories(dir / "state");
  SpawnOptions so;
  so.argv = testing::ChildArgv();
  so.env = {testing::ChildEnv("full-disk"), "RUMI_TEST_DIR=" + dir.string()};
  std::string why;
  const pid_t child = SpawnChild(so, &why);
  ASSERT_GT(child, 0) << why;
  const int rc = WaitExit(child, 180);
  if (rc == 77) GTEST_SKIP() << "mounting a small tmpfs needs root (CAP_SYS_ADMIN) in a mount namespace";
  const char* checks[] = {"ok",
                          "the manager attached",
                          "the first save",
                          "the error logged (No space left on device)",
                          "the manager still running",
                          "map.rumi unchanged",
                          "map.rumi loads with the first submap",
                          "a save once there is room again",
                          "the new map with all three submaps",
                          "exit code 5 on SIGTERM"};
  EXPECT_EQ(rc, 0) << "failed check: " << (rc > 0 && rc < 10 ? checks[rc] : "?") << "\n--- manager log ---\n"
                   << Slurp((dir / "manager.log").string());
}

}  // namespace
}  // namespace rumi
