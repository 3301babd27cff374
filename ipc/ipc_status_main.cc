// rumi-ipc-status: prints the counters of an instance's shared-memory channels
// (pushed, popped, drops by cause, peers and whether they are alive).
#include <CLI/CLI.hpp>

#include <cstdio>

#include "ipc/channels.h"

int main(int argc, char** argv) {
  CLI::App app{"Show rumi shared-memory channel counters"};
  std::string instance = "default";
  app.add_option("-i,--instance", instance, "rumi instance id");
  CLI11_PARSE(app, argc, argv);
  int found = 0;
  for (const char* ch : {rumi::kWindowChannel, rumi::kFrontSubmapChannel, rumi::kBackSubmapChannel}) {
    rumi::RingStats s;
    std::string err;
    if (rumi::ReadRingStats(rumi::SegmentName(instance, ch), &s, &err)) {
      std::printf("%s\n", rumi::FormatRingStats(s).c_str());
      ++found;
    } else {
      std::printf("%s\n", err.c_str());
    }
  }
  return found > 0 ? 0 : 1;
}
