#pragma once
// rumi-dds-bench --manager RAW (apps/dds_bench_main.cc): does serving the
// map over DDS cost the manager? Feeds the first `submaps` submaps of a saved
// map.rumi.raw one at a time into a manager service, rebuilding and saving
// after each, in three modes: without DDS ("off"); with the server, a 30 Hz
// pose stream and a `rumi query pose --follow` client reading ("follow");
// and with that client stopped by SIGSTOP so it reads nothing ("stopped").
// The service against ddsperf: ipc/dds/dds_bench.h.
#include <string>

#include "ipc/dds/dds_options.h"

namespace rumi {

struct DdsServingBenchOptions {
  DdsOptions dds;       // the server's
  std::string raw;      // the saved map (map.rumi.raw)
  int submaps = 40;     // fed, in the order they were made (0: all)
  int repeat = 2;       // passes of the three modes, interleaved
};

// Prints the rebuild (+ save) and snapshot times of each pass. Returns 0,
// or 1 when the map does not load or the service fails (said on stderr).
int RunDdsServingBench(const DdsServingBenchOptions& o);

}  // namespace rumi
