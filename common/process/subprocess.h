#pragma once
// The one process spawner of rumi: every child (COLMAP steps in the back,
// rumi-front/back/manager under `rumi eval run` and `rumid`) is started by
// SpawnChild. No shell is involved; the child dies with its parent
// (PR_SET_PDEATHSIG), may get its own process group (so that its own
// children can be killed with it), low CPU priority, and a log file.
// RunProcess runs one command to its end with a timeout (the back's COLMAP
// steps).
#include <sys/types.h>

#include <atomic>
#include <string>
#include <vector>

namespace rumi {

struct SpawnOptions {
  std::vector<std::string> argv;  // argv[0] is looked up in PATH when it has no '/'
  // stdout + stderr: appended to this file; "" keeps the parent's.
  std::string log_path;
  bool truncate_log = false;      // start the log file empty
  std::vector<std::string> env;   // "NAME=value" set on top of ours; "NAME=" alone removes NAME
  // Process group: -1 keeps the parent's, 0 founds a new one (pgid = pid),
  // > 0 joins that group.
  pid_t process_group = 0;
  int death_signal = 9;           // sent when the parent dies (SIGKILL); 0: none
  bool low_priority = false;      // SCHED_IDLE (fallback nice 19) and idle I/O class
};

// Starts the child. Returns its pid, or -1 with *why (the command cannot be
// executed: no such file, not executable, log not writable).
pid_t SpawnChild(const SpawnOptions& options, std::string* why);

// "exited with code 3", "was killed by signal 9 (Killed)".
std::string DescribeWaitStatus(int status);

enum class RunStatus { kOk, kFailed, kTimeout, kCancelled, kLaunchFailed };
const char* ToString(RunStatus s);

struct RunResult {
  RunStatus status = RunStatus::kLaunchFailed;
  int exit_code = -1;    // when exited
  int term_signal = 0;   // when killed by a signal (not by us)
  double seconds = 0.0;      // wall clock
  double cpu_seconds = 0.0;  // user + system CPU of the child (and its reaped children)
  std::string message;   // human-readable summary incl. the log's tail on failure
};

struct RunRequest {
  std::vector<std::string> argv;  // argv[0] is looked up in PATH when it has no '/'
  std::string log_path;           // stdout+stderr appended here ("" = /dev/null)
  std::vector<std::string> env;   // "NAME=value" set in the child on top of ours
  double timeout_s = 600.0;
  bool low_priority = true;       // SCHED_IDLE (fallback nice 19) in the child
  const std::atomic<bool>* cancel = nullptr;  // polled; set -> group killed, kCancelled
};

// Runs the command in its own process group to its end; a timeout or a
// cancel kills the whole group (SIGTERM, 2 s, SIGKILL).
RunResult RunProcess(const RunRequest& request);

// Puts the calling process (all its threads, and children forked later) at
// the lowest CPU priority: SCHED_IDLE, or nice 19 where SCHED_IDLE is refused.
// Returns a description of what was applied.
std::string LowerOwnPriority();

// Last max_bytes of a text file ("" when unreadable), for error messages.
std::string FileTail(const std::string& path, size_t max_bytes = 1500);

// Folder of the running executable (/proc/self/exe).
std::string ExecutableDir();

}  // namespace rumi
