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
#include <functional>

#include "common/atomic_file.h"
#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/process/subprocess.h"
#include "common/process/supervisor.h"
#include "ipc/segments.h"
#include "apps/daemon/state_dir.h"
#include "apps/daemon/status_json.h"
#include "apps/view/view_session.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int64_t kIdsPerGeneration = 1000000;  // submaps and windows of one front/back start

double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

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

bool ExitedWith(const ChildInfo& in, int code) {
  return WIFEXITED(in.last_status) && WEXITSTATUS(in.last_status) == code;
}

// One rumid run: prepare the state folder, start the three children,
// supervise them until the session ends or a stop, then stop them.
class Daemon {
 public:
  Daemon(const DaemonRunOptions& o, const std::atomic<bool>* stop, std::atomic<bool>* forward_hangup)
      : o_(o), c_(o.config), d_(o.config.daemon), stop_(stop), forward_hangup_(forward_hangup),
        layout_{o.state_dir}, sup_(SupervisorOptionsOf(o)) {
    facts_.instance = o.instance;
    facts_.config_path = o.config_path;
    facts_.state_dir = o.state_dir;
    facts_.started = LocalWallClockText();
    facts_.started_at = Clock::now();
    facts_.status_interval_s = d_.status_interval_s;
    facts_.source = c_.source.kind + " " + c_.source.path;
  }

  int Run() {
    if (const int rc = Prepare(); rc >= 0) return rc;
    StartView();
    AddChildren();
    spdlog::info("rumid: instance {}, state {}, config {}, source {} {}{}", o_.instance, o_.state_dir,
                 o_.config_path.empty() ? "(defaults)" : o_.config_path, c_.source.kind, c_.source.path,
                 watchdog_ ? ", watchdog " + std::to_string(watchdog_usec_ / 1000) + " ms" : "");
    if (StartChildren())
      while (facts_.failure.empty() && !Stopped() && Tick()) {
      }
    return Stop();
  }

 private:
  static SupervisorOptions SupervisorOptionsOf(const DaemonRunOptions& o) {
    const DaemonOptions& d = o.config.daemon;
    SupervisorOptions so;
    so.restart = true;
    so.backoff_initial_s = d.restart_backoff_initial_s;
    so.backoff_max_s = d.restart_backoff_max_s;
    so.crash_loop_starts = d.crash_loop_restarts;
    so.crash_loop_window_s = d.crash_loop_window_s;
    so.notify_name = "rumid-" + o.instance + "-" + std::to_string(::getpid());
    return so;
  }

  bool Stopped() const { return stop_ && stop_->load(); }

  // The state folder made and locked, the config and binaries checked, stale
  // segments removed. -1 to go on, else the exit code.
  int Prepare() {
    std::error_code ec;
    for (const std::string& d : {layout_.root, layout_.Front(), layout_.Back(), layout_.Logs()}) {
      fs::create_directories(d, ec);
      if (ec) {
        spdlog::error("rumid: cannot create {}: {}", d, ec.message());
        return kExitError;
      }
    }
    std::string why;
    if (!lock_.Acquire(layout_, &why)) {
      spdlog::error("rumid: {}", why);
      return kExitBadInput;
    }
    // One rumid per instance on the machine too: the instance names the
    // shared-memory segments, and a second rumid of the same name (two
    // robot.yaml in two folders) removed the first one's at its stop.
    if (!instance_lock_.Acquire(InstanceLockPath(o_.instance), "instance '" + o_.instance + "' on this machine", &why)) {
      spdlog::error("rumid: {}: give this one another --instance (or daemon.instance)", why);
      return kExitBadInput;
    }
    if (c_.source.kind == "dataset" && c_.source.path.empty()) {
      spdlog::error("rumid: source.path is empty in {}: which dataset, camera or stream?", o_.config_path);
      return kExitBadInput;
    }
    if (c_.source.kind == "capture" && !c_.has_camera) {
      spdlog::error("rumid: source.kind capture needs the camera's calibration: a camera: section in {}", o_.config_path);
      return kExitBadInput;
    }
    for (const char* bin : {"rumi-front", "rumi-back", "rumi-manager"}) {
      const std::string p = o_.bin_dir + "/" + bin;
      if (::access(p.c_str(), X_OK) != 0) {
        spdlog::error("rumid: {} not found or not executable (daemon.bin_dir, --bin-dir)", p);
        return kExitBadInput;
      }
    }
    for (const std::string& name : ReclaimStaleSegments(o_.instance))
      spdlog::info("rumid: removed the stale shared-memory segment {} (its processes are gone)", name);
    // This instance's own segments left by a rumid that was killed: kept when
    // they hold unread messages (the restarted consumers read them), removed
    // when drained (a finished producer's closed segment would read as "done").
    for (const std::string& name : InstanceSegmentNames(o_.instance)) {
      RingStats rs;
      if (!ReadRingStats(name, &rs)) continue;
      // Unread poses and notices are stale: those rings never wait for their reader.
      const bool drained = rs.tail >= rs.head || NewestWinsSegment(o_.instance, name);
      if (!rs.producer_alive && !rs.consumer_alive && drained && RemoveSegment(name))
        spdlog::info("rumid: removed {}, drained, left by an earlier run", name);
    }
    return -1;
  }

