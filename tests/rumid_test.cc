// rumid as systemd runs it: the real rumid, rumi-front, rumi-back and
// rumi-manager on a generated sequence replayed live (looped), with this test
// in systemd's place on $NOTIFY_SOCKET. Checks the notify protocol (READY
// once the children are up, STATUS, WATCHDOG every WatchdogSec/2 only while
// the manager's loop turns, STOPPING), SIGHUP, a bounded SIGTERM stop that
// leaves no process and no segment, the state-folder lock, `rumi status`,
// and a crash loop that gives up.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "common/process/notify.h"
#include "common/process/process_info.h"
#include "ipc/segments.h"
#include "manager/grid/grid_file.h"
#include "common/testing/temp_dir.h"
#include "tests/rumi_cli_util.h"
// Last: it pulls in <resolv.h>, whose _res macro breaks Eigen included after it.
#include <httplib.h>

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::Slurp;
const auto& Bin = test::BinPath;
const auto& Since = test::SecondsSince;

class Daemon : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp_ = std::make_unique<TempDir>();
    dir_ = tmp_->Create();
    // 3 s of a smooth walk at QVGA: quick to render, tracked, no loss.
    seq_ = dir_ / "smooth";
    ASSERT_EQ(test::RunRumiLogged("synth " + seq_.string() + " --scenario smooth --frames 90 --size 320x240 --seed 4",
                                  dir_ / "synth.log"),
              0)
        << Slurp(dir_ / "synth.log");
  }
  static void TearDownTestSuite() { tmp_.reset(); }

  void TearDown() override {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  // A config for rumid: the sequence looped (it runs until stopped), logs in files.
  std::string Config(const std::string& name, const std::string& extra = "", const std::string& level = "info") {
    const fs::path p = dir_ / (name + ".yaml");
    std::ofstream(p) << Slurp(seq_ / "camera.yaml") << "log_level: " << level << "\n"
                     << "source: {kind: dataset, dataset: tum, path: " << seq_.string() << ", loop: true}\n"
                     << "daemon:\n  child_output: files\n  state_dir: " << (dir_ / ("state_" + name)).string()
                     << "\n  restart_backoff_initial_s: 0.1\n  status_interval_s: 0.2\n"
                     << extra;
    return p.string();
  }
  fs::path State(const std::string& name) const { return dir_ / ("state_" + name); }

  pid_t Start(const std::vector<std::string>& args, const std::vector<std::string>& env, const std::string& log) {
    std::vector<std::string> argv = {Bin("rumid")};
    argv.insert(argv.end(), args.begin(), args.end());
    return test::Start(argv, log, env);
  }
  static int WaitExit(pid_t pid, double timeout_s) { return test::WaitExit(pid, timeout_s); }
  // Waits (at most 30 s) until the rumid of state folder `name` says it is running.
  bool WaitRunning(const std::string& name) const {
    return test::WaitFor([&] { return Status(State(name)).value("state", std::string()) == "running"; }, 30,
                         std::chrono::milliseconds(50));
  }
  static nlohmann::json Status(const fs::path& state) { return test::ReadStatus(state); }
  static pid_t ChildPid(const nlohmann::json& st, const std::string& name) {
    return test::StatusChild(st, name).value("pid", -1);
  }
  static bool StatusChildReady(const nlohmann::json& st, const std::string& name) {
    return test::StatusChild(st, name).value("ready", false);
  }

  static std::unique_ptr<TempDir> tmp_;
  static fs::path dir_, seq_;
  pid_t pid_ = -1;
};
std::unique_ptr<TempDir> Daemon::tmp_;
fs::path Daemon::dir_, Daemon::seq_;

