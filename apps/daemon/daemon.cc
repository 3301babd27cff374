#include "apps/daemon/daemon.h"

#include <signal.h>
#include <sys/wait.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/process/process_info.h"
#include "common/process/subprocess.h"
#include "common/process/supervisor.h"
#include "ipc/segments.h"
#include "ipc/daemon_status.h"
#include "apps/daemon/state_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int64_t kIdsPerGeneration = 1000000;  // submaps and windows of one front/back start

double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string WallClockNow() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S%z", std::localtime(&t));
  return buf;
}

int64_t SteadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

// Replaces "--first-submap-id N" with a fresh id base from the state folder.
void SetIdBase(const StateDirLayout& layout, std::vector<std::string>* argv) {
  std::string why;
  long g = NextGeneration(layout, &why);
  if (g < 0) {
    spdlog::error("rumid: {}; ids from the process start time instead", why);
    g = static_cast<long>(std::time(nullptr) % 100000);
  }
  for (size_t i = 0; i + 1 < argv->size(); ++i)
    if ((*argv)[i] == "--first-submap-id") (*argv)[i + 1] = std::to_string(g * kIdsPerGeneration);
}

// Resident memory (MiB: all, private, shared segments) and open file
// descriptors of a process; -1 unknown.
void AddResources(pid_t pid, nlohmann::json* j) {
  const ResidentMemory mem = ResidentMemoryOf(pid);
  int fds = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec); !ec && it != fs::directory_iterator();
       it.increment(ec))
    ++fds;
  (*j)["rss_mib"] = mem.total_mib;
  (*j)["private_mib"] = mem.private_mib;
  (*j)["shared_mib"] = mem.shared_mib;
  (*j)["fds"] = ec ? -1 : fds;
}

nlohmann::json RingsJson(const std::string& instance) {
  nlohmann::json rings = nlohmann::json::array();
  for (const std::string& name : InstanceSegmentNames(instance)) {
    RingStats s;
    if (!ReadRingStats(name, &s)) continue;
    rings.push_back({{"name", name},
                     {"pushed", s.pushed},
                     {"popped", s.popped},
                     {"dropped", s.dropped_full + s.dropped_oldest + s.dropped_too_large},
                     {"producer_alive", s.producer_alive},
                     {"consumer_alive", s.consumer_alive}});
  }
  return rings;
}

}  // namespace

