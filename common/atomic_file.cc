#include "common/atomic_file.h"

#include <fcntl.h>
#include <sys/mman.h>
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

AtomicFileWriter::AtomicFileWriter(const std::string& path, unsigned mode) : path_(path) {
  // Unique per process and call: two threads may save different files of one folder.
  static std::atomic<uint64_t> counter{0};
  tmp_ = path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  // A stale temporary of a crashed writer (same pid) would keep its old mode
  // through O_TRUNC: remove it and create the file anew with this mode.
  ::unlink(tmp_.c_str());
  fd_ = ::open(tmp_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd_ < 0) error_ = Errno("cannot create", tmp_);
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(tmp_.c_str());
  }
}

bool AtomicFileWriter::Fail(const std::string& what) {
  if (error_.empty()) error_ = Errno(what, tmp_);
  return false;
}

bool AtomicFileWriter::Append(const void* data, size_t size) {
  if (!error_.empty()) return false;
  if (!WriteAll(fd_, static_cast<const uint8_t*>(data), size)) return Fail("cannot write");
  size_ += size;
  return true;
}

bool AtomicFileWriter::Patch(uint64_t offset, const void* data, size_t size) {
  if (!error_.empty()) return false;
  if (offset > size_ || size > size_ - offset) {
    error_ = "cannot patch " + tmp_ + ": beyond what was written";
    return false;
  }
  const auto* p = static_cast<const uint8_t*>(data);
  while (size > 0) {
    const ssize_t w = ::pwrite(fd_, p, size, off_t(offset));
    if (w < 0) {
      if (errno == EINTR) continue;
      return Fail("cannot write");
    }
    p += w;
    offset += uint64_t(w);
    size -= size_t(w);
  }
  return true;
}

std::unique_ptr<AtomicFileWriter::View> AtomicFileWriter::Read(uint64_t offset, uint64_t size) {
  if (!error_.empty() || offset > size_ || size > size_ - offset) return nullptr;  // a question: not sticky
  const size_t mapped = size_t(offset + size);
  if (mapped == 0) return std::make_unique<View>(nullptr, 0, nullptr);
  void* base = ::mmap(nullptr, mapped, PROT_READ, MAP_SHARED, fd_, 0);
  if (base == MAP_FAILED) {
    Fail("cannot read back");
    return nullptr;
  }
  return std::make_unique<View>(base, mapped, static_cast<const uint8_t*>(base) + offset);
}

AtomicFileWriter::View::~View() {
  if (base_) ::munmap(base_, mapped_);
}

bool AtomicFileWriter::Commit(std::string* why) {
  if (error_.empty() && ::fsync(fd_) != 0) Fail("cannot write");
  if (fd_ >= 0 && ::close(fd_) != 0) Fail("cannot write");
  fd_ = -1;
  if (error_.empty() && ::rename(tmp_.c_str(), path_.c_str()) != 0) error_ = Errno("cannot rename onto", path_);
  if (!error_.empty()) {
    ::unlink(tmp_.c_str());
    if (why) *why = error_;
    return false;
  }
  // The rename itself must reach the disk.
  const int dfd = ::open(DirName(path_).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return true;
}

bool WriteFileAtomically(const std::string& path, const void* data, size_t size, std::string* why, unsigned mode) {
  AtomicFileWriter w(path, mode);
  w.Append(data, size);
  return w.Commit(why);
}

namespace {
template <typename Buffer>
bool ReadWhole(const std::string& path, Buffer* out, std::string* why) {
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
}  // namespace

bool ReadFileBytes(const std::string& path, std::vector<uint8_t>* out, std::string* why) {
  return ReadWhole(path, out, why);
}

bool ReadFileText(const std::string& path, std::string* out, std::string* why) {
  return ReadWhole(path, out, why);
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
