// rumi-ipc-status: prints the counters of an instance's shared-memory channels
// (pushed, popped, drops by cause, peers and whether they are alive), lists
// every rumi segment on the machine (--all), or removes the stale ones that
// killed processes left behind (--reclaim; rumid and `rumi eval run` do this
// at start too).
#include <CLI/CLI.hpp>

#include <cstdio>

#include "ipc/channels.h"
#include "ipc/segments.h"

int main(int argc, char** argv) {
  CLI::App app{"Show rumi shared-memory channel counters; list or reclaim segments"};
  std::string instance = "default";
  bool all = false, reclaim = false;
  app.add_option("-i,--instance", instance, "rumi instance id");
  app.add_flag("--all", all, "every rumi segment on this machine, stale ones marked");
  app.add_flag("--reclaim", reclaim, "remove the segments no live process uses (of any instance)");
  CLI11_PARSE(app, argc, argv);
  if (reclaim) {
    const auto removed = rumi::ReclaimStaleSegments();
    for (const std::string& name : removed) std::printf("removed %s\n", name.c_str());
    std::printf("%zu stale segment(s) removed\n", removed.size());
    return 0;
  }
  if (all) {
    const auto segments = rumi::ListRumiSegments();
    for (const rumi::SegmentInfo& i : segments) {
      if (!i.readable) std::printf("%s: not a rumi ring (%s)\n", i.name.c_str(), i.note.c_str());
      else std::printf("%s%s\n", rumi::FormatRingStats(i.stats).c_str(), i.stale ? "  [stale: --reclaim removes it]" : "");
    }
    if (segments.empty()) std::printf("no rumi segment\n");
    return 0;
  }
  int found = 0;
  for (const std::string& name : rumi::InstanceSegmentNames(instance)) {
    rumi::RingStats s;
    std::string err;
    if (rumi::ReadRingStats(name, &s, &err)) {
      std::printf("%s\n", rumi::FormatRingStats(s).c_str());
      ++found;
    } else {
      std::printf("%s\n", err.c_str());
    }
  }
  return found > 0 ? 0 : 1;
}