  // The web view (docs/view.md): a thread here, a DDS client of the
  // manager like any other. One that cannot start (its port taken) is a
  // warning: the daemon runs without it.
  void StartView() {
    if (!c_.view.enabled) return;
    ViewSessionOptions v;
    v.view = c_.view;
    v.state_dir = layout_.root;
    v.live_dds = c_.dds.enabled;
    v.dds = c_.dds;
    v.instance = o_.instance;
    std::string why;
    view_ = ViewSession::Start(v, &why);
    if (!view_) {
      spdlog::warn("rumid: {}; running without the web view", why);
      return;
    }
    facts_.view = view_->Address();
    spdlog::info("rumid: the map's web view: {}", facts_.view);
  }

  int Add(const char* name, std::vector<std::string> argv, bool low_priority,
          std::function<void(int, std::vector<std::string>*)> prepare) {
    ChildSpec s;
    s.name = name;
    s.argv = std::move(argv);
    if (!o_.config_path.empty()) s.argv.insert(s.argv.end(), {"--config", o_.config_path});
    s.log_path = d_.child_output == "files" ? layout_.Logs() + "/" + name + ".log" : "";
    s.low_priority = low_priority;
    s.prepare = std::move(prepare);
    return sup_.Add(std::move(s));
  }

  void AddChildren() {
    const auto fresh_ids = [this](int, std::vector<std::string>* argv) { SetIdBase(layout_, argv); };
    manager_ = Add("rumi-manager",
                   {o_.bin_dir + "/rumi-manager", "--instance", o_.instance, "--out", layout_.root, "--daemon"}, false,
                   nullptr);
    back_ = Add("rumi-back",
                {o_.bin_dir + "/rumi-back", "--instance", o_.instance, "--work", layout_.Back(), "--daemon",
                 "--first-submap-id", "0"},
                c_.back.low_priority, fresh_ids);
    // A dataset plays as a camera would: its first frame is due shortly after
    // the daemon started, and a restarted front joins where the stream is.
    const int64_t replay_start_ns = SteadyNowNs() + 2'000'000'000LL;
    std::vector<std::string> front_argv = {o_.bin_dir + "/rumi-front", "--instance", o_.instance, "--out",
                                           layout_.Front(), "--daemon", "--first-submap-id", "0"};
    front_argv.insert(front_argv.end(), {"--replay-start-ns", std::to_string(replay_start_ns)});
    if (o_.source_overridden) {
      front_argv.insert(front_argv.end(), {"--dataset", c_.source.dataset, c_.source.path});
      if (!c_.source.calibration.empty()) front_argv.insert(front_argv.end(), {"--calibration", c_.source.calibration});
    }
    front_ = Add("rumi-front", front_argv, false, fresh_ids);
    facts_.front = front_;
    facts_.back = back_;
    facts_.manager = manager_;
    stall_killed_.assign(sup_.size(), -1);
    watchdog_ = sd_watchdog_enabled(0, &watchdog_usec_) > 0 && watchdog_usec_ > 0;
  }

  // The manager (map reloaded), the back, the front. The next one starts
  // once the manager is up (the map loaded; at most 30 s, or until it died).
  // Not so for the back: it runs at idle priority and, on a busy machine, may
  // take minutes to come up; the front never waits for it (its windows wait
  // in the ring).
  bool StartChildren() {
    std::string why;
    for (int i : {manager_, back_, front_}) {
      if (!sup_.Start(i, &why)) {
        facts_.failure = sup_.info(i).name + ": " + why;
        return false;
      }
      if (i != manager_) continue;
      const auto t0 = Clock::now();
      while (!sup_.info(i).ready && sup_.Alive(i) && Since(t0) < 30 && !Stopped()) sup_.Poll(0.05);
    }
    last_watchdog_ = Clock::now() - std::chrono::hours(1);
    last_status_ = last_watchdog_;
    return true;
  }

