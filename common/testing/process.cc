#include "common/testing/process.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "common/atomic_file.h"
#include "common/process/subprocess.h"

namespace rumi::test {

std::string BinPath(const std::string& name) {
  const char* dir = std::getenv("RUMI_BIN_DIR");
  return (std::filesystem::path(dir ? dir : RUMI_BINARY_DIR "/bin") / name).string();
}

std::string Slurp(const std::filesystem::path& p) {
  std::string text;
  ReadFileText(p.string(), &text, nullptr);  // a file not there: empty
  return text;
}

std::string SlurpTail(const std::filesystem::path& p, size_t max_chars) {
  const std::string text = Slurp(p);
  return text.size() > max_chars ? text.substr(text.size() - max_chars) : text;
}

double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

int RunLogged(const std::string& command_line, const std::filesystem::path& log) {
  const int status = std::system((command_line + " > " + log.string() + " 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

CommandResult RunCommand(const std::string& command_line) {
  CommandResult r;
  FILE* p = ::popen((command_line + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

pid_t Start(const std::vector<std::string>& argv, const std::string& log, const std::vector<std::string>& env,
            bool append) {
  SpawnOptions so;
  so.argv = argv;
  so.env = env;
  so.log_path = log;
  so.truncate_log = !append;
  std::string why;
  const pid_t pid = SpawnChild(so, &why);
  EXPECT_GT(pid, 0) << why;
  return pid;
}

int WaitExit(pid_t pid, double timeout_s, bool kill_on_timeout, std::chrono::milliseconds poll) {
  const auto t0 = std::chrono::steady_clock::now();
  int st = 0;
  while (SecondsSince(t0) < timeout_s) {
    if (::waitpid(pid, &st, WNOHANG) == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : -2;
    std::this_thread::sleep_for(poll);
  }
  if (kill_on_timeout) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &st, 0);
  }
  return -1;
}

int Stop(pid_t pid, double grace_s, std::chrono::milliseconds poll) {
  ::kill(pid, SIGTERM);
  return WaitExit(pid, grace_s, /*kill_on_timeout=*/true, poll);
}

bool WaitFor(const std::function<bool()>& done, double timeout_s, std::chrono::milliseconds poll) {
  const auto t0 = std::chrono::steady_clock::now();
  while (!done() && SecondsSince(t0) < timeout_s) std::this_thread::sleep_for(poll);
  return done();
}

bool JoinWithin(std::thread* worker, std::atomic<bool>* stop, double timeout_s) {
  const auto t0 = std::chrono::steady_clock::now();
  std::thread guard([&] {
    while (!*stop && SecondsSince(t0) < timeout_s) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    *stop = true;
  });
  worker->join();
  const bool ended_by_itself = !*stop;
  *stop = true;
  guard.join();
  return ended_by_itself;
}

}  // namespace rumi::test
