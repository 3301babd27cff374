// rumi-back in shared-memory mode, end to end with a fake colmap (no COLMAP
// run): this test is the window producer and the back-submap consumer.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "back/testing/canned_colmap_model.h"
#include "common/process/exit_codes.h"
#include "common/process/process_info.h"
#include "common/testing/process.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"
#include "common/timestamp.h"
#include "ipc/channels.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;
const auto& Since = test::SecondsSince;

bool ProcessGone(pid_t pid) { return !ProcessRunning(pid); }

class BackIpcTest : public ::testing::Test {
 protected:
  void SetUp() override {
    exe_ = test::BinPath("rumi-back");
    RUMI_REQUIRE(fs::exists(exe_), "build rumi-back first: " << exe_);
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    tmp_.Create();
    ipc_.instance = "test_" + std::to_string(::getpid()) + "_" + name.substr(0, 8);
    ipc_.window_slot_bytes = 1 << 20;
    ipc_.submap_slot_bytes = 1 << 20;
    Cleanup();
  }
  void TearDown() override {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    Cleanup();
  }
  void Cleanup() {
    for (const char* ch : {kWindowChannel, kBackSubmapChannel}) RemoveSegment(SegmentName(ipc_.instance, ch));
  }

  // Fake colmap: the mapper copies canned/<stem of the first image>/ (if any)
  // into the output; feature extraction hangs when `hang` exists.
  std::string Config(int max_queue_windows = 4, const std::string& back_extra = "") {
    const std::string script =
        WriteFakeColmap(dir_, std::string("if [ $cmd = feature_extractor ] && [ -e $d/hang_exec ]; then\n") +
                                  "  echo $$ > $d/sleep.pid.tmp; mv $d/sleep.pid.tmp $d/sleep.pid; exec sleep 60; fi\n" +
                                  "if [ $cmd = feature_extractor ] && [ -e $d/hang ]; then\n" +
                                  "  echo $$ > $d/sh.pid; sleep 60 & echo $! > $d/sleep.pid.tmp;" +
                                  " mv $d/sleep.pid.tmp $d/sleep.pid; wait; fi\n");
    const fs::path p = dir_ / "config.yaml";
    std::ofstream(p) << "back: {colmap_path: " << script << ", workspace_dir: " << (dir_ / "ws").string()
                     << ", max_queue_windows: " << max_queue_windows << ", low_priority: false, step_timeout_s: 30"
                     << back_extra << "}\n"
                     << "ipc: {window_slot_bytes: " << ipc_.window_slot_bytes
                     << ", submap_slot_bytes: " << ipc_.submap_slot_bytes << "}\n"
                     << "log_level: debug\n"
                     << "front: {fps: 30}\nsampler: {inter: 5}\nmanager: {search_n: 10}\n";
    return p.string();
  }

  static ImageWindow MakeWindow(int64_t id, Timestamp t0) { return TinyWindow(id, t0); }
  static std::vector<Timestamp> Stamps(const ImageWindow& w) {
    std::vector<Timestamp> t;
    for (const WindowFrame& f : w.frames) t.push_back(f.timestamp);
    return t;
  }

  void Start(const std::vector<std::string>& extra) {
    std::vector<std::string> args = {exe_, "--instance", ipc_.instance, "--work", (dir_ / "work").string(),
                                     "--wait-for-producer", "20", "--wait-for-consumer", "20"};
    args.insert(args.end(), extra.begin(), extra.end());
    pid_ = test::Start(args, (dir_ / "back.log").string());
    ASSERT_GE(pid_, 0);
  }
  // Exit code, -2 when killed, -1 when still running after timeout_s.
  int Wait(double timeout_s) {
    const int rc = test::WaitExit(pid_, timeout_s, false, std::chrono::milliseconds(10));
    if (rc != -1) pid_ = -1;  // reaped
    return rc;
  }
  std::string Log() const { return test::Slurp(dir_ / "back.log"); }
  nlohmann::json Stats() const {
    std::ifstream in(dir_ / "work" / "back_stats.json");
    EXPECT_TRUE(in.good()) << Log();
    return in.good() ? nlohmann::json::parse(in) : nlohmann::json();
  }

