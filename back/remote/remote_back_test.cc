// Remote back workers end to end (docs/back.md "Remote workers"): rumi-back
// as the dispatcher (back.mode remote / both) and `rumi-back --remote`
// workers as separate processes, talking real Cyclone DDS, with a fake
// colmap (canned models, as back_ipc_test). This test is the window producer
// and the back-submap consumer.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "back/testing/canned_colmap_model.h"
#include "common/process/exit_codes.h"
#include "common/testing/process.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"
#include "common/timestamp.h"
#include "ipc/channels.h"
#include "ipc/submap_codec.h"
#include "ipc/window_codec.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;
using test::Slurp;
const auto& Since = test::SecondsSince;

int Sh(const std::string& cmd) { return test::RunLogged(cmd, "/dev/null"); }

class RemoteBackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    exe_ = test::BinPath("rumi-back");
    RUMI_REQUIRE(fs::exists(exe_), "build rumi-back first: " << exe_);
    name_ = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    tmp_.Create();
    ipc_.instance = "rtest_" + std::to_string(::getpid()) + "_" + name_.substr(0, 6);
    ipc_.window_slot_bytes = 1 << 20;
    ipc_.submap_slot_bytes = 1 << 20;
    domain_ = 20 + ::getpid() % 200;
    for (const char* ch : {kWindowChannel, kBackSubmapChannel}) RemoveSegment(SegmentName(ipc_.instance, ch));
    // Fake colmap: the feature extractor sleeps while `slow` exists.
    WriteFakeColmap(dir_, "if [ $cmd = feature_extractor ]; then n=0; while [ -e $d/slow ] && [ $n -lt 600 ]; do"
                          " sleep 0.05; n=$((n+1)); done; fi\n");
  }
  void TearDown() override {
    for (pid_t& p : pids_)
      if (p > 0) ::kill(p, SIGKILL), ::waitpid(p, nullptr, 0);
    for (const char* ch : {kWindowChannel, kBackSubmapChannel}) RemoveSegment(SegmentName(ipc_.instance, ch));
    if (!netns_a_.empty()) Sh("ip netns del " + netns_a_), Sh("ip netns del " + netns_b_);
  }

  std::string Config(const std::string& file, const std::string& mode, const std::string& interface) {
    const fs::path p = dir_ / file;
    std::ofstream(p) << "back: {colmap_path: " << (dir_ / "colmap.sh").string() << ", workspace_dir: "
                     << (dir_ / ("ws_" + file)).string() << ", low_priority: false, step_timeout_s: 60, max_queue_windows: 8"
                     << ", mode: " << mode << ", remote_lease_s: 3, remote_claim_timeout_s: 1.5}\n"
                     << "dds: {domain_id: " << domain_ << ", interface: '" << interface << "'}\n"
                     << "ipc: {window_slot_bytes: " << ipc_.window_slot_bytes
                     << ", submap_slot_bytes: " << ipc_.submap_slot_bytes << "}\nlog_level: debug\n";
    return p.string();
  }

  std::vector<ImageWindow> Windows() {
    std::vector<ImageWindow> ws = {TinyWindow(7, 1341847980722988001LL), TinyWindow(8, 1341847990000000003LL),
                                   TinyWindow(9, 1341848000000000005LL)};  // 9: no model
    for (int i = 0; i < 2; ++i) {
      std::vector<Timestamp> t;
      for (const WindowFrame& f : ws[i].frames) t.push_back(f.timestamp);
      WriteCannedModel(dir_ / "canned" / TimestampFileStem(t[0]) / "0", ws[i].camera, t, 30.5, 20.5);
    }
    return ws;
  }

  // Starts a process (optionally inside a network namespace); its output goes to <log>.
  pid_t Start(std::vector<std::string> args, const std::string& log, const std::string& netns = "") {
    if (!netns.empty()) args.insert(args.begin(), {"/usr/sbin/ip", "netns", "exec", netns});
    const pid_t pid = test::Start(args, (dir_ / log).string());
    pids_.push_back(pid);
    return pid;
  }
  // Exit code, -2 when killed, -1 when still running after timeout_s.
  int Wait(pid_t pid, double timeout_s) {
    const int rc = test::WaitExit(pid, timeout_s, false, std::chrono::milliseconds(10));
    if (rc != -1)  // reaped
      for (pid_t& p : pids_)
        if (p == pid) p = -1;
    return rc;
  }
  std::string Logs() const {
    std::string s;
    for (const auto& e : fs::directory_iterator(dir_))
      if (e.path().extension() == ".log") s += "---- " + e.path().filename().string() + "\n" + Slurp(e.path());
    return s;
  }

  // Sends the windows to a dispatcher started with `config`, collects the
  // back submaps; while it runs, `during` may act (kill a worker). Returns
  // back_stats.json.
  nlohmann::json Run(const std::string& config, const std::string& netns, std::vector<Submap>* got,
                     const std::function<void()>& during = {}) {
    const std::string work = (dir_ / ("work_" + fs::path(config).stem().string())).string();
    auto tx = std::make_unique<WindowSender>(ipc_);
    SubmapReceiver rx(ipc_, SubmapSource::kBack);
    const pid_t back = Start({exe_, "--instance", ipc_.instance, "--work", work, "--config", config,
                              "--wait-for-producer", "30", "--wait-for-consumer", "30"},
                             "dispatcher_" + fs::path(config).stem().string() + ".log", netns);
    for (const ImageWindow& w : Windows()) EXPECT_EQ(tx->Send(w), PushStatus::kOk);
    const auto t0 = Clock::now();
    while (Since(t0) < 20) {
      const RingStats rs = tx->ring().Stats();
      if (rs.consumer_alive && rs.tail == rs.head) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    tx.reset();
    if (during) during();
    const auto t1 = Clock::now();
    while (Since(t1) < 60) {
      Submap s;
      if (rx.Receive(&s, 0.05) == PopStatus::kOk) got->push_back(std::move(s));
      if (rx.ring().closed_segments() > 0 && !rx.ring().connected()) break;
    }
    EXPECT_EQ(Wait(back, 20), kExitDone) << Logs();
    std::ifstream in(fs::path(work) / "back_stats.json");
    EXPECT_TRUE(in.good()) << Logs();
    return in.good() ? nlohmann::json::parse(in) : nlohmann::json();
  }

  // Two workers, the one that takes window 7 killed while it builds it: every
  // window is still built exactly once, and the submaps are a local run's.
  void TwoWorkersOneKilled(const std::string& dispatcher_if, const std::string& worker_if, const std::string& netns_d,
                           const std::string& netns_w) {
    std::vector<Submap> local;
    const nlohmann::json ls = Run(Config("local.yaml", "local", "lo"), "", &local);
    ASSERT_EQ(local.size(), 2u) << Logs();

    const std::string wcfg = Config("worker.yaml", "local", worker_if);
    std::ofstream(dir_ / "slow").close();
    const pid_t a = Start({exe_, "--remote", "--instance", ipc_.instance, "--config", wcfg, "--name", "wa"}, "wa.log",
                          netns_w);
    const pid_t b = Start({exe_, "--remote", "--instance", ipc_.instance, "--config", wcfg, "--name", "wb"}, "wb.log",
                          netns_w);
    std::string killed;
    std::vector<Submap> remote;
    const nlohmann::json rs = Run(Config("remote.yaml", "remote", dispatcher_if), netns_d, &remote, [&] {
      // Whoever builds window 7 first dies in the middle of it.
      const auto t0 = Clock::now();
      while (killed.empty() && Since(t0) < 30) {
        for (const auto& [p, n] : {std::make_pair(a, std::string("wa")), std::make_pair(b, std::string("wb"))})
          if (killed.empty() && Slurp(dir_ / (n + ".log")).find("building window 7") != std::string::npos) {
            ::kill(p, SIGKILL);
            Wait(p, 5);
            killed = n;
          }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      fs::remove(dir_ / "slow");
    });
    ASSERT_FALSE(killed.empty()) << "no worker started window 7\n" << Logs();
    const std::string survivor = killed == "wa" ? "wb" : "wa";
    ASSERT_EQ(remote.size(), 2u) << Logs();
    for (size_t i = 0; i < 2; ++i)
      EXPECT_EQ(EncodeSubmap(remote[i]), EncodeSubmap(local[i])) << "submap " << i << " differs from the local run";
    EXPECT_EQ(rs["windows"], 3) << rs.dump(1);
    EXPECT_EQ(rs["windows_done"], 2);
    EXPECT_EQ(rs["windows_failed"], 1);  // window 9: no model, as locally
    EXPECT_EQ(rs["submaps_sent"], 2);
    std::map<int64_t, uint64_t> png_bytes;
    for (const ImageWindow& w : Windows()) png_bytes[w.id] = EncodeWindow(w, WindowPixels::kPng).size();
    std::set<int64_t> ids;
    for (const auto& w : rs["per_window"]) {
      ids.insert(w["window_id"].get<int64_t>());
      EXPECT_EQ(w["built_by"], survivor) << w.dump();
      // Window 7 went out again after the kill (a worker starved past the
      // lease on a loaded machine may add an offer anywhere: not a failure).
      EXPECT_GE(w["remote"]["offers"].get<int>(), w["window_id"] == 7 ? 2 : 1) << w.dump();
      // Whole windows with PNG frames (back.remote_png, the default) crossed the wire.
      const uint64_t out = w["remote"]["bytes_out"].get<uint64_t>();
      ASSERT_TRUE(png_bytes.count(w["window_id"].get<int64_t>())) << w.dump();
      const uint64_t one = png_bytes.at(w["window_id"].get<int64_t>());
      EXPECT_TRUE(out > 0 && out % one == 0) << out << " bytes out, " << one << " per window: " << w.dump();
      EXPECT_GT(w["remote"]["bytes_in"].get<uint64_t>(), 0u) << w.dump();
    }
    EXPECT_EQ(ids, (std::set<int64_t>{7, 8, 9})) << "each window once";
    for (const auto& w : ls["per_window"]) EXPECT_EQ(w["built_by"], "local");
    const std::string log = Slurp(dir_ / "dispatcher_remote.log");
    EXPECT_NE(log.find("remote worker " + killed + " silent"), std::string::npos) << log;
    EXPECT_NE(log.find("offered again (attempt 2)"), std::string::npos) << log;
  }

  std::string exe_, name_;
  TempDir tmp_;  // kept with RUMI_KEEP_TEST_DIR (debugging: the logs stay)
  fs::path dir_ = tmp_.path();
  IpcOptions ipc_;
  int domain_ = 0;
  std::vector<pid_t> pids_;
  std::string netns_a_, netns_b_;
};

TEST_F(RemoteBackTest, TwoWorkersOneKilledEveryWindowBuiltOnceOverLoopback) { TwoWorkersOneKilled("lo", "lo", "", ""); }

// The same across a veth pair between two network namespaces, so that the
// traffic really crosses an interface (root and `ip netns` needed).
TEST_F(RemoteBackTest, TwoWorkersOneKilledAcrossNetworkNamespaces) {
  const std::string tag = std::to_string(::getpid() % 100000);
  const std::string net = std::to_string(10 + ::getpid() % 240);
  netns_a_ = "rumiA" + tag;
  netns_b_ = "rumiB" + tag;
  // Adding a namespace may work where entering one does not (a chroot
  // without its own mount namespace: "mount --make-rslave / failed").
  if (::geteuid() != 0 || Sh("ip netns add " + netns_a_) != 0 || Sh("ip -n " + netns_a_ + " link set lo up") != 0 ||
      Sh("ip netns exec " + netns_a_ + " true") != 0) {
    Sh("ip netns del " + netns_a_);
    netns_a_.clear();
    GTEST_SKIP() << "ip netns is not permitted here (needs root, iproute2 and a namespace it can enter): "
                    "the namespace test is skipped";
  }
  const std::string va = "rva" + tag, vb = "rvb" + tag;
  ASSERT_EQ(Sh("ip netns add " + netns_b_), 0);
  ASSERT_EQ(Sh("ip link add " + va + " type veth peer name " + vb), 0);
  ASSERT_EQ(Sh("ip link set " + va + " netns " + netns_a_ + " && ip link set " + vb + " netns " + netns_b_), 0);
  ASSERT_EQ(Sh("ip -n " + netns_a_ + " addr add 10.213." + net + ".1/24 dev " + va + " && ip -n " + netns_a_ +
               " link set " + va + " up && ip -n " + netns_a_ + " link set lo up"),
            0);
  ASSERT_EQ(Sh("ip -n " + netns_b_ + " addr add 10.213." + net + ".2/24 dev " + vb + " && ip -n " + netns_b_ +
               " link set " + vb + " up && ip -n " + netns_b_ + " link set lo up"),
            0);
  TwoWorkersOneKilled("10.213." + net + ".1", "10.213." + net + ".2", netns_a_, netns_b_);
}

TEST_F(RemoteBackTest, WithNoWorkerModeBothBuildsHere) {
  std::vector<Submap> got;
  const nlohmann::json s = Run(Config("both.yaml", "both", "lo"), "", &got);
  EXPECT_EQ(got.size(), 2u) << Logs();
  EXPECT_EQ(s["windows"], 3);
  for (const auto& w : s["per_window"]) {
    EXPECT_EQ(w["built_by"], "local");
    EXPECT_EQ(w["remote"]["offers"], 1) << w.dump();
    EXPECT_GE(w["remote"]["claim_wait_s"].get<double>(), 1.5) << w.dump();
    EXPECT_EQ(w["remote"]["bytes_out"], 0) << w.dump();
  }
  EXPECT_NE(Slurp(dir_ / "dispatcher_both.log").find("no remote worker claimed window 7 within 1.5 s: building it here"),
            std::string::npos)
      << Logs();
}

}  // namespace
}  // namespace rumi