TEST_F(Daemon, NotifyProtocolWatchdogHangupAndABoundedStop) {
  NotifyServer systemd("rumi-daemon-test-" + std::to_string(::getpid()));
  const std::string cfg = Config("notify", "  manager_stall_s: 2.0\n");
  const std::string log = (dir_ / "rumid_notify.log").string();
  pid_ = Start({"--config", cfg, "--instance", "dnotify" + std::to_string(::getpid() % 100000)},
               {"NOTIFY_SOCKET=" + systemd.address(), "WATCHDOG_USEC=1000000"}, log);
  const fs::path state = State("notify");

  // READY=1 once front, back and manager are up; STATUS= lines before and after.
  bool ready = false, stopping = false;
  std::string status_line;
  std::vector<double> watchdog_at;
  const auto t0 = Clock::now();
  auto drain = [&](double seconds) {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    while (Clock::now() < until) {
      for (const auto& m : systemd.Receive(0.05)) {
        if (m.pid != pid_) continue;
        if (m.fields.count("READY")) ready = true;
        if (m.fields.count("STATUS")) status_line = m.fields.at("STATUS");
        if (m.fields.count("WATCHDOG")) watchdog_at.push_back(Since(t0));
        if (m.fields.count("STOPPING")) stopping = true;
      }
    }
  };
  while (!ready && Since(t0) < 60) drain(0.2);
  ASSERT_TRUE(ready) << Slurp(log);
  const nlohmann::json st = Status(state);
  for (const auto& c : st["children"]) EXPECT_TRUE(c.value("ready", false)) << c.dump();

  // WATCHDOG=1 every WatchdogSec/2 (0.5 s) while all is well.
  watchdog_at.clear();
  drain(3.0);
  EXPECT_GE(watchdog_at.size(), 4u) << Slurp(log);
  EXPECT_NE(status_line.find("source replaying"), std::string::npos) << status_line;

  // `rumi status` shows it.
  ASSERT_EQ(test::RunRumiLogged("status --state-dir " + state.string(), dir_ / "status.txt"), 0)
      << Slurp(dir_ / "status.txt");
  const std::string table = Slurp(dir_ / "status.txt");
  for (const char* s : {"rumi-front", "rumi-back", "rumi-manager", "tracking", "replaying"})
    EXPECT_NE(table.find(s), std::string::npos) << s << "\n" << table;
  ASSERT_EQ(test::RunRumiLogged("status --json --state-dir " + state.string(), dir_ / "status.json.txt"), 0);
  EXPECT_TRUE(nlohmann::json::parse(Slurp(dir_ / "status.json.txt"))["alive"].get<bool>());

  // A manager whose loop stops turning: rumid itself kills it after
  // manager_stall_s and starts another (it used to stop pinging and leave
  // it to systemd); WATCHDOG=1 goes on once the new one beats.
  const pid_t manager = ChildPid(Status(state), "rumi-manager");
  ASSERT_GT(manager, 0);
  ::kill(manager, SIGSTOP);
  pid_t restarted = manager;
  const auto t_stop = Clock::now();
  while (Since(t_stop) < 20 && (restarted == manager || restarted <= 0)) {
    drain(0.2);
    restarted = ChildPid(Status(state), "rumi-manager");
  }
  EXPECT_NE(restarted, manager) << Slurp(log);
  while (Since(t_stop) < 30 && !StatusChildReady(Status(state), "rumi-manager")) drain(0.2);
  watchdog_at.clear();
  drain(2.0);
  EXPECT_FALSE(watchdog_at.empty()) << "pings did not resume";

  // SIGHUP: the config is read again and the new log level applied, here and in the children.
  {
    std::string text = Slurp(cfg);
    text.replace(text.find("log_level: info"), 15, "log_level: debug");
    std::ofstream(cfg) << text;
  }
  ::kill(pid_, SIGHUP);
  const auto t_hup = Clock::now();
  const fs::path front_log = state / "logs" / "rumi-front.log";
  while (Since(t_hup) < 10 && Slurp(front_log).find("log level now debug") == std::string::npos) drain(0.2);
  EXPECT_NE(Slurp(log).find("SIGHUP: log level now debug"), std::string::npos) << Slurp(log);
  EXPECT_NE(Slurp(front_log).find("SIGHUP: log level now debug"), std::string::npos);

  // SIGTERM: STOPPING=1, exit 0 within daemon.stop_timeout_s (10 s), nothing left behind.
  std::vector<pid_t> children;
  for (const auto& c : Status(state)["children"]) children.push_back(c.value("pid", -1));
  const std::string instance = Status(state)["instance"];
  ::kill(pid_, SIGTERM);
  const auto t_term = Clock::now();
  int rc = -1;
  while (rc == -1 && Since(t_term) < 15) {
    drain(0.05);
    rc = WaitExit(pid_, 0.05);
  }
  const double stop_s = Since(t_term);
  pid_ = -1;
  EXPECT_EQ(rc, 0) << Slurp(log);
  EXPECT_LT(stop_s, 12.0);  // daemon.stop_timeout_s (10 s), then what is left is killed
  std::printf("rumid stopped %.2f s after SIGTERM\n", stop_s);
  EXPECT_TRUE(stopping) << "no STOPPING=1";
  for (pid_t c : children) EXPECT_FALSE(ProcessRunning(c)) << "child " << c << " outlived rumid";
  for (const std::string& name : InstanceSegmentNames(instance)) {
    RingStats s;
    EXPECT_FALSE(ReadRingStats(name, &s)) << name << " left behind";
  }
  EXPECT_EQ(Status(state)["state"], "stopped");
  EXPECT_EQ(test::RunRumiLogged("status --state-dir " + state.string(), dir_ / "status2.txt"), 3);
  EXPECT_NE(Slurp(dir_ / "status2.txt").find("not running"), std::string::npos);
  // The map of the session is there.
  EXPECT_TRUE(fs::exists(state / "map.rumi"));
  EXPECT_GT(fs::file_size(state / "merged.txt"), 100u);
}

