// Faults: rumid on a generated sequence with a loss (dark stretch), live, with
// the robot's pose source; each child is killed once with SIGKILL: the front
// mid-track, the back mid-COLMAP, the manager mid-merge. The final map and
// trajectory must still cover the sequence (merged tracking rate within 5
// points of an unkilled run), no submap the manager had received may be
// lost, and no shared-memory segment or process may be left at the end.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "common/dataset.h"
#include "common/process/process_info.h"
#include "common/trajectory.h"
#include "common/trajectory_eval.h"
#include "ipc/segments.h"
#include "common/testing/temp_dir.h"
#include "tests/rumi_cli_util.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::Slurp;

const auto& Since = test::SecondsSince;
const auto& Bin = test::BinPath;
const auto& Status = test::ReadStatus;
const auto& Child = test::StatusChild;

// Submap keys ("front#3", "back#0") in a map file and its journal.
std::set<std::string> ReceivedSubmaps(const fs::path& state) {
  std::set<std::string> keys;
  try {
    const nlohmann::json stats = nlohmann::json::parse(Slurp(state / "manager_stats.json"));
    for (const auto& c : stats.at("component_list"))
      for (const auto& s : c.at("submaps")) keys.insert(s.get<std::string>());
  } catch (const std::exception&) {  // not written yet, or being replaced
  }
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(state / "map.rumi.received", ec)) {
    const std::string stem = e.path().stem().string();  // front_3
    const size_t u = stem.find('_');
    if (e.path().extension() == ".rsub" && u != std::string::npos)
      keys.insert(stem.substr(0, u) + "#" + stem.substr(u + 1));
  }
  return keys;
}

class DaemonFaults : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp_ = std::make_unique<TempDir>();  // kept with RUMI_KEEP_TEST_DIR (debugging: the logs stay)
    dir_ = tmp_->Create();
    // 20 s at 640x480: the dark stretch (1 s, from 8 s) makes the front lose
    // track and the sampler ship a window; a front restart (~0.7 s) costs
    // about 3 points of the 20 s.
    seq_ = dir_ / "dark";
    ASSERT_EQ(test::RunRumiLogged("synth " + seq_.string() +
                                      " --scenario dark --seed 2 --frames 600 --dark-gain 0.02",
                                  dir_ / "synth.log"),
              0)
        << Slurp(dir_ / "synth.log");
  }
  static void TearDownTestSuite() { tmp_.reset(); }

  std::string Config(const std::string& name) {
    const fs::path p = dir_ / (name + ".yaml");
    std::ofstream(p) << Slurp(seq_ / "camera.yaml") << "log_level: info\n"
                     << "source: {kind: dataset, dataset: tum, path: " << seq_.string()
                     << ", odometry: " << (seq_ / "odometry.txt").string() << "}\n"
                     // The sequential matcher: the back takes ~1 min per window here, not 4.
                     << "back: {matcher: sequential, max_num_features: 1024}\n"
                     << "daemon: {child_output: files, state_dir: " << (dir_ / ("state_" + name)).string()
                     << ", restart_backoff_initial_s: 0.1, status_interval_s: 0.1}\n";
    return p.string();
  }

  pid_t StartRumid(const std::string& name) {
    return test::Start({Bin("rumid"), "--config", Config(name), "--instance", name + std::to_string(::getpid() % 100000)},
                       (dir_ / ("rumid_" + name + ".log")).string());
  }

  // Merged tracking rate (covered time / sequence time) of a state folder.
  double MergedRate(const fs::path& state) {
    DatasetOptions d;
    d.kind = DatasetKind::kTum;
    d.path = seq_.string();
    d.config_path = (seq_ / "camera.yaml").string();
    const auto source = OpenDataset(d);
    TrajectoryReadOptions ro;
    ro.drop_duplicates = true;
    const Trajectory merged = ReadTumTrajectory((state / "merged.txt").string(), ro);
    std::vector<Timestamp> tracked;
    for (const auto& p : merged) tracked.push_back(p.t);
    return ComputeTrackingRate(source->timestamps(), tracked).covered_rate;
  }

  // Waits for rumid to exit, at most limit_s. On time out it says what each
  // part was at, stops rumid (its children go with it) and returns false.
  bool WaitRumid(pid_t pid, const std::string& name, double limit_s, int* status) {
    const auto t0 = Clock::now();
    while (Since(t0) < limit_s) {
      if (::waitpid(pid, status, WNOHANG) == pid) return true;
      if (on_wait_) on_wait_();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    const fs::path state = dir_ / ("state_" + name);
    ADD_FAILURE() << "rumid (" << name << ") still running after " << limit_s << " s; status: "
                  << Status(state).dump(1) << "\nrumid log tail:\n"
                  << test::SlurpTail(dir_ / ("rumid_" + name + ".log"))
                  << "\nback log tail:\n" << test::SlurpTail(state / "logs" / "rumi-back.log")
                  << "\nmanager log tail:\n" << test::SlurpTail(state / "logs" / "rumi-manager.log");
    test::Stop(pid, 30, std::chrono::milliseconds(100));
    return false;
  }
  std::function<void()> on_wait_;
  static std::unique_ptr<TempDir> tmp_;
  static fs::path dir_, seq_;
};
std::unique_ptr<TempDir> DaemonFaults::tmp_;
fs::path DaemonFaults::dir_, DaemonFaults::seq_;

