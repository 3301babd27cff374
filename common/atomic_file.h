#pragma once
// The one way rumi writes a file that a reader (another process, a later
// start) may open at any time: a temporary file beside the target, written
// and fsynced, renamed over the target, then the folder fsynced. A reader sees
// the old file or the new one, never half of one; a full disk or a killed
// writer leaves the old file as it was (and no temporary behind on errors).
#include <cstddef>
#include <cstdint>
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

// Whole file into *out; false with *why when it cannot be read.
bool ReadFileBytes(const std::string& path, std::vector<uint8_t>* out, std::string* why);

// A file a reader may take in whole: it exists, is a regular file (not a
// device, a pipe or a folder: `/dev/zero` would be read for ever) and holds
// at most max_bytes. False with *why naming the file and what it is.
bool CheckRegularFile(const std::string& path, uint64_t max_bytes, std::string* why);

}  // namespace rumi
