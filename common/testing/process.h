#pragma once
// For tests only: run the executables of this build (or a shell command)
// as a user would, read what they wrote, wait for them or for a condition
// with a bound. The one copy of these for every test.
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace rumi::test {

// A rumi executable of this build ($RUMI_BIN_DIR, set by ctest).
std::string BinPath(const std::string& name);

// A text file's whole content ("" when unreadable).
std::string Slurp(const std::filesystem::path& p);
// Its last max_chars (a log's tail for a failure message).
std::string SlurpTail(const std::filesystem::path& p, size_t max_chars = 3000);

double SecondsSince(std::chrono::steady_clock::time_point t);

// Runs a shell command line with stdout and stderr into `log`: its exit
// code, -1 when it did not exit (killed by a signal).
int RunLogged(const std::string& command_line, const std::filesystem::path& log);

struct CommandResult {
  int code = -1;    // exit code, -1 when it did not exit
  std::string out;  // stdout and stderr
};
// Runs a shell command line to its end, its output captured.
CommandResult RunCommand(const std::string& command_line);

// Starts argv (SpawnChild: no shell, its own process group, killed with
// the test) with stdout and stderr into `log`, emptied first unless
// `append`; env "NAME=value" on top of ours. Its pid, or -1 (a test
// failure says why).
pid_t Start(const std::vector<std::string>& argv, const std::string& log, const std::vector<std::string>& env = {},
            bool append = false);

// Exit code of child pid, -2 when killed by a signal, -1 when it is still
// running after timeout_s (then SIGKILLed and reaped with kill_on_timeout).
int WaitExit(pid_t pid, double timeout_s, bool kill_on_timeout = false, std::chrono::milliseconds poll = std::chrono::milliseconds(20));

// SIGTERM, then SIGKILL when it still runs after grace_s; reaped. WaitExit's code.
int Stop(pid_t pid, double grace_s, std::chrono::milliseconds poll = std::chrono::milliseconds(20));

// Polls `done` every `poll` until it holds or timeout_s passed; its last value.
bool WaitFor(const std::function<bool()>& done, double timeout_s,
             std::chrono::milliseconds poll = std::chrono::milliseconds(20));

// Joins `worker`, a thread that returns once *stop is set or by itself; sets
// *stop when it is still running after timeout_s (a loop that never ends
// must not hang the test). True when it returned by itself.
bool JoinWithin(std::thread* worker, std::atomic<bool>* stop, double timeout_s);

}  // namespace rumi::test