TEST_F(Daemon, OneRumidPerStateFolder) {
  const std::string cfg = Config("lock");
  const std::string log = (dir_ / "rumid_lock_a.log").string();
  pid_ = Start({"--config", cfg}, {}, log);
  WaitRunning("lock");  // (the checks below need the lock, not readiness)
  const std::string log_b = (dir_ / "rumid_lock_b.log").string();
  const pid_t b = Start({"--config", cfg, "--instance", "another"}, {}, log_b);
  EXPECT_EQ(WaitExit(b, 20), 2);
  EXPECT_NE(Slurp(log_b).find("another rumid (pid " + std::to_string(pid_) + ") runs on"), std::string::npos)
      << Slurp(log_b);
  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 15), 0);
  pid_ = -1;
}

// Two rumids of one instance name (two robot.yaml in two folders): the second
// is refused before it touches the first one's shared memory (#50.2: it
// removed the first one's segments at its stop).
TEST_F(Daemon, OneRumidPerInstance) {
  const std::string cfg = Config("inst");
  pid_ = Start({"--config", cfg}, {}, (dir_ / "rumid_inst_a.log").string());
  WaitRunning("inst");  // (the checks below need the lock, not readiness)
  const std::string log_b = (dir_ / "rumid_inst_b.log").string();
  const pid_t b = Start({"--config", cfg, "--state-dir", (dir_ / "state_inst_b").string()}, {}, log_b);
  EXPECT_EQ(WaitExit(b, 20), 2);
  EXPECT_NE(Slurp(log_b).find("another rumid (pid " + std::to_string(pid_) + ") runs instance 'inst'"),
            std::string::npos)
      << Slurp(log_b);
  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 15), 0);
  pid_ = -1;
}

// The state folder deleted under a running rumid (#50.3: a warning every
// second, the folder never came back, and a second rumid could start on the
// same path): made again and locked again, said in the log, and the map is
// saved there at the stop.
TEST_F(Daemon, ADeletedStateFolderIsMadeAndLockedAgain) {
  const std::string cfg = Config("gone");
  const std::string log = (dir_ / "rumid_gone.log").string();
  pid_ = Start({"--config", cfg}, {}, log);
  WaitRunning("gone");  // (the relock needs rumid's loop, not the children's readiness)
  fs::remove_all(State("gone"));
  test::WaitFor([&] { return Slurp(log).find("locking it again") != std::string::npos; }, 10, std::chrono::milliseconds(50));
  EXPECT_NE(Slurp(log).find("was deleted or replaced while rumid ran"), std::string::npos) << Slurp(log);
  EXPECT_TRUE(fs::exists(State("gone") / "rumid.lock"));
  const std::string log_b = (dir_ / "rumid_gone_b.log").string();
  const pid_t b = Start({"--config", cfg, "--instance", "gone_b"}, {}, log_b);
  EXPECT_EQ(WaitExit(b, 20), 2);
  EXPECT_NE(Slurp(log_b).find("another rumid (pid " + std::to_string(pid_) + ") runs on"), std::string::npos)
      << Slurp(log_b);
  EXPECT_TRUE(test::WaitFor([&] { return fs::exists(State("gone") / "status.json"); }, 10, std::chrono::milliseconds(50)));
  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 20), 0) << Slurp(log);
  pid_ = -1;
  EXPECT_TRUE(fs::exists(State("gone") / "map.rumi")) << Slurp(log);
}

