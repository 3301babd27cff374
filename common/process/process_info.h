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

// Resident memory of a process, MiB (pid 0: this process); -1 when unknown
// (no such process). The total (VmRSS) also counts the pages of shared
// segments the process has touched (a ring fills its pages as its write
// position first goes round, up to the ring's size) and of mapped libraries;
// the private part (RssAnon: heap, stacks) is what the process itself grows.
struct ResidentMemory {
  double total_mib = -1;    // VmRSS
  double private_mib = -1;  // RssAnon
  double shared_mib = -1;   // RssShmem: shared-memory segments (the ipc rings)
};
ResidentMemory ResidentMemoryOf(pid_t pid = 0);
inline double ResidentMiB(pid_t pid = 0) { return ResidentMemoryOf(pid).total_mib; }

}  // namespace rumi
