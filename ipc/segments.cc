#include "ipc/segments.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>

#include "ipc/channels.h"

namespace rumi {
namespace {

// Boost.Interprocess names POSIX shared memory through shm_open, which is
// /dev/shm on Linux: the only place rumi lists segments from.
constexpr const char* kShmDir = "/dev/shm";

bool Stale(const RingStats& s) {
  const bool producer_gone = s.producer_pid == 0 || !s.producer_alive;
  const bool consumer_gone = s.consumer_pid == 0 || !s.consumer_alive;
  return producer_gone && consumer_gone;
}

SegmentInfo Inspect(const std::string& name) {
  SegmentInfo i;
  i.name = name;
  std::string error;
  i.readable = ReadRingStats(name, &i.stats, &error);
  if (!i.readable) {
    i.note = error;
    return i;
  }
  i.stale = Stale(i.stats);
  return i;
}

}  // namespace

std::vector<std::string> InstanceSegmentNames(const std::string& instance) {
  return {SegmentName(instance, kWindowChannel), SegmentName(instance, kFrontSubmapChannel),
          SegmentName(instance, kBackSubmapChannel), SegmentName(instance, kPoseChannel),
          SegmentName(instance, kMapNoticeChannel)};
}

bool NewestWinsSegment(const std::string& instance, const std::string& name) {
  return name == SegmentName(instance, kPoseChannel) || name == SegmentName(instance, kMapNoticeChannel);
}

std::vector<SegmentInfo> ListRumiSegments() {
  std::vector<SegmentInfo> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(kShmDir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("rumi_", 0) == 0) out.push_back(Inspect(name));
  }
  return out;
}

std::vector<std::string> RemoveInstanceSegments(const std::string& instance, bool force) {
  std::vector<std::string> removed;
  for (const std::string& name : InstanceSegmentNames(instance)) {
    const SegmentInfo i = Inspect(name);
    // An unreadable one is foreign or half-created: only removed by force.
    if ((force || (i.readable && i.stale)) && RemoveSegment(name)) removed.push_back(name);
  }
  return removed;
}

std::vector<std::string> ReclaimStaleSegments(const std::string& keep_instance) {
  std::vector<std::string> removed;
  const std::vector<std::string> kept =
      keep_instance.empty() ? std::vector<std::string>() : InstanceSegmentNames(keep_instance);
  for (const SegmentInfo& i : ListRumiSegments()) {
    if (!i.readable || !i.stale) continue;
    // Unread messages of a rumid instance wait for its restart; those of a
    // `rumi eval run` (instance eval_<pid>_<k>) have nobody to come back.
    const bool unread = i.stats.tail < i.stats.head;
    if (unread && i.name.rfind("rumi_eval_", 0) != 0) continue;
    if (std::find(kept.begin(), kept.end(), i.name) != kept.end()) continue;
    if (RemoveSegment(i.name)) {
      spdlog::info("ipc: removed stale segment {} (producer pid {}, consumer pid {}: both gone)", i.name,
                   i.stats.producer_pid, i.stats.consumer_pid);
      removed.push_back(i.name);
    }
  }
  return removed;
}

}  // namespace rumi
