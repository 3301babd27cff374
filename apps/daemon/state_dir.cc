#include "apps/daemon/state_dir.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "common/atomic_file.h"

namespace rumi {

std::string ResolveStateDir(const std::string& cli, const std::string& config, const std::string& instance) {
  if (!cli.empty()) return cli;
  if (!config.empty()) return config;
  // systemd's StateDirectory=rumi/%i sets $STATE_DIRECTORY (several: ':').
  if (const char* s = std::getenv("STATE_DIRECTORY"); s && *s) {
    const std::string v = s;
    return v.substr(0, v.find(':'));
  }
  return "/var/lib/rumi/" + instance;
}

std::string InstanceLockPath(const std::string& instance) { return "/dev/shm/.rumid_" + instance + ".lock"; }

bool StateDirLock::Acquire(const StateDirLayout& layout, std::string* why) {
  return Acquire(layout.Lock(), "on " + layout.root, why);
}

bool StateDirLock::Acquire(const std::string& path, const std::string& what, std::string* why) {
  if (fd_ >= 0) ::close(fd_);
  path_ = path;
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd_ < 0) {
    if (why) *why = "cannot open " + path + ": " + std::strerror(errno);
    return false;
  }
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    std::ifstream in(path);
    std::string holder;
    std::getline(in, holder);
    if (why) *why = "another rumid (pid " + (holder.empty() ? std::string("?") : holder) + ") runs " + what;
    ::close(fd_);
    fd_ = -1;
    return false;
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) < 0) {
    // The lock holds; the pid is only for the message of a second rumid.
  }
  return true;
}

bool StateDirLock::StillHeld() const {
  struct stat held {}, now {};
  if (fd_ < 0 || ::fstat(fd_, &held) != 0 || ::stat(path_.c_str(), &now) != 0) return false;
  return held.st_dev == now.st_dev && held.st_ino == now.st_ino;
}

StateDirLock::~StateDirLock() {
  if (fd_ >= 0) ::close(fd_);
}

long NextGeneration(const StateDirLayout& layout, std::string* why) {
  long g = 0;
  std::ifstream in(layout.Generation());
  if (in >> g) ++g;
  else g = 0;
  if (!WriteFileAtomically(layout.Generation(), std::to_string(g) + "\n", why)) return -1;
  return g;
}

}  // namespace rumi
