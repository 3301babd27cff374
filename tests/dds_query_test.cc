// rumi-manager serves its map over Cyclone DDS and `rumi query` reads it, as
// separate processes on loopback: this test is the front and back (the
// shared-memory channels of a private instance) and the user at the shell.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "common/process/exit_codes.h"
#include "ipc/channels.h"
#include "manager/testing/test_scenario.h"
#include "tests/rumi_cli_util.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;
using test::RunRumiLogged;
using test::Slurp;

int CountDataLines(const fs::path& p) {
  std::ifstream in(p);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += !line.empty() && line[0] != '#';
  return n;
}

class DdsQueryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    instance_ = "ddsq_" + std::to_string(::getpid());
    tmp_.Create();
    std::ofstream(dir_ / "config.yaml") << "dds: {enabled: true}\nmanager: {rebuild_interval_s: 0.2}\n";
  }
  void TearDown() override {
    if (manager_ > 0) {
      ::kill(manager_, SIGKILL);
      test::WaitExit(manager_, 10);
    }
    if (HasFailure()) tmp_.Keep();
  }
  // `rumi query --instance <ours> ARGS`, output in dir_/<name>.log.
  int Query(const std::string& args, const std::string& name, const std::string& instance = "") {
    return RunRumiLogged("query --instance " + (instance.empty() ? instance_ : instance) + " " + args,
                         dir_ / (name + ".log"));
  }
  std::string Log(const std::string& name) { return Slurp(dir_ / (name + ".log")); }

  std::string instance_;
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
  pid_t manager_ = -1;
};

TEST_F(DdsQueryTest, NoServerIsAClearTimeOut) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(Query("--timeout 1 status", "none", "nobody_home"), kExitNoProducer);
  EXPECT_LT(test::SecondsSince(start), 60);
  const std::string log = Log("none");
  EXPECT_NE(log.find("no rumi server for instance 'nobody_home' on DDS domain 0"), std::string::npos) << log;
}

TEST_F(DdsQueryTest, QueriesARunningManager) {
  std::vector<std::string> argv = {test::BinPath("rumi-manager"), "--instance", instance_, "--out",
                                   (dir_ / "out").string(), "--config", (dir_ / "config.yaml").string()};
  const std::string log = (dir_ / "manager.log").string();
  manager_ = test::Start(argv, log, {}, /*append=*/true);
  ASSERT_GT(manager_, 0);
  IpcOptions ipc;
  ipc.instance = instance_;
  const auto s = testing::MakeScenario();
  {
    SubmapSender front(ipc, SubmapSource::kFront);
    SubmapSender back(ipc, SubmapSource::kBack);
    // The server answers before any map: "starting" or "running" (empty).
    ASSERT_EQ(Query("--timeout 20 status --json", "early"), 0) << Log("early");
    // Wait for the manager to attach, then send A, the back window, B.
    for (int i = 0; i < 2000 && !(front.ring().Stats().consumer_alive && back.ring().Stats().consumer_alive); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    front.Send(s.front_a.submap);
    back.Send(s.back.submap);
    front.Send(s.front_b.submap);
  }  // producers close: the manager rebuilds, saves and ends
  ASSERT_EQ(test::WaitExit(manager_, 120), kExitDone) << Slurp(dir_ / "manager.log");
  manager_ = -1;
  // The manager has ended: its last snapshot is gone with it. Run it again
  // on the saved map (it reloads map.rumi) and query that one.
  argv.push_back("--wait-for-producers");
  argv.push_back("600");
  manager_ = test::Start(argv, log, {}, /*append=*/true);
  ASSERT_GT(manager_, 0);

  nlohmann::json st;
  for (int i = 0; i < 100; ++i) {  // the reloaded map is published once loaded
    ASSERT_EQ(Query("--timeout 20 status --json", "status"), 0) << Log("status");
    st = nlohmann::json::parse(Log("status"), nullptr, false);
    if (st.is_object() && st.value("submaps_front", 0) == 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(st.is_object()) << Log("status");
  EXPECT_EQ(st.value("submaps_front", 0), 2) << st.dump();
  EXPECT_EQ(st.value("submaps_back", 0), 1) << st.dump();
  EXPECT_EQ(st.value("components", 0), 1) << st.dump();  // A + back + B merged
  EXPECT_EQ(st["manager"].value("process", ""), "manager") << st.dump();

  ASSERT_EQ(Query("trajectory -o " + (dir_ / "traj.txt").string(), "traj"), 0) << Log("traj");
  EXPECT_EQ(CountDataLines(dir_ / "traj.txt"), CountDataLines(dir_ / "out" / "merged.txt"));
  EXPECT_EQ(CountDataLines(dir_ / "traj.txt"), st.value("trajectory_frames", -1));

  ASSERT_EQ(Query("points --page-size 500 -o " + (dir_ / "map.ply").string(), "points"), 0) << Log("points");
  const std::string ply = Slurp(dir_ / "map.ply");
  EXPECT_NE(ply.find("element vertex " + std::to_string(st.value("points", -1)) + "\n"), std::string::npos)
      << ply.substr(0, 200);

  ASSERT_EQ(Query("keyframes --json", "kfs"), 0) << Log("kfs");
  const auto kfs = nlohmann::json::parse(Log("kfs"), nullptr, false);
  ASSERT_TRUE(kfs.is_array()) << Log("kfs");
  EXPECT_EQ(int(kfs.size()), st.value("keyframes", -1));

  ASSERT_EQ(Query("submaps --json", "subs"), 0) << Log("subs");
  const auto subs = nlohmann::json::parse(Log("subs"), nullptr, false);
  ASSERT_TRUE(subs.is_array() && subs.size() == 3) << Log("subs");
  std::string back_key;
  for (const auto& x : subs)
    if (x.value("key", "").rfind("back#", 0) == 0) back_key = x.value("key", "");
  ASSERT_EQ(Query("submaps " + back_key, "sub"), 0) << Log("sub");
  EXPECT_NE(Log("sub").find(back_key + "  component 0"), std::string::npos) << Log("sub");
  EXPECT_EQ(Query("submaps front#77", "nosub"), kExitError);
  EXPECT_NE(Log("nosub").find("no submap 'front#77'"), std::string::npos) << Log("nosub");
  EXPECT_EQ(Query("points --box 1,1,1,0,0,0", "badbox"), kExitError);
  EXPECT_NE(Log("badbox").find("box_min[0]"), std::string::npos) << Log("badbox");

  // The C example of docs/dds.md reads the same.
  ASSERT_EQ(test::RunLogged(test::BinPath("rumi-dds-example") + " " + instance_ + " lo", dir_ / "example.log"), 0)
      << Slurp(dir_ / "example.log");
  EXPECT_NE(Slurp(dir_ / "example.log").find("trajectory: " + std::to_string(st.value("trajectory_frames", -1)) + " poses"),
            std::string::npos)
      << Slurp(dir_ / "example.log");

  // No pose source in this scenario: no metric grid, and the reason.
  EXPECT_EQ(Query("grid", "grid"), kExitError);
  EXPECT_NE(Log("grid").find("no grid"), std::string::npos) << Log("grid");

  ::kill(manager_, SIGTERM);
  EXPECT_EQ(test::WaitExit(manager_, 60), kExitStopped) << Slurp(dir_ / "manager.log");
  manager_ = -1;
}

}  // namespace
}  // namespace rumi