// A manager stopped (SIGSTOP) sends no heartbeat: rumid kills and restarts
// it after daemon.manager_stall_s, with or without systemd (#50.5: 90 s of
// "running" with nothing done and nothing logged).
TEST_F(Daemon, AStalledManagerIsKilledAndRestarted) {
  const std::string cfg = Config("stall", "  manager_stall_s: 2\n");
  const std::string log = (dir_ / "rumid_stall.log").string();
  pid_ = Start({"--config", cfg}, {}, log);
  WaitRunning("stall");
  auto t0 = Clock::now();
  const pid_t stopped = ChildPid(Status(State("stall")), "rumi-manager");
  ASSERT_GT(stopped, 0) << Slurp(log);
  ASSERT_EQ(::kill(stopped, SIGSTOP), 0);
  t0 = Clock::now();
  pid_t now = stopped;
  while (Since(t0) < 30) {
    now = ChildPid(Status(State("stall")), "rumi-manager");
    if (now > 0 && now != stopped) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_NE(now, stopped) << Slurp(log);
  EXPECT_GT(now, 0) << Slurp(log);
  EXPECT_NE(Slurp(log).find("rumi-manager (pid " + std::to_string(stopped) + ") sent no heartbeat"),
            std::string::npos)
      << Slurp(log);
  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 20), 0) << Slurp(log);
  pid_ = -1;
}

// The manager's final save fails (map.rumi cannot be replaced: here a
// folder in its way, as a full disk would): rumid exits 1 and says what is
// kept (#50.5: it logged "stopped" and exited 0).
TEST_F(Daemon, AFailedFinalSaveFailsRumid) {
  const std::string cfg = Config("save", "manager: {map_save_interval_s: 1}\n");
  const std::string log = (dir_ / "rumid_save.log").string();
  pid_ = Start({"--config", cfg}, {}, log);
  WaitRunning("save");
  // A save or two, then the map file cannot be replaced.
  test::WaitFor([&] { return fs::exists(State("save") / "map.rumi"); }, 30, std::chrono::milliseconds(50));
  fs::remove(State("save") / "map.rumi");
  fs::create_directories(State("save") / "map.rumi" / "in_the_way");
  // The next save fails (the map is then unsaved at the stop, whatever comes).
  const fs::path manager_log = State("save") / "logs" / "rumi-manager.log";
  test::WaitFor([&] { return Slurp(manager_log).find("[error]") != std::string::npos; }, 30, std::chrono::milliseconds(50));
  ASSERT_NE(Slurp(manager_log).find("[error]"), std::string::npos) << Slurp(manager_log);
  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 20), 1) << Slurp(log);
  pid_ = -1;
  EXPECT_NE(Slurp(log).find("rumi-manager's last save failed"), std::string::npos) << Slurp(log);
  EXPECT_EQ(Status(State("save"))["state"], "failed");
}

// A child that crashes at every start: restarted with backoff, then given up
// on with one clear line; rumid fails (systemd's Restart= takes over).
TEST_F(Daemon, ACrashLoopGivesUpWithAClearLine) {
  const fs::path bin = dir_ / "bin_crash";
  fs::create_directories(bin);
  for (const char* b : {"rumi-back", "rumi-manager"}) fs::create_symlink(Bin(b), bin / b);
  std::ofstream(bin / "rumi-front") << "#!/bin/sh\necho 'rumi-front: simulated crash' >&2\nkill -SEGV $$\n";
  fs::permissions(bin / "rumi-front", fs::perms::owner_all);
  const std::string cfg = Config("crash", "  crash_loop_restarts: 2\n  crash_loop_window_s: 60\n");
  const std::string log = (dir_ / "rumid_crash.log").string();
  pid_ = Start({"--config", cfg, "--bin-dir", bin.string()}, {}, log);
  const int rc = WaitExit(pid_, 60);
  pid_ = -1;
  EXPECT_EQ(rc, 1) << Slurp(log);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find("rumi-front crashed 3 times within 60 s"), std::string::npos) << text;
  EXPECT_NE(text.find("giving up on it"), std::string::npos) << text;
  EXPECT_NE(text.find("restarting it in 0.1 s"), std::string::npos) << text;
  EXPECT_NE(text.find("restarting it in 0.2 s"), std::string::npos) << text;  // backoff doubles
  EXPECT_EQ(Status(State("crash"))["state"], "failed");
}