TEST_F(DaemonFaults, EveryChildKilledOnceAndTheMapStillCoversTheSequence) {
  // The reference: the same session, nothing killed.
  const pid_t ref = StartRumid("ref");
  int status = 0;
  const auto t_ref = Clock::now();
  ASSERT_TRUE(WaitRumid(ref, "ref", 900, &status));
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << Slurp(dir_ / "rumid_ref.log");
  const double ref_rate = MergedRate(dir_ / "state_ref");
  const double ref_s = Since(t_ref);
  std::printf("unkilled: merged rate %.1f %% in %.0f s\n", 100 * ref_rate, ref_s);

  const fs::path state = dir_ / "state_faults";
  const fs::path logs = state / "logs";
  const pid_t pid = StartRumid("faults");
  bool reaped = false;
  struct StopOnReturn {  // an ASSERT that returns early stops rumid and its children
    std::function<void()> f;
    ~StopOnReturn() { f(); }
  } stop_on_return{[&] {
    if (!reaped) test::Stop(pid, 30, std::chrono::milliseconds(100));
  }};
  std::set<pid_t> pids;  // every child process seen, of every generation
  auto watch = [&] {
    const nlohmann::json st = Status(state);
    for (const auto& c : st.value("children", nlohmann::json::array()))
      if (c.value("pid", -1) > 0) pids.insert(c.value("pid", -1));
    return st;
  };
  auto kill_child = [&](const std::string& name) {
    const pid_t p = Child(watch(), name).value("pid", -1);
    EXPECT_GT(p, 0) << name;
    if (p > 0) ::kill(p, SIGKILL);
    std::printf("killed %s (pid %d) at %.1f s\n", name.c_str(), p, Since(t_ref));
    std::fflush(stdout);
    return p;
  };
  // The faulted session does the back's window twice and reloads the
  // manager: a few times the unkilled one, however loaded the machine is.
  const double limit_s = std::max(900.0, 6 * ref_s);
  const auto t0 = Clock::now();
  auto timed_out = [&] { return Since(t0) > limit_s; };

  // 1. The front, mid-track (3 s into the stream, well before the dark stretch).
  while (!timed_out() && watch().value("front", nlohmann::json::object()).value("frames", 0) < 90)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(watch()["front"].value("state", std::string()), "tracking") << Slurp(logs / "rumi-front.log");
  kill_child("rumi-front");

  // 2. The back, mid-COLMAP (its window at work for 5 s).
  for (;;) {
    const nlohmann::json b = watch().value("back", nlohmann::json::object());
    if (timed_out() || (b.contains("building") && b["building"].value("elapsed_s", 0.0) > 5)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_FALSE(timed_out()) << "the back never built a window: " << Slurp(logs / "rumi-back.log");
  const std::string stage = watch()["back"]["building"].value("stage", std::string());
  kill_child("rumi-back");
  std::printf("  back was at %s\n", stage.c_str());

  // 3. The manager, mid-merge: as the rebuild that takes the back submap starts.
  while (!timed_out() && Slurp(logs / "rumi-back.log").find("sent back submap") == std::string::npos)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const size_t mark = Slurp(logs / "rumi-manager.log").size();
  std::string rebuild;
  while (!timed_out() && rebuild.empty()) {
    const std::string text = Slurp(logs / "rumi-manager.log");
    const size_t at = text.find("rebuild ", mark);
    if (at != std::string::npos && text.find(" starting", at) != std::string::npos)
      rebuild = text.substr(at, text.find(" starting", at) - at);
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const std::set<std::string> before_kill = ReceivedSubmaps(state);
  kill_child("rumi-manager");
  const std::string after = Slurp(logs / "rumi-manager.log");
  EXPECT_EQ(after.find(rebuild + " in", mark), std::string::npos) << "the rebuild had ended before the kill";

  on_wait_ = [&] { watch(); };
  const bool ended = WaitRumid(pid, "faults", std::max(60.0, limit_s - Since(t0)), &status);
  on_wait_ = nullptr;
  reaped = true;  // exited, or stopped by WaitRumid
  ASSERT_TRUE(ended);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << Slurp(dir_ / "rumid_faults.log");

  // Each child restarted once and did its part.
  const nlohmann::json st = Status(state);
  for (const char* name : {"rumi-front", "rumi-back", "rumi-manager"})
    EXPECT_EQ(Child(st, name).value("restarts", -1), 1) << name << " " << st.dump(1);
  EXPECT_NE(Slurp(logs / "rumi-back.log").find("retrying it once"), std::string::npos);
  EXPECT_NE(Slurp(logs / "rumi-manager.log").find("reloaded"), std::string::npos);
  const nlohmann::json bs = nlohmann::json::parse(Slurp(state / "back" / "back_stats.json"));
  EXPECT_GE(bs["windows_done"].get<int>(), 1) << bs.dump(1);

  // No submap the manager had is lost.
  const std::set<std::string> final_keys = ReceivedSubmaps(state);
  for (const std::string& k : before_kill) EXPECT_TRUE(final_keys.count(k)) << k << " lost";
  bool has_back = false;
  for (const std::string& k : final_keys) has_back |= k.rfind("back#", 0) == 0;
  EXPECT_TRUE(has_back);

  // The map still covers the sequence.
  const double rate = MergedRate(state);
  std::printf("killed each child once: merged rate %.1f %% (unkilled %.1f %%), submaps %zu\n", 100 * rate,
              100 * ref_rate, final_keys.size());
  EXPECT_GT(rate, ref_rate - 0.05);

  // Nothing left behind.
  for (pid_t p : pids) EXPECT_FALSE(ProcessRunning(p)) << "process " << p << " left behind";
  const std::string instance = st["instance"];
  for (const std::string& name : InstanceSegmentNames(instance)) {
    RingStats rs;
    EXPECT_FALSE(ReadRingStats(name, &rs)) << name << " left behind";
  }
}

}  // namespace
}  // namespace rumi
