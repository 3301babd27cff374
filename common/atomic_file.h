#pragma once
// The one way rumi writes a file that a reader (another process, a later
// start) may open at any time: a temporary file beside the target, written
// and fsynced, renamed over the target, then the folder fsynced. A reader sees
// the old file or the new one, never half of one; a full disk or a killed
// writer leaves the old file as it was (and no temporary behind on errors).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace rumi {

// False with *why naming the file and the system's reason (e.g. "No space
// left on device"). mode: the new file's permissions (less the umask); a
// secret is written 0600 and is never readable by others, not even while it
// is being written.
bool WriteFileAtomically(const std::string& path, const void* data, size_t size, std::string* why,
                         unsigned mode = 0644);
inline bool WriteFileAtomically(const std::string& path, const std::string& text, std::string* why,
                                unsigned mode = 0644) {
  return WriteFileAtomically(path, text.data(), text.size(), why, mode);
}
inline bool WriteFileAtomically(const std::string& path, const std::vector<uint8_t>& bytes, std::string* why) {
  return WriteFileAtomically(path, bytes.data(), bytes.size(), why);
}

// The same for a file written in pieces, so that a file of hundreds of MB
// (a long session's map) is not held in memory whole: Append, Patch what
// only the end knows (a header's size and checksum), Commit. A writer
// dropped without Commit removes its temporary; the target is untouched.
// After a failed call every later one fails and Commit says the first error.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(const std::string& path, unsigned mode = 0644);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  bool Append(const void* data, size_t size);
  // Overwrites [offset, offset + size), written already.
  bool Patch(uint64_t offset, const void* data, size_t size);
  // What was written at [offset, offset + size), read back through a
  // read-only mapping (the page cache, not the heap); null on failure.
  class View;
  std::unique_ptr<View> Read(uint64_t offset, uint64_t size);
  uint64_t size() const { return size_; }
  // The first error ("" while all went well).
  const std::string& error() const { return error_; }
  bool Commit(std::string* why);

 private:
  bool Fail(const std::string& what);
  std::string path_, tmp_, error_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

class AtomicFileWriter::View {
 public:
  View(void* base, size_t mapped, const uint8_t* data) : base_(base), mapped_(mapped), data_(data) {}
  ~View();
  View(const View&) = delete;
  View& operator=(const View&) = delete;
  const uint8_t* data() const { return data_; }

 private:
  void* base_;
  size_t mapped_;
  const uint8_t* data_;
};

// Whole file into *out; false with *why when it cannot be read (the one
// file reader: a text file, a model, a map file).
bool ReadFileBytes(const std::string& path, std::vector<uint8_t>* out, std::string* why);
bool ReadFileText(const std::string& path, std::string* out, std::string* why);

// A file a reader may take in whole: it exists, is a regular file (not a
// device, a pipe or a folder: `/dev/zero` would be read for ever) and holds
// at most max_bytes. False with *why naming the file and what it is.
bool CheckRegularFile(const std::string& path, uint64_t max_bytes, std::string* why);

}  // namespace rumi
