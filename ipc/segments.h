#pragma once
// Where an instance's shared-memory segments are named, listed, removed and
// reclaimed: the one place that knows the names (rumi_<instance>_<channel>,
// ipc/channels.h) and where POSIX shared memory lives on this system.
//
// A segment is stale when no process that used it is alive: its producer and
// its consumer (when one attached) are dead or were never recorded. A
// killed `rumi eval run` or rumid leaves such segments; the next start of any
// rumi supervisor reclaims them (a rumid instance's stale segments that
// still hold unread messages are left to that instance's next start), and
// `rumi-ipc-status --reclaim` does it by hand.
#include <string>
#include <vector>

#include "ipc/shm_ring.h"

namespace rumi {

// The instance's segments, one per channel (windows, front_submaps, back_submaps).
std::vector<std::string> InstanceSegmentNames(const std::string& instance);
// Rings whose reader only wants the newest message (poses, map notices):
// unread messages in them are stale, never worth keeping for a restart.
bool NewestWinsSegment(const std::string& instance, const std::string& name);

struct SegmentInfo {
  std::string name;
  bool readable = false;  // a rumi ring whose header could be read
  RingStats stats;        // when readable
  bool stale = false;     // nobody alive uses it
  std::string note;       // why it is not readable
};

// Every rumi_* segment on this machine (all instances).
std::vector<SegmentInfo> ListRumiSegments();

// Removes the instance's segments that are stale, or all of them with
// `force` (the caller knows its children are gone). Returns the names removed.
std::vector<std::string> RemoveInstanceSegments(const std::string& instance, bool force);

// Removes every stale rumi_* segment (of any instance but `keep_instance`,
// whose segments a restarting rumid takes over with what is unread in them).
// Returns the names.
std::vector<std::string> ReclaimStaleSegments(const std::string& keep_instance = "");

}  // namespace rumi
