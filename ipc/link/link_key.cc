#include "ipc/link/link_key.h"

#include <sys/random.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "common/atomic_file.h"

namespace rumi {

bool RandomBytes(uint8_t* out, size_t n) {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = getrandom(out + got, n - got, 0);
    if (r < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    got += static_cast<size_t>(r);
  }
  return true;
}

bool LoadLinkKey(const std::string& path, LinkKey* key, std::string* why) {
  if (!CheckRegularFile(path, 4096, why)) return false;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (why) *why = "link key " + path + ": " + std::strerror(errno);
    return false;
  }
  if (st.st_mode & 077) {
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(st.st_mode & 07777));
    if (why)
      *why = "link key " + path + " can be read or changed by others (mode " + mode + "); chmod 600 " + path;
    return false;
  }
  std::vector<uint8_t> bytes;
  if (!ReadFileBytes(path, &bytes, why)) return false;
  if (rl_key_from_hex(reinterpret_cast<const char*>(bytes.data()), bytes.size(), key->data()) != 0) {
    if (why) *why = "link key " + path + " is not 64 hex digits (make one with `rumi link keygen`)";
    return false;
  }
  return true;
}

bool GenerateLinkKey(LinkKey* key, std::string* why) {
  if (RandomBytes(key->data(), key->size())) return true;
  if (why) *why = std::string("getrandom: ") + std::strerror(errno);
  return false;
}

bool WriteLinkKey(const std::string& path, const LinkKey& key, bool overwrite, std::string* why) {
  struct stat st {};
  if (!overwrite && ::lstat(path.c_str(), &st) == 0) {
    if (why) *why = path + " exists (a robot may already hold that key); --force replaces it";
    return false;
  }
  char hex[2 * RL_KEY_SIZE + 1];
  rl_key_to_hex(key.data(), hex);
  return WriteFileAtomically(path, std::string(hex) + "\n", why, 0600);
}

std::string LinkKeyNvsCsv(const LinkKey& key) {
  char hex[2 * RL_KEY_SIZE + 1];
  rl_key_to_hex(key.data(), hex);
  return std::string("key,type,encoding,value\nrumi,namespace,,\nlink_key,data,hex2bin,") + hex + "\n";
}

}  // namespace rumi
