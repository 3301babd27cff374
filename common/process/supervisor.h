#pragma once
// Starts and watches a set of child processes: the one supervisor of
// `rumi eval run` (no restarts: the first failure ends the run) and of
// rumid (crashed children are restarted with backoff).
//
// Each child gets its own process group (its descendants go with it), dies
// with the supervisor (PR_SET_PDEATHSIG), and talks to it through the notify
// protocol (common/process/notify.h): $NOTIFY_SOCKET points at the
// supervisor's socket, and READY / WATCHDOG / STATUS / RUMI_STATUS from the
// child's pid land in its ChildInfo.
//
// Restart policy: a child that exits with kExitDone is finished and stays
// down. kExitBadInput (and CLI11's 100..114) means restarting cannot help: it
// stays down, `gave_up`. Any other exit or a death by signal is a crash: with
// `restart`, the child starts again after a backoff that doubles from
// backoff_initial_s up to backoff_max_s (reset once it ran stable_after_s);
// more than crash_loop_starts crashes within crash_loop_window_s give up
// with one log line instead of a busy loop.
#include <sys/types.h>

#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/process/notify.h"

namespace rumi {

struct SupervisorOptions {
  bool restart = false;
  double backoff_initial_s = 0.5;
  double backoff_max_s = 30.0;
  int crash_loop_starts = 5;
  double crash_loop_window_s = 120.0;
  double stable_after_s = 60.0;
  // Abstract socket name for the notify server; "" = no notify socket.
  std::string notify_name;
};

struct ChildSpec {
  std::string name;               // "rumi-front"
  std::vector<std::string> argv;
  std::string log_path;           // stdout + stderr appended here; "" = the supervisor's
  bool truncate_log = false;
  bool low_priority = false;      // SCHED_IDLE + idle I/O from the start
  std::vector<std::string> env;   // on top of the supervisor's
  // Called before each start with the start count (0 first): may rewrite the
  // command line (rumid: a fresh submap id base after a restart).
  std::function<void(int start, std::vector<std::string>* argv)> prepare;
};

enum class ChildState { kNotStarted, kRunning, kBackoff, kExited, kGaveUp };
const char* ToString(ChildState s);

struct ChildInfo {
  std::string name;
  pid_t pid = -1;
  ChildState state = ChildState::kNotStarted;
  int starts = 0;          // times started
  int crashes = 0;         // exits that counted as crashes
  int last_status = 0;     // waitpid status of the last exit
  bool exited_once = false;
  std::chrono::steady_clock::time_point started{};
  std::chrono::steady_clock::time_point restart_at{};
  // From the child's notify messages (reset at each start).
  bool ready = false;
  std::chrono::steady_clock::time_point last_heartbeat{};
  std::string status_line;     // STATUS=
  nlohmann::json status;       // RUMI_STATUS=
  std::vector<std::chrono::steady_clock::time_point> crash_times;
  double backoff_s = 0;
  int restarts() const { return starts > 0 ? starts - 1 : 0; }
  double uptime_s() const;
  double heartbeat_age_s() const;  // since the last WATCHDOG=1 (inf if none)
};

class Supervisor {
 public:
  explicit Supervisor(SupervisorOptions options);
  ~Supervisor();  // SIGKILLs what still runs
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  int Add(ChildSpec spec);
  // Starts child i now. False with *why when it cannot be executed.
  bool Start(int i, std::string* why);

  struct Exit {
    int child = -1;
    int status = 0;            // waitpid status
    bool crash = false;        // counted as a crash
    bool will_restart = false;
    bool gave_up = false;      // crash loop, or bad input
  };
  // Reads notify messages (waiting up to timeout_s for one), reaps exited
  // children and restarts those whose backoff has passed. Returns the exits
  // seen in this call.
  std::vector<Exit> Poll(double timeout_s = 0.0);

  // Sends sig to child i's process group (no-op when it is not running).
  void Signal(int i, int sig);
  // SIGTERM the children in `order` one after the other (indices out of
  // range are skipped), each given its share of timeout_s to exit (the last
  // one whatever is left), then SIGKILL what still runs. No restarts happen
  // from here on.
  void StopAll(const std::vector<int>& order, double timeout_s);
  // SIGKILL every running child (and its group) and reap it.
  void KillAll();

  bool AnyRunning() const;
  // Running, or waiting to be restarted.
  bool Alive(int i) const;
  size_t size() const { return children_.size(); }
  const ChildInfo& info(int i) const { return children_[i].info; }
  const ChildSpec& spec(int i) const { return children_[i].spec; }
  std::string notify_address() const { return notify_ ? notify_->address() : ""; }

 private:
  struct Child {
    ChildSpec spec;
    ChildInfo info;
  };
  void ReadNotify(double timeout_s);
  bool WaitOne(Child* c, int options, std::vector<Exit>* exits);
  void OnExit(int i, int status, std::vector<Exit>* exits);

  SupervisorOptions o_;
  std::vector<Child> children_;
  std::unique_ptr<NotifyServer> notify_;
  bool stopping_ = false;
};

}  // namespace rumi