  std::string exe_;
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
  IpcOptions ipc_;
  pid_t pid_ = -1;
};

TEST_F(BackIpcTest, WindowsInBackSubmapsOutThenCleanExit) {
  const ImageWindow a = MakeWindow(7, 1341847980722988001LL);
  const ImageWindow b = MakeWindow(8, 1341847990000000003LL);
  const ImageWindow c = MakeWindow(9, 1341848000000000005LL);  // no model: fails as no_model
  WriteCannedModel(dir_ / "canned" / TimestampFileStem(a.frames[0].timestamp) / "0", a.camera, Stamps(a), 30.5, 20.5);
  WriteCannedModel(dir_ / "canned" / TimestampFileStem(b.frames[0].timestamp) / "0", b.camera, Stamps(b), 30.5, 20.5);
  const std::string config = Config();

  auto tx = std::make_unique<WindowSender>(ipc_);
  SubmapReceiver rx(ipc_, SubmapSource::kBack);
  Start({"--config", config});
  for (const ImageWindow* w : {&a, &b, &c}) ASSERT_EQ(tx->Send(*w), PushStatus::kOk);
  // As every producer must: let the consumer read everything, then close.
  const auto t0 = Clock::now();
  while (Since(t0) < 15) {
    const RingStats rs = tx->ring().Stats();
    if (rs.consumer_alive && rs.tail == rs.head) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(tx->ring().Stats().tail, 3u) << Log();
  tx.reset();
  // Attach only after the back has built every window: it must wait for its
  // consumer instead of closing (and unlinking) the channel with the submaps.
  const auto t2 = Clock::now();
  while (Since(t2) < 15) {
    std::ifstream in(dir_ / "work" / "back_stats.json");
    if (in.good() && nlohmann::json::parse(in, nullptr, false).value("windows", 0) == 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(::waitpid(pid_, nullptr, WNOHANG), 0) << "rumi-back exited before its consumer attached\n" << Log();

  std::vector<Submap> got;
  const auto t1 = Clock::now();
  while (Since(t1) < 15) {
    Submap s;
    if (rx.Receive(&s, 0.05) == PopStatus::kOk) got.push_back(std::move(s));
    if (rx.ring().closed_segments() > 0 && !rx.ring().connected()) break;
  }
  EXPECT_EQ(rx.ring().closed_segments(), 1u) << "back did not close its channel\n" << Log();
  EXPECT_EQ(Wait(10), 0) << Log();

  ASSERT_EQ(got.size(), 2u) << Log();
  EXPECT_NE(got[0].id, got[1].id);
  for (size_t i = 0; i < 2; ++i) {
    const ImageWindow& w = i == 0 ? a : b;
    EXPECT_EQ(got[i].source, SubmapSource::kBack);
    ASSERT_EQ(got[i].keyframes.size(), w.frames.size());
    for (size_t k = 0; k < w.frames.size(); ++k) EXPECT_EQ(got[i].keyframes[k].timestamp, w.frames[k].timestamp);
    EXPECT_DOUBLE_EQ(got[i].camera.fx, 50);
  }

  const nlohmann::json j = Stats();
  EXPECT_EQ(j["windows"], 3);  // processed (docs/eval.md)
  EXPECT_EQ(j["windows_received"], 3);
  EXPECT_EQ(j["windows_done"], 2);
  EXPECT_EQ(j["windows_failed"], 1);
  EXPECT_EQ(j["windows_cancelled"], 0);
  EXPECT_EQ(j["windows_dropped"], 0);
  EXPECT_EQ(j["submaps_sent"], 2);
  EXPECT_EQ(j["producer"], "closed");
  EXPECT_EQ(j["stopped_by_signal"], false);
  EXPECT_GT(j["seconds"].get<double>(), 0.0);
  ASSERT_EQ(j["per_window"].size(), 3u);
  const auto& p = j["per_window"];
  EXPECT_EQ(p[0]["window_id"], 7);
  EXPECT_EQ(p[0]["status"], "ok");
  EXPECT_EQ(p[0]["frames"], 4);
  EXPECT_EQ(p[0]["registered"], 4);
  EXPECT_EQ(p[0]["submaps"], nlohmann::json::array({got[0].id}));
  EXPECT_EQ(p[1]["submaps"], nlohmann::json::array({got[1].id}));
  EXPECT_EQ(p[2]["window_id"], 9);
  EXPECT_EQ(p[2]["status"], "no_model");
  EXPECT_EQ(p[2]["registered"], 0);
  double sum = 0;
  for (const auto& w : p) {
    EXPECT_TRUE(w["seconds"].contains("matching"));
    sum += w["seconds"]["total"].get<double>();
  }
  EXPECT_NEAR(j["seconds"].get<double>(), sum, 1e-9);
  EXPECT_TRUE(!fs::exists(dir_ / "ws") || fs::is_empty(dir_ / "ws"));
  // Both segments are gone after clean exits.
  RingStats rs;
  EXPECT_FALSE(ReadRingStats(SegmentName(ipc_.instance, kBackSubmapChannel), &rs));
}

// A stop while COLMAP runs cancels it, kills its process group, closes the
// channel, and the exit code says the work was not done (it used to be 0).
TEST_F(BackIpcTest, SigtermCancelsRunningColmapAndSaysSo) {
  std::ofstream(dir_ / "hang") << "1\n";
  const std::string config = Config(/*max_queue_windows=*/1);
  WindowSender tx(ipc_);
  Start({"--config", config});
  ASSERT_EQ(tx.Send(MakeWindow(3, 1000000000LL)), PushStatus::kOk);
  const auto t0 = Clock::now();
  while (!fs::exists(dir_ / "sleep.pid") && Since(t0) < 15)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(dir_ / "sleep.pid")) << Log();
  pid_t sh = 0, sleeper = 0;
  std::ifstream(dir_ / "sh.pid") >> sh;
  std::ifstream(dir_ / "sleep.pid") >> sleeper;
  ASSERT_GT(sh, 0);
  ASSERT_GT(sleeper, 0);
  EXPECT_FALSE(ProcessGone(sleeper));
  // While COLMAP runs, the receiver keeps the ring empty: windows 4..6 are
  // taken off it; 5 (1 s after 4) joins 4, and 6 (95 s later) makes the
  // queue of one drop 4 with the 5 it had joined (2 dropped).
  for (int64_t id : {4, 5, 100})
    ASSERT_EQ(tx.Send(MakeWindow(id == 100 ? 6 : id, id * 1000000000LL)), PushStatus::kOk);
  while (tx.ring().Stats().tail != 4 && Since(t0) < 15) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(tx.ring().Stats().tail, 4u) << Log();

  const auto t1 = Clock::now();
  ASSERT_EQ(::kill(pid_, SIGTERM), 0);
  EXPECT_EQ(Wait(10), kExitStopped) << Log();
  const double secs = Since(t1);
  std::printf("rumi-back stopped %.3f s after SIGTERM\n", secs);
  EXPECT_LT(secs, 3.0) << "docs/eval.md: stop within 3 s";
  // Orphans are reaped by init: give it a moment.
  test::WaitFor([&] { return ProcessGone(sh) && ProcessGone(sleeper); }, 2, std::chrono::milliseconds(10));
  EXPECT_TRUE(ProcessGone(sh)) << "fake colmap survived";
  EXPECT_TRUE(ProcessGone(sleeper)) << "fake colmap's child survived";

  const nlohmann::json j = Stats();
  EXPECT_EQ(j["windows_received"], 4);
  EXPECT_EQ(j["windows_dropped"], 2);
  EXPECT_EQ(j["windows_joined"], 1);
  EXPECT_EQ(j["windows"], 1);
  EXPECT_EQ(j["windows_cancelled"], 1);
  EXPECT_EQ(j["windows_done"], 0);
  EXPECT_EQ(j["submaps_sent"], 0);
  EXPECT_EQ(j["stopped_by_signal"], true);
  EXPECT_EQ(j["per_window"][0]["status"], "cancelled");
  RingStats rs;
  EXPECT_FALSE(ReadRingStats(SegmentName(ipc_.instance, kBackSubmapChannel), &rs)) << "channel not closed";
}

// The source has ended (the producer closed its channel) and the back drains
// its queue: a stop still cancels COLMAP at once, and under rumid the window
// stays in the spool without a failed attempt counted (#50.4: the stop went
// unheard until rumid's SIGKILL, and two such stops dropped the window).
TEST_F(BackIpcTest, SigtermWhileDrainingAfterTheSourceEndedCancelsToo) {
  std::ofstream(dir_ / "hang") << "1\n";
  const std::string config = Config(/*max_queue_windows=*/1);
  auto tx = std::make_unique<WindowSender>(ipc_);
  Start({"--config", config, "--daemon"});
  ASSERT_EQ(tx->Send(MakeWindow(3, 1000000000LL)), PushStatus::kOk);
  const auto t0 = Clock::now();
  while (!fs::exists(dir_ / "sleep.pid") && Since(t0) < 15)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(dir_ / "sleep.pid")) << Log();
  tx.reset();  // the producer is done: the channel is closed and drained
  while (Log().find("window producer closed its channel") == std::string::npos && Since(t0) < 15)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_NE(Log().find("window producer closed its channel"), std::string::npos) << Log();
  ASSERT_EQ(::kill(pid_, SIGUSR1), 0);  // rumid: "the source ended"
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the receiver has seen the end
  const auto t1 = Clock::now();
  ASSERT_EQ(::kill(pid_, SIGTERM), 0);
  EXPECT_EQ(Wait(10), kExitStopped) << Log();
  EXPECT_LT(Since(t1), 3.0) << "docs/eval.md: stop within 3 s\n" << Log();
  const nlohmann::json j = Stats();
  EXPECT_EQ(j["windows_cancelled"], 1) << j.dump(1);
  EXPECT_EQ(j["stopped_by_signal"], true);
  int attempts = -1;
  std::ifstream(dir_ / "work" / "spool" / "3.attempt") >> attempts;
  EXPECT_EQ(attempts, 0) << "a stop is not a failed attempt";
  EXPECT_TRUE(fs::exists(dir_ / "work" / "spool" / "3.rwin"));
}

// rumid's back (--daemon): a window is on disk before its ring slot is let
// go; a back killed while COLMAP runs leaves no COLMAP behind, its restart
// retries that window once and removes the dead one's workspace; a second
// death on the same window drops it with a log line.
TEST_F(BackIpcTest, KilledBackRetriesItsWindowOnceThenDropsIt) {
  std::ofstream(dir_ / "hang_exec") << "1\n";  // COLMAP as it is: one process (no children of its own)
  const std::string config = Config();
  WindowSender tx(ipc_);
  auto run_until_colmap = [&](int round) {
    fs::remove(dir_ / "sleep.pid");
    Start({"--config", config, "--daemon"});
    test::WaitFor([&] { return fs::exists(dir_ / "sleep.pid"); }, 15, std::chrono::milliseconds(10));
    ASSERT_TRUE(fs::exists(dir_ / "sleep.pid")) << "round " << round << "\n" << Log();
  };
  fs::remove(dir_ / "sleep.pid");
  Start({"--config", config, "--daemon"});
  ASSERT_EQ(tx.Send(MakeWindow(3, 1000000000LL)), PushStatus::kOk);
  auto t0 = Clock::now();
  while (!fs::exists(dir_ / "sleep.pid") && Since(t0) < 15) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(dir_ / "sleep.pid")) << Log();
  EXPECT_TRUE(fs::exists(dir_ / "work" / "spool" / "3.rwin"));
  // Windows 4 and 5 (1 s apart) wait; 5 joins 4, and both stay on disk
  // until the joined window is built.
  for (int64_t id = 4; id <= 5; ++id) ASSERT_EQ(tx.Send(MakeWindow(id, id * 1000000000LL)), PushStatus::kOk);
  while (Log().find("window 5 (4 frames) joins waiting window 4") == std::string::npos && Since(t0) < 15)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_NE(Log().find("window 5 (4 frames) joins waiting window 4"), std::string::npos) << Log();
  EXPECT_TRUE(fs::exists(dir_ / "work" / "spool" / "4.rwin"));
  EXPECT_TRUE(fs::exists(dir_ / "work" / "spool" / "5.rwin"));
  pid_t sleeper = 0;
  std::ifstream(dir_ / "sleep.pid") >> sleeper;
  ::kill(pid_, SIGKILL);  // mid-COLMAP
  Wait(5);
  EXPECT_TRUE(test::WaitFor([&] { return ProcessGone(sleeper); }, 5, std::chrono::milliseconds(10))) << "COLMAP outlived the killed back";
  int workspaces = 0;
  for (const auto& e : fs::directory_iterator(dir_ / "ws")) workspaces += e.is_directory();
  EXPECT_EQ(workspaces, 1);  // left by the killed back

  run_until_colmap(2);  // the restart takes window 3 from the spool, and 4 and 5 join again
  EXPECT_NE(Log().find("window 3 (4 frames) from the spool: rumi-back died while building it; retrying it once"),
            std::string::npos)
      << Log();
  EXPECT_NE(Log().find("window 5 (4 frames) joins waiting window 4"), std::string::npos) << Log();
  EXPECT_NE(Log().find("removed the workspace"), std::string::npos) << Log();
  ::kill(pid_, SIGKILL);
  Wait(5);

  Start({"--config", config, "--daemon"});
  test::WaitFor([&] { return Log().find("dropped") != std::string::npos; }, 15, std::chrono::milliseconds(20));
  EXPECT_NE(Log().find("window 3 was being built when rumi-back died, twice: dropped"), std::string::npos) << Log();
  EXPECT_FALSE(fs::exists(dir_ / "work" / "spool" / "3.rwin"));
  test::WaitFor([&] { return Stats()["windows_dropped"] == 1; }, 5, std::chrono::milliseconds(20));
  EXPECT_EQ(Stats()["windows_dropped"], 1);
}

