#include "common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

namespace rumi {
namespace {

std::string Errno(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

std::string DirName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

bool WriteAll(int fd, const uint8_t* p, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

}  // namespace

bool WriteFileAtomically(const std::string& path, const void* data, size_t size, std::string* why, unsigned mode) {
  // Unique per process and call: two threads may save different files of one folder.
  static std::atomic<uint64_t> counter{0};
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  // A stale temporary of a crashed writer (same pid) would keep its old mode
  // through O_TRUNC: remove it and create the file anew with this mode.
  ::unlink(tmp.c_str());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) {
    if (why) *why = Errno("cannot create", tmp);
    return false;
  }
  if (!WriteAll(fd, static_cast<const uint8_t*>(data), size) || ::fsync(fd) != 0) {
    if (why) *why = Errno("cannot write", tmp);
    ::close(fd);
    ::unlink(tmp.c_str());
    return false;
  }
  if (::close(fd) != 0) {
    if (why) *why = Errno("cannot write", tmp);
    ::unlink(tmp.c_str());
    return false;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    if (why) *why = Errno("cannot rename onto", path);
    ::unlink(tmp.c_str());
    return false;
  }
  // The rename itself must reach the disk.
  const int dfd = ::open(DirName(path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return true;
}

bool ReadFileBytes(const std::string& path, std::vector<uint8_t>* out, std::string* why) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (why) *why = Errno("cannot open", path);
    return false;
  }
  out->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) {
    if (why) *why = Errno("cannot read", path);
    return false;
  }
  return true;
}

bool CheckRegularFile(const std::string& path, uint64_t max_bytes, std::string* why) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (why) *why = Errno("cannot open", path);
    return false;
  }
  if (!S_ISREG(st.st_mode)) {
    if (why)
      *why = "'" + path + "' is not a regular file (" +
             (S_ISDIR(st.st_mode) ? "a folder" : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device"
                                               : S_ISFIFO(st.st_mode)                       ? "a pipe"
                                                                                            : "not a file") +
             ")";
    return false;
  }
  if (uint64_t(st.st_size) > max_bytes) {
    if (why)
      *why = "'" + path + "' holds " + std::to_string(uint64_t(st.st_size)) + " bytes, more than the " +
             std::to_string(max_bytes) + " it may";
    return false;
  }
  return true;
}

}  // namespace rumi
