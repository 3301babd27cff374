#include "common/process/supervisor.h"

#include <signal.h>
#include <sys/wait.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "common/process/exit_codes.h"
#include "common/process/subprocess.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Restarting cannot help a child that rejected its config or command line.
bool BadInput(int status) {
  if (!WIFEXITED(status)) return false;
  const int code = WEXITSTATUS(status);
  return code == kExitBadInput || (code >= 100 && code <= 114);
}

}  // namespace

const char* ToString(ChildState s) {
  switch (s) {
    case ChildState::kNotStarted: return "not_started";
    case ChildState::kRunning: return "running";
    case ChildState::kBackoff: return "restarting";
    case ChildState::kExited: return "exited";
    case ChildState::kGaveUp: return "gave_up";
  }
  return "?";
}

double ChildInfo::uptime_s() const {
  return state == ChildState::kRunning ? Seconds(Clock::now() - started) : 0.0;
}

double ChildInfo::heartbeat_age_s() const {
  if (last_heartbeat == Clock::time_point{}) return std::numeric_limits<double>::infinity();
  return Seconds(Clock::now() - last_heartbeat);
}

Supervisor::Supervisor(SupervisorOptions options) : o_(std::move(options)) {
  if (!o_.notify_name.empty()) notify_ = std::make_unique<NotifyServer>(o_.notify_name);
}

Supervisor::~Supervisor() { KillAll(); }

int Supervisor::Add(ChildSpec spec) {
  Child c;
  c.info.name = spec.name;
  c.spec = std::move(spec);
  children_.push_back(std::move(c));
  return static_cast<int>(children_.size()) - 1;
}

bool Supervisor::Start(int i, std::string* why) {
  Child& c = children_[i];
  SpawnOptions so;
  so.argv = c.spec.argv;
  if (c.spec.prepare) c.spec.prepare(c.info.starts, &so.argv);
  so.log_path = c.spec.log_path;
  so.truncate_log = c.spec.truncate_log && c.info.starts == 0;
  so.env = c.spec.env;
  // The child reports to us, not to whoever supervises us (systemd).
  so.env.push_back("NOTIFY_SOCKET=" + notify_address());
  so.env.push_back("WATCHDOG_USEC=");
  so.env.push_back("WATCHDOG_PID=");
  so.process_group = 0;
  so.death_signal = SIGKILL;
  so.low_priority = c.spec.low_priority;
  const pid_t pid = SpawnChild(so, why);
  if (pid < 0) return false;
  ChildInfo& in = c.info;
  in.pid = pid;
  in.state = ChildState::kRunning;
  in.started = Clock::now();
  ++in.starts;
  in.ready = false;
  in.last_heartbeat = {};
  in.status_line.clear();
  in.status = nlohmann::json();
  spdlog::info("supervisor: started {} (pid {}{})", in.name, pid,
               in.starts > 1 ? ", restart " + std::to_string(in.starts - 1) : std::string());
  return true;
}

void Supervisor::ReadNotify(double timeout_s) {
  if (!notify_) {
    if (timeout_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(timeout_s));
    return;
  }
  for (NotifyServer::Message& m : notify_->Receive(timeout_s)) {
    for (Child& c : children_) {
      if (c.info.pid != m.pid || c.info.state != ChildState::kRunning) continue;
      ChildInfo& in = c.info;
      auto f = m.fields.find("READY");
      if (f != m.fields.end() && f->second == "1") in.ready = true;
      f = m.fields.find("WATCHDOG");
      if (f != m.fields.end() && f->second == "1") in.last_heartbeat = Clock::now();
      f = m.fields.find("STATUS");
      if (f != m.fields.end()) in.status_line = f->second;
      f = m.fields.find("RUMI_STATUS");
      if (f != m.fields.end()) {
        try {
          in.status = nlohmann::json::parse(f->second);
        } catch (const std::exception&) {
          spdlog::warn("supervisor: {} sent a malformed RUMI_STATUS; ignored", in.name);
        }
      }
    }
  }
}

