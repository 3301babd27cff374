#pragma once
// Runs one external command (a COLMAP step) as a child in its own process
// group, with its output in a log file, a wall-clock timeout that kills the
// whole group, and optional low priority. No shell is involved.
#include <atomic>
#include <string>
#include <vector>

namespace rumi {

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

RunResult RunProcess(const RunRequest& request);

// Puts the calling process (all its threads, and children forked later) at
// the lowest CPU priority: SCHED_IDLE, or nice 19 where SCHED_IDLE is refused.
// Returns a description of what was applied.
std::string LowerOwnPriority();

// Last max_bytes of a text file ("" when unreadable), for error messages.
std::string FileTail(const std::string& path, size_t max_bytes = 1500);

}  // namespace rumi