// A child that refuses its input (exit 2): given up on at once, and rumid
// exits 2 too, which the unit does not restart (RestartPreventExitStatus=2;
// it used to exit 1, and systemd retried a config that cannot load 5 times).
TEST_F(Daemon, AChildThatRefusesItsInputEndsRumidWithExit2) {
  const fs::path bin = dir_ / "bin_refuse";
  fs::create_directories(bin);
  for (const char* b : {"rumi-back", "rumi-manager"}) fs::create_symlink(Bin(b), bin / b);
  std::ofstream(bin / "rumi-front") << "#!/bin/sh\necho 'rumi-front: source: no such camera' >&2\nexit 2\n";
  fs::permissions(bin / "rumi-front", fs::perms::owner_all);
  const std::string cfg = Config("refuse");
  const std::string log = (dir_ / "rumid_refuse.log").string();
  pid_ = Start({"--config", cfg, "--bin-dir", bin.string()}, {}, log);
  const int rc = WaitExit(pid_, 60);
  pid_ = -1;
  EXPECT_EQ(rc, 2) << Slurp(log);
  EXPECT_NE(Slurp(log).find("rumid exits 2"), std::string::npos) << Slurp(log);
  EXPECT_EQ(Status(State("refuse"))["state"], "failed");
}

// The live map over DDS (loopback): `rumi query` answers from rumid's
// manager while the sequence plays: the live pose at frame rate, the
// status, the trajectory, the points and the grid (metric from the
// sequence's odometry, the robot's pose source).
TEST_F(Daemon, ServesTheLiveMapOverDds) {
  const std::string instance = "dds" + std::to_string(::getpid());
  const std::string cfg = Config("dds", "dds: {enabled: true}\nview: {port: 0}\n");
  {
    std::string text = Slurp(cfg);
    const std::string loop = "loop: true}";
    text.replace(text.find(loop), loop.size(), "odometry: " + (seq_ / "odometry.txt").string() + ", " + loop);
    std::ofstream(cfg) << text;
  }
  const std::string log = (dir_ / "rumid_dds.log").string();
  pid_ = Start({"--config", cfg, "--instance", instance}, {}, log);
  const std::string q = "query --instance " + instance + " ";
  // The first saves come within seconds (bounded generously: a loaded CI).
  nlohmann::json st;
  const auto t0 = Clock::now();
  while (Since(t0) < 180) {
    ASSERT_EQ(test::RunRumiLogged(q + "--timeout 30 status --json", dir_ / "dds_status.txt"), 0)
        << Slurp(dir_ / "dds_status.txt");
    st = nlohmann::json::parse(Slurp(dir_ / "dds_status.txt"), nullptr, false);
    if (st.is_object() && !st.value("last_save", "").empty() && st.value("grid", "").rfind("grid ", 0) == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  ASSERT_TRUE(st.is_object());
  EXPECT_EQ(st.value("state", ""), "running") << st.dump();
  EXPECT_GE(st.value("keyframes", 0), 5) << st.dump();
  EXPECT_FALSE(st.value("last_save", "").empty()) << st.dump();
  ASSERT_EQ(test::RunRumiLogged(q + "--timeout 60 pose --follow --count 30 --json", dir_ / "pose.txt"), 0)
      << Slurp(dir_ / "pose.txt") << Slurp(log);
  std::istringstream poses(Slurp(dir_ / "pose.txt"));
  int n = 0, fine = 0, global = 0;
  int64_t last_t = 0;
  for (std::string line; std::getline(poses, line);) {
    const auto j = nlohmann::json::parse(line, nullptr, false);
    ASSERT_TRUE(j.is_object()) << line;
    const int64_t t = j.value("t_ns", int64_t{0});
    EXPECT_GT(t, last_t) << "poses arrive in frame order";
    last_t = t;
    fine += j.value("state", "") == "fine";
    global += j.value("in_global", false);
    ++n;
  }
  EXPECT_EQ(n, 30);
  EXPECT_GE(fine, 20) << Slurp(dir_ / "pose.txt");  // a smooth walk: tracked
  // Its submap is in the saved map by now: poses come in the global frame.
  EXPECT_GT(global, 0) << "no pose in the global frame";

  // The web view (docs/view.md), a DDS client of the manager in rumid: its
  // address in status.json, the map and the live pose from the manager.
  const std::string view = Status(State("dds")).value("view", "");
  ASSERT_EQ(view.rfind("http://127.0.0.1:", 0), 0u) << Status(State("dds")).dump();
  httplib::Client web(view.substr(0, view.size() - 1));
  nlohmann::json map, state;
  EXPECT_TRUE(test::WaitFor(
      [&] {
        auto m = web.Get("/api/map"), s = web.Get("/api/state");
        if (!m || !s || m->status != 200 || s->status != 200) return false;
        map = nlohmann::json::parse(m->body, nullptr, false);
        state = nlohmann::json::parse(s->body, nullptr, false);
        return map.is_object() && state.is_object() && map["counts"].value("keyframes", 0) >= 5 &&
               !state["trail"].empty() && state["status"].contains("children") && !state["events"].empty();
      },
      120, std::chrono::milliseconds(500)))
      << map.dump().substr(0, 500) << "\n" << state.dump().substr(0, 500);
  EXPECT_GT(map["counts"].value("points", 0), 100);
  EXPECT_EQ(web.Post("/api/map", "", "text/plain")->status, 405);

  const fs::path grid = dir_ / "dds_grid" / "map.yaml";
  fs::create_directories(grid.parent_path());
  ASSERT_EQ(st.value("grid", "").rfind("grid ", 0), 0u) << st.dump();
  ASSERT_EQ(test::RunRumiLogged(q + "grid -o " + grid.string(), dir_ / "dds_grid.txt"), 0)
      << Slurp(dir_ / "dds_grid.txt");
  // What a map_server reads: the header, its thresholds, the cells.
  MapServerGrid g;
  std::string why;
  ASSERT_TRUE(ReadMapServerGrid(grid.string(), &g, &why)) << why;
  EXPECT_EQ(g.image, "map.pgm");
  EXPECT_DOUBLE_EQ(g.occupied_thresh, 0.65);
  EXPECT_DOUBLE_EQ(g.free_thresh, 0.196);
  EXPECT_DOUBLE_EQ(g.resolution, OccupancyGridOptions{}.resolution_m);
  int free_cells = 0;
  for (uint8_t v : g.pixels) free_cells += v == kPgmFree;
  EXPECT_GT(free_cells, 100);
  EXPECT_NE(Slurp(grid).find("rumi_scale_source: odometry"), std::string::npos) << Slurp(grid);

  ASSERT_EQ(test::RunRumiLogged(q + "trajectory -o " + (dir_ / "dds_traj.txt").string(), dir_ / "dds_traj.log"), 0)
      << Slurp(dir_ / "dds_traj.log");
  EXPECT_GT(fs::file_size(dir_ / "dds_traj.txt"), 1000u);
  ASSERT_EQ(test::RunRumiLogged(q + "points --json", dir_ / "dds_points.txt"), 0);
  const auto pts = nlohmann::json::parse(Slurp(dir_ / "dds_points.txt"), nullptr, false);
  ASSERT_TRUE(pts.is_object());
  EXPECT_GT(pts.value("total", 0), 100);

  ::kill(pid_, SIGTERM);
  EXPECT_EQ(WaitExit(pid_, 20), 0) << Slurp(log);
  pid_ = -1;
  // rumid keeps a ring that still holds unread messages (a window the back
  // had not read yet, on a loaded machine) for the instance's next start;
  // this instance has none.
  RemoveInstanceSegments(instance, /*force=*/true);
}

// Bad configs stop rumid at once with the file, the key and the reason.
TEST_F(Daemon, BadConfigIsRefusedNamingTheKey) {
  const std::string cfg = Config("bad", "  stop_timeout_s: -1\n");
  const std::string log = (dir_ / "rumid_bad.log").string();
  const pid_t pid = Start({"--config", cfg}, {}, log);
  EXPECT_EQ(WaitExit(pid, 20), 2);
  EXPECT_NE(Slurp(log).find("daemon.stop_timeout_s"), std::string::npos) << Slurp(log);
}

}  // namespace
}  // namespace rumi