void Supervisor::OnExit(int i, int status, std::vector<Exit>* exits) {
  Child& c = children_[i];
  ChildInfo& in = c.info;
  in.last_status = status;
  in.exited_once = true;
  in.pid = -1;
  Exit e;
  e.child = i;
  e.status = status;
  const bool done = WIFEXITED(status) && WEXITSTATUS(status) == kExitDone;
  e.crash = !done && !stopping_;
  const double ran_s = Seconds(Clock::now() - in.started);
  if (done || stopping_) {
    in.state = ChildState::kExited;
  } else if (BadInput(status)) {
    in.state = ChildState::kGaveUp;
    e.gave_up = true;
    spdlog::error("supervisor: {} {} ({}): not restarting it, fix the config or command line", in.name,
                  DescribeWaitStatus(status), WIFEXITED(status) ? DescribeExitCode(WEXITSTATUS(status)) : "");
  } else {
    ++in.crashes;
    const auto now = Clock::now();
    in.crash_times.push_back(now);
    in.crash_times.erase(std::remove_if(in.crash_times.begin(), in.crash_times.end(),
                                        [&](Clock::time_point t) { return Seconds(now - t) > o_.crash_loop_window_s; }),
                         in.crash_times.end());
    if (!o_.restart) {
      in.state = ChildState::kExited;
    } else if (static_cast<int>(in.crash_times.size()) > o_.crash_loop_starts) {
      in.state = ChildState::kGaveUp;
      e.gave_up = true;
      spdlog::error("supervisor: {} crashed {} times within {:.0f} s (last: {}); giving up on it", in.name,
                    in.crash_times.size(), o_.crash_loop_window_s, DescribeWaitStatus(status));
    } else {
      in.backoff_s = ran_s >= o_.stable_after_s || in.backoff_s <= 0
                         ? o_.backoff_initial_s
                         : std::min(o_.backoff_max_s, 2 * in.backoff_s);
      in.state = ChildState::kBackoff;
      in.restart_at = now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(in.backoff_s));
      e.will_restart = true;
      spdlog::warn("supervisor: {} {} after {:.1f} s; restarting it in {:.1f} s", in.name,
                   DescribeWaitStatus(status), ran_s, in.backoff_s);
    }
  }
  exits->push_back(e);
}

bool Supervisor::WaitOne(Child* c, int options, std::vector<Exit>* exits) {
  if (c->info.state != ChildState::kRunning) return false;
  int status = 0;
  const pid_t r = ::waitpid(c->info.pid, &status, options);
  if (r != c->info.pid) return false;
  // The child is gone; make sure nothing of its group stays (a COLMAP of a
  // killed rumi-back also dies by PDEATHSIG; this covers the rest).
  ::kill(-r, SIGKILL);
  OnExit(static_cast<int>(c - children_.data()), status, exits);
  return true;
}

std::vector<Supervisor::Exit> Supervisor::Poll(double timeout_s) {
  ReadNotify(timeout_s);
  std::vector<Exit> exits;
  for (Child& c : children_) WaitOne(&c, WNOHANG, &exits);
  const auto now = Clock::now();
  for (size_t i = 0; i < children_.size(); ++i) {
    ChildInfo& in = children_[i].info;
    if (in.state != ChildState::kBackoff || stopping_ || now < in.restart_at) continue;
    std::string why;
    if (!Start(static_cast<int>(i), &why)) {
      spdlog::error("supervisor: cannot restart {}: {}", in.name, why);
      in.state = ChildState::kGaveUp;
      Exit e;
      e.child = static_cast<int>(i);
      e.gave_up = true;
      exits.push_back(e);
    }
  }
  return exits;
}

void Supervisor::Signal(int i, int sig) {
  const ChildInfo& in = children_[i].info;
  if (in.state == ChildState::kRunning && in.pid > 0) ::kill(-in.pid, sig);
}

void Supervisor::StopAll(const std::vector<int>& order, double timeout_s) {
  stopping_ = true;
  for (Child& c : children_)
    if (c.info.state == ChildState::kBackoff) c.info.state = ChildState::kExited;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  std::vector<Exit> ignored;
  for (size_t k = 0; k < order.size(); ++k) {
    if (order[k] < 0 || order[k] >= static_cast<int>(children_.size())) continue;  // not started (front only)
    Child& c = children_[order[k]];
    if (c.info.state != ChildState::kRunning) continue;
    ::kill(-c.info.pid, SIGTERM);
    // Its share of what is left; the last one gets all of it.
    const double left = Seconds(deadline - Clock::now());
    const double share = k + 1 == order.size() ? left : left / static_cast<double>(order.size() - k);
    const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(share));
    while (Clock::now() < until && !WaitOne(&c, WNOHANG, &ignored)) {
      ReadNotify(0.02);
    }
  }
  for (Child& c : children_) {
    if (c.info.state != ChildState::kRunning) continue;
    spdlog::warn("supervisor: {} (pid {}) did not stop within {:.0f} s; killing it", c.info.name, c.info.pid,
                 timeout_s);
    ::kill(-c.info.pid, SIGKILL);
    WaitOne(&c, 0, &ignored);
  }
}

void Supervisor::KillAll() {
  stopping_ = true;
  std::vector<Exit> ignored;
  for (Child& c : children_) {
    if (c.info.state == ChildState::kBackoff) c.info.state = ChildState::kExited;
    if (c.info.state != ChildState::kRunning) continue;
    ::kill(-c.info.pid, SIGKILL);
    WaitOne(&c, 0, &ignored);
  }
}

bool Supervisor::AnyRunning() const {
  for (const Child& c : children_)
    if (c.info.state == ChildState::kRunning) return true;
  return false;
}

bool Supervisor::Alive(int i) const {
  const ChildState s = children_[i].info.state;
  return s == ChildState::kRunning || s == ChildState::kBackoff;
}

}  // namespace rumi
