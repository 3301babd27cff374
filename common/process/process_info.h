#pragma once
// Process identity that survives pid reuse: (pid, start time since boot).
#include <cstdint>
#include <sys/types.h>

namespace rumi {

struct ProcessId {
  uint64_t pid = 0;
  uint64_t start_ticks = 0;  // /proc/<pid>/stat field 22; 0 when unknown
};

ProcessId SelfProcessId();
// Start time of pid in clock ticks since boot, 0 when it does not exist.
uint64_t ProcessStartTicks(pid_t pid);
// True when the process exists and (if known) was started at start_ticks, i.e.
// it is the same process and not a later one that got the same pid.
bool ProcessAlive(const ProcessId& id);
// The process exists and is not a zombie (killed, not reaped yet).
inline bool ProcessRunning(pid_t pid) {
  return pid > 0 && ProcessAlive({static_cast<uint64_t>(pid), ProcessStartTicks(pid)});
}

// Resident memory of a process (VmRSS), MiB (0: this process); -1 when
// unknown (no such process).
double ResidentMiB(pid_t pid = 0);

}  // namespace rumi