int RunDaemon(const DaemonRunOptions& o, const std::atomic<bool>* stop, std::atomic<bool>* forward_hangup) {
  const auto started = Clock::now();
  const std::string started_wall = WallClockNow();
  const StateDirLayout layout{o.state_dir};
  std::error_code ec;
  for (const std::string& d : {layout.root, layout.Front(), layout.Back(), layout.Logs()}) {
    fs::create_directories(d, ec);
    if (ec) {
      spdlog::error("rumid: cannot create {}: {}", d, ec.message());
      return kExitError;
    }
  }
  StateDirLock lock;
  std::string why;
  if (!lock.Acquire(layout, &why)) {
    spdlog::error("rumid: {}", why);
    return kExitBadInput;
  }
  // One rumid per instance on the machine too: the instance names the
  // shared-memory segments, and a second rumid of the same name (two
  // robot.yaml in two folders) removed the first one's at its stop.
  StateDirLock instance_lock;
  if (!instance_lock.Acquire(InstanceLockPath(o.instance), "instance '" + o.instance + "' on this machine", &why)) {
    spdlog::error("rumid: {}: give this one another --instance (or daemon.instance)", why);
    return kExitBadInput;
  }
  const RumiConfig& c = o.config;
  if (c.source.kind == "dataset" && c.source.path.empty()) {
    spdlog::error("rumid: source.path is empty in {}: which dataset, camera or stream?", o.config_path);
    return kExitBadInput;
  }
  if (c.source.kind == "capture" && !c.has_camera) {
    spdlog::error("rumid: source.kind capture needs the camera's calibration: a camera: section in {}", o.config_path);
    return kExitBadInput;
  }
  for (const char* bin : {"rumi-front", "rumi-back", "rumi-manager"}) {
    const std::string p = o.bin_dir + "/" + bin;
    if (::access(p.c_str(), X_OK) != 0) {
      spdlog::error("rumid: {} not found or not executable (daemon.bin_dir, --bin-dir)", p);
      return kExitBadInput;
    }
  }
  for (const std::string& name : ReclaimStaleSegments(o.instance))
    spdlog::info("rumid: removed the stale shared-memory segment {} (its processes are gone)", name);
  // This instance's own segments left by a rumid that was killed: kept when
  // they hold unread messages (the restarted consumers read them), removed
  // when drained (a finished producer's closed segment would read as "done").
  for (const std::string& name : InstanceSegmentNames(o.instance)) {
    RingStats rs;
    if (!ReadRingStats(name, &rs)) continue;
    // Unread poses and notices are stale: those rings never wait for their reader.
    const bool drained = rs.tail >= rs.head || NewestWinsSegment(o.instance, name);
    if (!rs.producer_alive && !rs.consumer_alive && drained && RemoveSegment(name))
      spdlog::info("rumid: removed {}, drained, left by an earlier run", name);
  }

  // ---- the children ----
  const DaemonOptions& d = c.daemon;
  SupervisorOptions so;
  so.restart = true;
  so.backoff_initial_s = d.restart_backoff_initial_s;
  so.backoff_max_s = d.restart_backoff_max_s;
  so.crash_loop_starts = d.crash_loop_restarts;
  so.crash_loop_window_s = d.crash_loop_window_s;
  so.notify_name = "rumid-" + o.instance + "-" + std::to_string(::getpid());
  Supervisor sup(so);
  const bool files = d.child_output == "files";
  auto add = [&](const char* name, std::vector<std::string> argv, bool low_priority,
                 std::function<void(int, std::vector<std::string>*)> prepare) {
    ChildSpec s;
    s.name = name;
    s.argv = std::move(argv);
    if (!o.config_path.empty()) s.argv.insert(s.argv.end(), {"--config", o.config_path});
    s.log_path = files ? layout.Logs() + "/" + name + ".log" : "";
    s.low_priority = low_priority;
    s.prepare = std::move(prepare);
    return sup.Add(std::move(s));
  };
  const auto fresh_ids = [&layout](int, std::vector<std::string>* argv) { SetIdBase(layout, argv); };
  const int manager = add("rumi-manager",
                          {o.bin_dir + "/rumi-manager", "--instance", o.instance, "--out", layout.root, "--daemon"},
                          false, nullptr);
  const int back = add("rumi-back",
                       {o.bin_dir + "/rumi-back", "--instance", o.instance, "--work", layout.Back(), "--daemon",
                        "--first-submap-id", "0"},
                       c.back.low_priority, fresh_ids);
  // A dataset plays as a camera would: its first frame is due shortly after
  // the daemon started, and a restarted front joins where the stream is.
  const int64_t replay_start_ns = SteadyNowNs() + 2'000'000'000LL;
  std::vector<std::string> front_argv = {o.bin_dir + "/rumi-front", "--instance", o.instance, "--out",
                                         layout.Front(), "--daemon", "--first-submap-id", "0"};
  front_argv.insert(front_argv.end(), {"--replay-start-ns", std::to_string(replay_start_ns)});
  if (o.source_overridden) {
    front_argv.insert(front_argv.end(), {"--dataset", c.source.dataset, c.source.path});
    if (!c.source.calibration.empty()) front_argv.insert(front_argv.end(), {"--calibration", c.source.calibration});
  }
  const int front = add("rumi-front", front_argv, false, fresh_ids);

  Notifier systemd;  // rumid's own $NOTIFY_SOCKET (systemd's)
  uint64_t watchdog_usec = 0;
  const bool watchdog = sd_watchdog_enabled(0, &watchdog_usec) > 0 && watchdog_usec > 0;
  spdlog::info("rumid: instance {}, state {}, config {}, source {} {}{}", o.instance, o.state_dir,
               o.config_path.empty() ? "(defaults)" : o.config_path, c.source.kind, c.source.path,
               watchdog ? ", watchdog " + std::to_string(watchdog_usec / 1000) + " ms" : "");

  std::string state = "starting";
  std::string failure;
  int failure_code = kExitError;  // kExitBadInput when a child refused its input: restarting cannot help
  auto status_json = [&]() {
    nlohmann::json st;
    st["instance"] = o.instance;
    st["pid"] = ::getpid();
    st["pid_start_ticks"] = SelfProcessId().start_ticks;
    st["state"] = state;
    st["started"] = started_wall;
    st["updated"] = WallClockNow();
    st["updated_unix_s"] = NsToSeconds(WallNowNs());
    st["status_interval_s"] = d.status_interval_s;
    st["uptime_s"] = Since(started);
    st["config"] = o.config_path;
    st["state_dir"] = o.state_dir;
    if (!failure.empty()) st["failure"] = failure;
    nlohmann::json children = nlohmann::json::array();
    for (int i = 0; i < static_cast<int>(sup.size()); ++i) {
      const ChildInfo& in = sup.info(i);
      nlohmann::json ch = {{"name", in.name},
                           {"pid", in.pid},
                           {"state", ToString(in.state)},
                           {"uptime_s", in.uptime_s()},
                           {"restarts", in.restarts()},
                           {"ready", in.ready}};
      const double hb = in.heartbeat_age_s();
      ch["heartbeat_age_s"] = std::isfinite(hb) ? nlohmann::json(hb) : nlohmann::json();
      if (in.exited_once) ch["last_exit"] = DescribeWaitStatus(in.last_status);
      if (in.state == ChildState::kRunning) AddResources(in.pid, &ch);
      children.push_back(ch);
    }
    st["children"] = children;
    nlohmann::json self;
    AddResources(::getpid(), &self);
    st["rumid"] = self;
    st["front"] = sup.info(front).status.is_null() ? nlohmann::json::object() : sup.info(front).status;
    st["back"] = sup.info(back).status.is_null() ? nlohmann::json::object() : sup.info(back).status;
    st["manager"] = sup.info(manager).status.is_null() ? nlohmann::json::object() : sup.info(manager).status;
    if (!st["front"].contains("source")) st["front"]["source"] = c.source.kind + " " + c.source.path;
    st["rings"] = RingsJson(o.instance);
    st["summary"] = DaemonSummary(st);
    return st;
  };
  // The state folder deleted under a running rumid: its lock guarded nothing
  // and status.json could not be written (a warning a second). Made again
  // and locked again, said in the log: the manager has the map in memory and
  // writes it there at its next save.
  auto relock_if_lost = [&]() {
    if (lock.StillHeld()) return;
    spdlog::warn("rumid: the state folder {} was deleted or replaced while rumid ran: making it again and "
                 "locking it again (the manager writes the map there at its next save)",
                 layout.root);
    std::error_code mk;
    for (const std::string& d : {layout.root, layout.Front(), layout.Back(), layout.Logs()}) fs::create_directories(d, mk);
    std::string err;
    if (!lock.Acquire(layout, &err) && failure.empty()) failure = "the state folder was taken over: " + err;
  };
  auto publish = [&]() {
    relock_if_lost();
    const nlohmann::json st = status_json();
    std::string err;
    if (!WriteFileAtomically(layout.Status(), st.dump(2) + "\n", &err)) spdlog::warn("rumid: {}", err);
    systemd.Status(st["summary"].get<std::string>());
  };

  // ---- start: the manager (map reloaded), the back, the front ----
  bool started_all = true;
  for (int i : {manager, back, front}) {
    if (!sup.Start(i, &why)) {
      failure = sup.info(i).name + ": " + why;
      started_all = false;
      break;
    }
    // The next one starts once the manager is up (the map loaded; at most
    // 30 s, or until it died). Not so for the back: it runs at idle priority
    // and, on a busy machine, may take minutes to come up; the front never
    // waits for it (its windows wait in the ring).
    if (i != manager) continue;
    const auto t0 = Clock::now();
    while (!sup.info(i).ready && sup.Alive(i) && Since(t0) < 30 && !(stop && stop->load())) sup.Poll(0.05);
  }

  std::vector<pid_t> stall_killed(sup.size(), -1);  // the pid killed as stalled, per child
  bool ready_sent = false, source_ended = false;
  pid_t back_told = -1, manager_told = -1;  // told the source ended (SIGUSR1)
  auto last_watchdog = Clock::now() - std::chrono::hours(1);
  auto last_status = last_watchdog;
  while (started_all && failure.empty() && !(stop && stop->load())) {
    for (const Supervisor::Exit& e : sup.Poll(0.1)) {
      const ChildInfo& in = sup.info(e.child);
      if (!e.crash && e.child == front) {
        source_ended = true;
        spdlog::info("rumid: the source ended; the back finishes its windows, the manager saves, then rumid exits");
      } else if (!e.crash) {
        spdlog::info("rumid: {} finished", in.name);
      }
    }
    // A child given up on (a crash loop, a config it refuses): the daemon fails.
    for (int i = 0; i < static_cast<int>(sup.size()) && failure.empty(); ++i) {
      const ChildInfo& in = sup.info(i);
      if (in.state != ChildState::kGaveUp) continue;
      failure = in.name + " " + DescribeWaitStatus(in.last_status) + " and was given up on";
      if (WIFEXITED(in.last_status) && WEXITSTATUS(in.last_status) == kExitBadInput) {
        failure += " (its config or input cannot load: rumid exits 2, which the unit does not restart)";
        failure_code = kExitBadInput;
      }
    }
    if (!failure.empty()) break;
    // A child alive but silent (SIGSTOP, a deadlock) does nothing and says
    // nothing: killed, it is restarted as after a crash (a manager stopped
    // for 90 s stayed "running" and only systemd's watchdog would act).
    for (const auto& [i, stall_s] : {std::pair<int, double>{front, d.front_stall_s}, {back, d.back_stall_s},
                                     {manager, d.manager_stall_s}}) {
      const ChildInfo& in = sup.info(i);
      const double age = in.heartbeat_age_s();
      if (in.state != ChildState::kRunning || !in.ready || !std::isfinite(age) || age < stall_s) continue;
      if (stall_killed[i] == in.pid) continue;  // killed already, not reaped yet
      stall_killed[i] = in.pid;
      spdlog::error("rumid: {} (pid {}) sent no heartbeat for {:.0f} s (daemon.{}_stall_s {}): stalled; killing it "
                    "to restart it",
                    in.name, in.pid, age, i == front ? "front" : i == back ? "back" : "manager", stall_s);
      sup.Signal(i, SIGKILL);
    }
    if (forward_hangup && forward_hangup->exchange(false)) {
      for (int i = 0; i < static_cast<int>(sup.size()); ++i) sup.Signal(i, SIGHUP);
    }
    if (!sup.AnyRunning()) {
      bool backoff = false;
      for (int i = 0; i < static_cast<int>(sup.size()); ++i) backoff |= sup.info(i).state == ChildState::kBackoff;
      if (!backoff) break;  // everyone finished: the session is complete
    }
    const bool all_ready = sup.info(front).ready && sup.info(back).ready && sup.info(manager).ready;
    if (!ready_sent && all_ready) {
      ready_sent = true;
      state = "running";
      publish();  // status.json says so before systemd hears it
      last_status = Clock::now();
      systemd.Ready();
      spdlog::info("rumid: ready (front, back and manager up, map loaded)");
    }
    if (source_ended && state == "running") state = "finishing";
    // The source ended: the back finishes its windows, then the manager its
    // map (SIGUSR1 each, once per process, once it is up).
    if (source_ended) {
      const ChildInfo& b = sup.info(back);
      if (b.state == ChildState::kRunning && b.ready && b.pid != back_told) {
        sup.Signal(back, SIGUSR1);
        back_told = b.pid;
      }
      const bool back_done = b.state == ChildState::kExited && WIFEXITED(b.last_status) &&
                             WEXITSTATUS(b.last_status) == kExitDone;
      const ChildInfo& m = sup.info(manager);
      if (back_done && m.state == ChildState::kRunning && m.ready && m.pid != manager_told) {
        sup.Signal(manager, SIGUSR1);
        manager_told = m.pid;
      }
    }
    // WATCHDOG=1 only while every child is alive and the manager's loop turns.
    if (watchdog && Since(last_watchdog) * 2e6 >= static_cast<double>(watchdog_usec)) {
      bool healthy = sup.Alive(manager) && sup.info(manager).state == ChildState::kRunning &&
                     sup.info(manager).heartbeat_age_s() < d.manager_stall_s;
      for (int i : {front, back}) {
        const ChildState s = sup.info(i).state;
        healthy &= s == ChildState::kRunning || (s == ChildState::kExited && WIFEXITED(sup.info(i).last_status) &&
                                                 WEXITSTATUS(sup.info(i).last_status) == kExitDone);
      }
      if (healthy) {
        systemd.Send("WATCHDOG=1");
        last_watchdog = Clock::now();
      }
    }
    if (Since(last_status) >= d.status_interval_s) {
      last_status = Clock::now();
      publish();
    }
  }

  // ---- stop ----
  const bool by_signal = stop && stop->load();
  state = failure.empty() ? "stopping" : "failed";
  systemd.Stopping();
  if (!failure.empty()) spdlog::error("rumid: {}; stopping", failure);
  else if (by_signal) spdlog::info("rumid: stop requested; stopping the front, the back, the manager (at most {} s)",
                                   d.stop_timeout_s);
  publish();
  const auto t_stop = Clock::now();
  sup.StopAll({front, back, manager}, d.stop_timeout_s);
  // The manager's last save is the session's map: when it failed (a full
  // disk), rumid fails too and says what is kept (it logged "stopped" and
  // exited 0).
  const ChildInfo& last = sup.info(manager);
  if (failure.empty() && last.exited_once && WIFEXITED(last.last_status) &&
      WEXITSTATUS(last.last_status) == kExitError) {
    failure = "rumi-manager's last save failed (exit 1, its log says why): map.rumi is the last whole save, and "
              "the submaps received since are in map.rumi.received/ for the next start";
    spdlog::error("rumid: {}", failure);
    state = "failed";
  }
  // Drained segments go; one that still holds messages (a manager stopped
  // before it read them) stays for the next start, which reads it.
  for (const std::string& name : InstanceSegmentNames(o.instance)) {
    RingStats rs;
    if (!ReadRingStats(name, &rs)) continue;
    if (rs.tail >= rs.head || NewestWinsSegment(o.instance, name)) RemoveSegment(name);
    else spdlog::warn("rumid: {} keeps {} unread message(s) for the next start", name, rs.head - rs.tail);
  }
  if (failure.empty()) state = "stopped";
  publish();
  spdlog::info("rumid: {} in {:.1f} s", failure.empty() ? "stopped" : "failed", Since(t_stop));
  return failure.empty() ? kExitDone : failure_code;
}

}  // namespace rumi
