#include "common/process/process_info.h"

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <unistd.h>

namespace rumi {

uint64_t ProcessStartTicks(pid_t pid) {
  char path[64];
  std::snprintf(path, sizeof(path), "/proc/%d/stat", static_cast<int>(pid));
  FILE* f = std::fopen(path, "r");
  if (!f) return 0;
  char buf[1024];
  const size_t n = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  buf[n] = '\0';
  // The command name (field 2) may hold spaces and ')': fields after the last ')'.
  const char* p = std::strrchr(buf, ')');
  if (!p) return 0;
  ++p;
  // Field 3 is the first after ')'; start time is field 22.
  int field = 2;
  while (*p && field < 22) {
    if (*p == ' ') ++field;
    ++p;
  }
  return std::strtoull(p, nullptr, 10);
}

ProcessId SelfProcessId() {
  ProcessId id;
  id.pid = static_cast<uint64_t>(getpid());
  id.start_ticks = ProcessStartTicks(getpid());
  return id;
}

bool ProcessAlive(const ProcessId& id) {
  if (id.pid == 0) return false;
  const pid_t pid = static_cast<pid_t>(id.pid);
  if (kill(pid, 0) != 0 && errno != EPERM) return false;
  if (id.start_ticks == 0) return true;
  const uint64_t now = ProcessStartTicks(pid);
  // A zombie (killed, not yet reaped) still has its /proc entry; treat as dead.
  if (now != id.start_ticks) return false;
  char path[64];
  std::snprintf(path, sizeof(path), "/proc/%d/stat", static_cast<int>(pid));
  FILE* f = std::fopen(path, "r");
  if (!f) return false;
  char buf[512];
  const size_t n = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  buf[n] = '\0';
  const char* p = std::strrchr(buf, ')');
  return !(p && p[1] == ' ' && (p[2] == 'Z' || p[2] == 'X'));
}

ResidentMemory ResidentMemoryOf(pid_t pid) {
  ResidentMemory m;
  std::ifstream in("/proc/" + (pid > 0 ? std::to_string(pid) : std::string("self")) + "/status");
  const std::pair<const char*, double*> fields[] = {
      {"VmRSS:", &m.total_mib}, {"RssAnon:", &m.private_mib}, {"RssShmem:", &m.shared_mib}};
  for (std::string line; std::getline(in, line);)
    for (const auto& [key, value] : fields)
      if (line.rfind(key, 0) == 0) *value = std::stod(line.substr(std::strlen(key))) / 1024.0;  // kB
  return m;
}

}  // namespace rumi
