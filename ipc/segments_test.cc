#include "ipc/segments.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>

#include "ipc/channels.h"

namespace rumi {
namespace {

bool Exists(const std::string& name) {
  RingStats s;
  return ReadRingStats(name, &s);
}

bool Contains(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// What `kill -9` of a pipeline leaves: segments whose producer died.
void LeaveSegmentsOfADeadProcess(const IpcOptions& o) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    WindowSender w(o);
    SubmapSender f(o, SubmapSource::kFront);
    w.ring().KeepSegmentOnExit();
    f.ring().KeepSegmentOnExit();
    ::_exit(0);
  }
  ::waitpid(pid, nullptr, 0);
}

TEST(Segments, StaleSegmentsOfDeadOwnersAreReclaimedLiveOnesAreKept) {
  IpcOptions dead;
  dead.instance = "segtest_dead_" + std::to_string(::getpid());
  dead.window_slot_bytes = dead.submap_slot_bytes = 1 << 16;
  LeaveSegmentsOfADeadProcess(dead);
  const std::string dead_windows = SegmentName(dead.instance, kWindowChannel);
  ASSERT_TRUE(Exists(dead_windows));

  IpcOptions live = dead;
  live.instance = "segtest_live_" + std::to_string(::getpid());
  WindowSender producer(live);  // alive: ours
  const std::string live_windows = SegmentName(live.instance, kWindowChannel);

  IpcOptions kept = dead;
  kept.instance = "segtest_kept_" + std::to_string(::getpid());
  LeaveSegmentsOfADeadProcess(kept);

  bool listed = false;
  for (const SegmentInfo& i : ListRumiSegments()) {
    if (i.name != dead_windows) continue;
    listed = true;
    EXPECT_TRUE(i.readable);
    EXPECT_TRUE(i.stale);
  }
  EXPECT_TRUE(listed);

  const std::vector<std::string> removed = ReclaimStaleSegments(kept.instance);
  EXPECT_TRUE(Contains(removed, dead_windows));
  EXPECT_TRUE(Contains(removed, SegmentName(dead.instance, kFrontSubmapChannel)));
  EXPECT_FALSE(Exists(dead_windows));
  EXPECT_TRUE(Exists(live_windows)) << "a live producer's segment was removed";
  EXPECT_TRUE(Exists(SegmentName(kept.instance, kWindowChannel))) << "the instance being restarted keeps its segments";

  // Removing an instance's segments: stale ones only, or all of them.
  EXPECT_TRUE(RemoveInstanceSegments(live.instance, false).empty());
  EXPECT_EQ(RemoveInstanceSegments(kept.instance, false).size(), 2u);
  EXPECT_EQ(InstanceSegmentNames(live.instance).size(), 5u);
}

}  // namespace
}  // namespace rumi
