#include "back/process_runner.h"

#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

namespace rumi {

const char* ToString(RunStatus s) {
  switch (s) {
    case RunStatus::kOk: return "ok";
    case RunStatus::kFailed: return "failed";
    case RunStatus::kTimeout: return "timeout";
    case RunStatus::kCancelled: return "cancelled";
    case RunStatus::kLaunchFailed: return "launch_failed";
  }
  return "unknown";
}

namespace {

// Applies SCHED_IDLE to the calling thread/process; nice 19 when refused.
// Async-signal-safe enough to call between fork and exec (only syscalls).
bool SetIdleScheduling() {
  sched_param p{};
  p.sched_priority = 0;
  if (sched_setscheduler(0, SCHED_IDLE, &p) == 0) return true;
  setpriority(PRIO_PROCESS, 0, 19);
  return false;
}

void KillGroup(pid_t pgid, int sig) { ::kill(-pgid, sig); }

}  // namespace

std::string LowerOwnPriority() {
  // sched_setscheduler(0) changes the calling thread only; apply it to every
  // existing thread of the process so spdlog/other threads follow too.
  bool idle_all = true;
  const pid_t pid = getpid();
  std::error_code ec;
  const std::string task_dir = "/proc/" + std::to_string(pid) + "/task";
  DIR* d = opendir(task_dir.c_str());
  if (d) {
    while (dirent* e = readdir(d)) {
      if (e->d_name[0] == '.') continue;
      const pid_t tid = static_cast<pid_t>(std::atoi(e->d_name));
      sched_param p{};
      if (sched_setscheduler(tid, SCHED_IDLE, &p) != 0) {
        idle_all = false;
        setpriority(PRIO_PROCESS, static_cast<id_t>(tid), 19);
      }
    }
    closedir(d);
  } else {
    idle_all = SetIdleScheduling();
  }
  // Nice also matters to tools that look only at it (top, ps) and to children
  // if a later policy change resets SCHED_IDLE.
  setpriority(PRIO_PROCESS, 0, 19);
  return idle_all ? "SCHED_IDLE + nice 19" : "nice 19 (SCHED_IDLE refused)";
}

std::string FileTail(const std::string& path, size_t max_bytes) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return "";
  const std::streamoff size = in.tellg();
  const std::streamoff start = size > static_cast<std::streamoff>(max_bytes) ? size - static_cast<std::streamoff>(max_bytes) : 0;
  in.seekg(start);
  std::string s(static_cast<size_t>(size - start), '\0');
  in.read(&s[0], static_cast<std::streamsize>(s.size()));
  return s;
}

RunResult RunProcess(const RunRequest& req) {
  RunResult res;
  if (req.argv.empty()) {
    res.message = "empty command";
    return res;
  }
  std::vector<char*> argv;
  for (const std::string& a : req.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // The child's environment is prepared here: after fork only exec is safe.
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry(*e);
    const std::string name = entry.substr(0, entry.find('='));
    bool overridden = false;
    for (const std::string& x : req.env) overridden |= x.compare(0, name.size() + 1, name + "=") == 0;
    if (!overridden) env_strings.push_back(entry);
  }
  env_strings.insert(env_strings.end(), req.env.begin(), req.env.end());
  std::vector<char*> envp;
  for (const std::string& e : env_strings) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);

  const std::string log = req.log_path.empty() ? "/dev/null" : req.log_path;
  const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) {
    res.message = "cannot open log file " + log + ": " + std::strerror(errno);
    return res;
  }
  // A pipe closed on exec tells the parent whether exec itself failed.
  int err_pipe[2];
  if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
    ::close(log_fd);
    res.message = std::string("pipe: ") + std::strerror(errno);
    return res;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log_fd);
    ::close(err_pipe[0]);
    ::close(err_pipe[1]);
    res.message = std::string("fork: ") + std::strerror(errno);
    return res;
  }
  if (pid == 0) {  // child: only async-signal-safe calls until exec
    ::setpgid(0, 0);
    // Its own group shields COLMAP from the caller's group signals, so make
    // sure it dies with rumi-back even when rumi-back is SIGKILLed.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    if (req.low_priority) SetIdleScheduling();
    ::dup2(log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, STDIN_FILENO);
    ::execvpe(argv[0], argv.data(), envp.data());
    const int e = errno;
    ssize_t w = ::write(err_pipe[1], &e, sizeof(e));
    (void)w;
    ::_exit(127);
  }
  ::setpgid(pid, pid);  // also from the parent: no race with an early kill
  ::close(log_fd);
  ::close(err_pipe[1]);
  int exec_errno = 0;
  const ssize_t got = ::read(err_pipe[0], &exec_errno, sizeof(exec_errno));
  ::close(err_pipe[0]);

  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  int wstatus = 0;
  rusage usage{};
  bool done = false;
  RunStatus stop_reason = RunStatus::kOk;
  while (!done) {
    const pid_t r = ::wait4(pid, &wstatus, WNOHANG, &usage);
    if (r == pid) {
      done = true;
      break;
    }
    if (r < 0 && errno != EINTR) {
      res.message = std::string("waitpid: ") + std::strerror(errno);
      break;
    }
    const bool cancelled = req.cancel && req.cancel->load();
    if (cancelled || elapsed() > req.timeout_s) {
      stop_reason = cancelled ? RunStatus::kCancelled : RunStatus::kTimeout;
      KillGroup(pid, SIGTERM);
      // Grace period, then SIGKILL for the whole group.
      const auto t_kill = std::chrono::steady_clock::now();
      while (::wait4(pid, &wstatus, WNOHANG, &usage) == 0 &&
             std::chrono::steady_clock::now() - t_kill < std::chrono::seconds(2)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      KillGroup(pid, SIGKILL);  // grandchildren too, even when the leader left
      ::wait4(pid, &wstatus, 0, &usage);
      done = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  res.seconds = elapsed();
  // CPU of the child and its waited-for descendants: independent of how
  // loaded the machine is, unlike the wall clock.
  res.cpu_seconds = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                    1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  if (got == static_cast<ssize_t>(sizeof(exec_errno))) {
    res.status = RunStatus::kLaunchFailed;
    res.message = "cannot execute '" + req.argv[0] + "': " + std::strerror(exec_errno);
    return res;
  }
  if (stop_reason != RunStatus::kOk) {
    res.status = stop_reason;
    res.message = req.argv[0] + " " + (req.argv.size() > 1 ? req.argv[1] + " " : "") +
                  (stop_reason == RunStatus::kTimeout
                       ? "timed out after " + std::to_string(req.timeout_s) + " s; process group killed"
                       : std::string("cancelled; process group killed"));
    return res;
  }
  if (!done) {
    res.status = RunStatus::kFailed;
    return res;
  }
  if (WIFEXITED(wstatus)) {
    res.exit_code = WEXITSTATUS(wstatus);
    res.status = res.exit_code == 0 ? RunStatus::kOk : RunStatus::kFailed;
  } else if (WIFSIGNALED(wstatus)) {
    res.term_signal = WTERMSIG(wstatus);
    res.status = RunStatus::kFailed;
  }
  if (res.status != RunStatus::kOk) {
    const std::string what = req.argv[0] + " " + (req.argv.size() > 1 ? req.argv[1] : "");
    res.message = what + (res.term_signal ? " killed by signal " + std::to_string(res.term_signal)
                                          : " exited with code " + std::to_string(res.exit_code));
    if (!req.log_path.empty()) {
      const std::string tail = FileTail(req.log_path, 600);
      if (!tail.empty()) res.message += "; log tail: " + tail;
    }
  }
  return res;
}

}  // namespace rumi