  // One turn of the supervision loop; false when the session is over (or failed).
  bool Tick() {
    ReapExits();
    if (!CheckGivenUp()) return false;
    KillStalled();
    if (forward_hangup_ && forward_hangup_->exchange(false))
      for (int i = 0; i < static_cast<int>(sup_.size()); ++i) sup_.Signal(i, SIGHUP);
    if (!sup_.AnyRunning()) {
      bool backoff = false;
      for (int i = 0; i < static_cast<int>(sup_.size()); ++i) backoff |= sup_.info(i).state == ChildState::kBackoff;
      if (!backoff) return false;  // everyone finished: the session is complete
    }
    SayReadyOnce();
    if (source_ended_ && facts_.state == "running") facts_.state = "finishing";
    if (source_ended_) FinishSession();
    FeedWatchdog();
    if (Since(last_status_) >= d_.status_interval_s) {
      last_status_ = Clock::now();
      Publish();
    }
    return true;
  }

  void ReapExits() {
    for (const Supervisor::Exit& e : sup_.Poll(0.1)) {
      if (!e.crash && e.child == front_) {
        source_ended_ = true;
        spdlog::info("rumid: the source ended; the back finishes its windows, the manager saves, then rumid exits");
      } else if (!e.crash) {
        spdlog::info("rumid: {} finished", sup_.info(e.child).name);
      }
    }
  }

  // A child given up on (a crash loop, a config it refuses): the daemon fails.
  bool CheckGivenUp() {
    for (int i = 0; i < static_cast<int>(sup_.size()) && facts_.failure.empty(); ++i) {
      const ChildInfo& in = sup_.info(i);
      if (in.state != ChildState::kGaveUp) continue;
      facts_.failure = in.name + " " + DescribeWaitStatus(in.last_status) + " and was given up on";
      if (ExitedWith(in, kExitBadInput)) {
        facts_.failure += " (its config or input cannot load: rumid exits 2, which the unit does not restart)";
        failure_code_ = kExitBadInput;
      }
    }
    return facts_.failure.empty();
  }

  // A child alive but silent (SIGSTOP, a deadlock) does nothing and says
  // nothing: killed, it is restarted as after a crash (a manager stopped for
  // 90 s stayed "running" and only systemd's watchdog would act).
  void KillStalled() {
    for (const auto& [i, stall_s] : {std::pair<int, double>{front_, d_.front_stall_s}, {back_, d_.back_stall_s},
                                     {manager_, d_.manager_stall_s}}) {
      const ChildInfo& in = sup_.info(i);
      const double age = in.heartbeat_age_s();
      if (in.state != ChildState::kRunning || !in.ready || !std::isfinite(age) || age < stall_s) continue;
      if (stall_killed_[size_t(i)] == in.pid) continue;  // killed already, not reaped yet
      stall_killed_[size_t(i)] = in.pid;
      spdlog::error("rumid: {} (pid {}) sent no heartbeat for {:.0f} s (daemon.{}_stall_s {}): stalled; killing it "
                    "to restart it",
                    in.name, in.pid, age, i == front_ ? "front" : i == back_ ? "back" : "manager", stall_s);
      sup_.Signal(i, SIGKILL);
    }
  }

  void SayReadyOnce() {
    if (ready_sent_ || !(sup_.info(front_).ready && sup_.info(back_).ready && sup_.info(manager_).ready)) return;
    ready_sent_ = true;
    facts_.state = "running";
    Publish();  // status.json says so before systemd hears it
    last_status_ = Clock::now();
    systemd_.Ready();
    spdlog::info("rumid: ready (front, back and manager up, map loaded)");
  }

  // The source ended: the back finishes its windows, then the manager its
  // map (SIGUSR1 each, once per process, once it is up).
  void FinishSession() {
    const ChildInfo& b = sup_.info(back_);
    if (b.state == ChildState::kRunning && b.ready && b.pid != back_told_) {
      sup_.Signal(back_, SIGUSR1);
      back_told_ = b.pid;
    }
    const bool back_done = b.state == ChildState::kExited && ExitedWith(b, kExitDone);
    const ChildInfo& m = sup_.info(manager_);
    if (back_done && m.state == ChildState::kRunning && m.ready && m.pid != manager_told_) {
      sup_.Signal(manager_, SIGUSR1);
      manager_told_ = m.pid;
    }
  }

  // WATCHDOG=1 only while every child is alive and the manager's loop turns.
  void FeedWatchdog() {
    if (!watchdog_ || Since(last_watchdog_) * 2e6 < static_cast<double>(watchdog_usec_)) return;
    bool healthy = sup_.Alive(manager_) && sup_.info(manager_).state == ChildState::kRunning &&
                   sup_.info(manager_).heartbeat_age_s() < d_.manager_stall_s;
    for (int i : {front_, back_}) {
      const ChildState s = sup_.info(i).state;
      healthy &= s == ChildState::kRunning || (s == ChildState::kExited && ExitedWith(sup_.info(i), kExitDone));
    }
    if (healthy) {
      systemd_.Send("WATCHDOG=1");
      last_watchdog_ = Clock::now();
    }
  }