// The manager attached, then vanished and did not come back: the back stops
// instead of working for nobody, and says so in its exit code.
TEST_F(BackIpcTest, AManagerGoneForGoodEndsTheBack) {
  Start({"--config", Config(4, ", peer_timeout_s: 1")});
  const std::string segment = SegmentName(ipc_.instance, kBackSubmapChannel);
  RingStats rs;
  ASSERT_TRUE(test::WaitFor([&] { return ReadRingStats(segment, &rs); }, 10, std::chrono::milliseconds(10))) << Log();
  const pid_t manager = ::fork();
  if (manager == 0) {  // attaches as the consumer, then dies without a word
    SubmapReceiver rx(ipc_, SubmapSource::kBack);
    Submap s;
    rx.Receive(&s, 0.2);
    ::_exit(0);
  }
  ::waitpid(manager, nullptr, 0);
  EXPECT_EQ(Wait(15), kExitPeerGone) << Log();
  EXPECT_NE(Log().find("the manager has been gone for 1 s: stopping"), std::string::npos) << Log();
}

TEST_F(BackIpcTest, ConfigAndCommandLineErrors) {
  const std::string good = Config();
  std::ofstream(dir_ / "typo.yaml") << "bakc: {num_threads: 2}\n";  // top-level typo
  std::ofstream(dir_ / "badipc.yaml") << "ipc: {window_slots: 0}\n";
  Start({"--config", (dir_ / "typo.yaml").string()});
  EXPECT_EQ(Wait(10), 2);
  EXPECT_NE(Log().find("bakc"), std::string::npos) << Log();
  Start({"--config", (dir_ / "badipc.yaml").string()});
  EXPECT_EQ(Wait(10), 2) << Log();
  // Instance ids are [A-Za-z0-9_-]{1,32}.
  ipc_.instance = "bad/id";
  Start({"--config", good});
  EXPECT_EQ(Wait(10), 2) << Log();
}

}  // namespace
}  // namespace rumi
