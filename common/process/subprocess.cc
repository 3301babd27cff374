#include "common/process/subprocess.h"

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
#include <filesystem>
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

namespace {

// Set the I/O priority class of the calling process to idle (ioprio_set has
// no glibc wrapper).
void SetIdleIo() {
  constexpr int kIoprioWhoProcess = 1, kIoprioClassIdle = 3, kIoprioClassShift = 13;
  ::syscall(SYS_ioprio_set, kIoprioWhoProcess, 0, kIoprioClassIdle << kIoprioClassShift);
}

}  // namespace

pid_t SpawnChild(const SpawnOptions& o, std::string* why) {
  if (o.argv.empty()) {
    if (why) *why = "empty command";
    return -1;
  }
  std::vector<char*> argv;
  for (const std::string& a : o.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // The child's environment is prepared here: after fork only exec is safe.
  std::vector<std::string> env_strings;
  auto name_of = [](const std::string& e) { return e.substr(0, e.find('=')); };
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry(*e);
    bool overridden = false;
    for (const std::string& x : o.env) overridden |= name_of(x) == name_of(entry);
    if (!overridden) env_strings.push_back(entry);
  }
  for (const std::string& x : o.env)
    if (x.size() > name_of(x).size() + 1) env_strings.push_back(x);  // "NAME=" alone removes NAME
  std::vector<char*> envp;
  for (const std::string& e : env_strings) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);

  int log_fd = -1;
  if (!o.log_path.empty()) {
    log_fd = ::open(o.log_path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | (o.truncate_log ? O_TRUNC : O_APPEND), 0644);
    if (log_fd < 0) {
      if (why) *why = "cannot open log file " + o.log_path + ": " + std::strerror(errno);
      return -1;
    }
  }
  // A pipe closed on exec tells the parent whether exec itself failed.
  int err_pipe[2];
  if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
    if (log_fd >= 0) ::close(log_fd);
    if (why) *why = std::string("pipe: ") + std::strerror(errno);
    return -1;
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    if (log_fd >= 0) ::close(log_fd);
    ::close(err_pipe[0]);
    ::close(err_pipe[1]);
    if (why) *why = std::string("fork: ") + std::strerror(errno);
    return -1;
  }
  if (pid == 0) {  // child: only async-signal-safe calls until exec
    if (o.process_group >= 0) ::setpgid(0, o.process_group);
    if (o.death_signal > 0) {
      ::prctl(PR_SET_PDEATHSIG, o.death_signal);
      if (::getppid() != parent) ::_exit(127);  // the parent died before the prctl
    }
    // Handlers are reset by exec, ignored/blocked signals are not: start clean.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE, SIGCHLD}) ::signal(sig, SIG_DFL);
    if (o.low_priority) {
      SetIdleScheduling();
      SetIdleIo();
    }
    if (log_fd >= 0) {
      ::dup2(log_fd, STDOUT_FILENO);
      ::dup2(log_fd, STDERR_FILENO);
    }
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) {
      ::dup2(devnull, STDIN_FILENO);
      if (devnull != STDIN_FILENO) ::close(devnull);
    }
    ::execvpe(argv[0], argv.data(), envp.data());
    const int e = errno;
    ssize_t w = ::write(err_pipe[1], &e, sizeof(e));
    (void)w;
    ::_exit(127);
  }
  // Also from the parent: no race with an early kill of the group.
  if (o.process_group >= 0) ::setpgid(pid, o.process_group == 0 ? pid : o.process_group);
  if (log_fd >= 0) ::close(log_fd);
  ::close(err_pipe[1]);
  int exec_errno = 0;
  const ssize_t got = ::read(err_pipe[0], &exec_errno, sizeof(exec_errno));
  ::close(err_pipe[0]);
  if (got == static_cast<ssize_t>(sizeof(exec_errno))) {
    ::waitpid(pid, nullptr, 0);
    if (why) *why = "cannot execute '" + o.argv[0] + "': " + std::strerror(exec_errno);
    return -1;
  }
  return pid;
}

std::string DescribeWaitStatus(int status) {
  if (WIFEXITED(status)) return "exited with code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  }
  return "ended with status " + std::to_string(status);
}

std::string ExecutableDir() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return ".";
  return self.parent_path().string();
}

RunResult RunProcess(const RunRequest& req) {
  RunResult res;
  SpawnOptions so;
  so.argv = req.argv;
  so.log_path = req.log_path.empty() ? "/dev/null" : req.log_path;
  so.env = req.env;
  so.process_group = 0;  // its own: COLMAP and anything it starts go together
  so.death_signal = SIGKILL;
  so.low_priority = req.low_priority;
  const auto t0 = std::chrono::steady_clock::now();
  std::string why;
  const pid_t pid = SpawnChild(so, &why);
  if (pid < 0) {
    res.status = RunStatus::kLaunchFailed;
    res.message = why;
    return res;
  }

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