  // The state folder deleted under a running rumid: its lock guarded nothing
  // and status.json could not be written (a warning a second). Made again
  // and locked again, said in the log: the manager has the map in memory and
  // writes it there at its next save.
  void RelockIfLost() {
    if (lock_.StillHeld()) return;
    spdlog::warn("rumid: the state folder {} was deleted or replaced while rumid ran: making it again and "
                 "locking it again (the manager writes the map there at its next save)",
                 layout_.root);
    std::error_code mk;
    for (const std::string& d : {layout_.root, layout_.Front(), layout_.Back(), layout_.Logs()})
      fs::create_directories(d, mk);
    std::string err;
    if (!lock_.Acquire(layout_, &err) && facts_.failure.empty())
      facts_.failure = "the state folder was taken over: " + err;
  }

  void Publish() {
    RelockIfLost();
    const nlohmann::json st = DaemonStatusJson(facts_, sup_);
    std::string err;
    if (!WriteFileAtomically(layout_.Status(), st.dump(2) + "\n", &err)) spdlog::warn("rumid: {}", err);
    systemd_.Status(st["summary"].get<std::string>());
  }

  int Stop() {
    const bool by_signal = Stopped();
    // The view first, while the manager still answers its last DDS call:
    // its pages see the stream end, and nothing waits on a manager gone.
    view_.reset();
    facts_.state = facts_.failure.empty() ? "stopping" : "failed";
    systemd_.Stopping();
    if (!facts_.failure.empty())
      spdlog::error("rumid: {}; stopping", facts_.failure);
    else if (by_signal)
      spdlog::info("rumid: stop requested; stopping the front, the back, the manager (at most {} s)",
                   d_.stop_timeout_s);
    Publish();
    const auto t_stop = Clock::now();
    sup_.StopAll({front_, back_, manager_}, d_.stop_timeout_s);
    // The manager's last save is the session's map: when it failed (a full
    // disk), rumid fails too and says what is kept (it logged "stopped" and
    // exited 0).
    const ChildInfo& last = sup_.info(manager_);
    if (facts_.failure.empty() && last.exited_once && ExitedWith(last, kExitError)) {
      facts_.failure =
          "rumi-manager's last save failed (exit 1, its log says why): map.rumi is the last whole save, and "
          "the submaps received since are in map.rumi.received/ for the next start";
      spdlog::error("rumid: {}", facts_.failure);
      facts_.state = "failed";
    }
    // Drained segments go; one that still holds messages (a manager stopped
    // before it read them) stays for the next start, which reads it.
    for (const std::string& name : InstanceSegmentNames(o_.instance)) {
      RingStats rs;
      if (!ReadRingStats(name, &rs)) continue;
      if (rs.tail >= rs.head || NewestWinsSegment(o_.instance, name))
        RemoveSegment(name);
      else
        spdlog::warn("rumid: {} keeps {} unread message(s) for the next start", name, rs.head - rs.tail);
    }
    if (facts_.failure.empty()) facts_.state = "stopped";
    Publish();
    spdlog::info("rumid: {} in {:.1f} s", facts_.failure.empty() ? "stopped" : "failed", Since(t_stop));
    return facts_.failure.empty() ? kExitDone : failure_code_;
  }

  const DaemonRunOptions& o_;
  const RumiConfig& c_;
  const DaemonOptions& d_;
  const std::atomic<bool>* stop_;
  std::atomic<bool>* forward_hangup_;
  const StateDirLayout layout_;
  StateDirLock lock_, instance_lock_;
  Supervisor sup_;
  Notifier systemd_;  // rumid's own $NOTIFY_SOCKET (systemd's)
  uint64_t watchdog_usec_ = 0;
  bool watchdog_ = false;
  int front_ = -1, back_ = -1, manager_ = -1;
  DaemonStatusFacts facts_;  // state "starting" until all three are ready
  int failure_code_ = kExitError;  // kExitBadInput when a child refused its input: restarting cannot help
  std::vector<pid_t> stall_killed_;  // the pid killed as stalled, per child
  bool ready_sent_ = false, source_ended_ = false;
  pid_t back_told_ = -1, manager_told_ = -1;  // told the source ended (SIGUSR1)
  Clock::time_point last_watchdog_, last_status_;
  std::unique_ptr<ViewSession> view_;
};

}  // namespace

int RunDaemon(const DaemonRunOptions& o, const std::atomic<bool>* stop, std::atomic<bool>* forward_hangup) {
  return Daemon(o, stop, forward_hangup).Run();
}

}  // namespace rumi
