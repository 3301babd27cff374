#pragma once
// rumi-dds-bench (apps/dds_bench_main.cc): the map service's speed against
// Cyclone's own ddsperf, on this machine, in one run (docs/dds.md,
// docs/results/). A child process serves a synthetic snapshot of `points`
// points; this process queries it: the status round trip (p50/p99 over
// `rounds` calls) and the fetch of all points in one page (the reply in
// chunks). Then ddsperf ping/pong on the same transport: 64 B round trips,
// and round trips of the points' byte count; and ddsperf pub/sub of samples
// that size. Whether serving costs the manager: manager/dds_serving_bench.h.
#include "ipc/dds/dds_options.h"

namespace rumi {

struct DdsBenchOptions {
  DdsOptions dds;             // domain (keep it apart from live ones), chunk_bytes; max_page_points >= points
  int points = 100000;        // in the served map (one page)
  int rounds = 2000;          // status round trips
  int fetches = 30;           // fetches of all points
  double ddsperf_s = 10;      // seconds per ddsperf run
};

// Prints the figures and the ratios the DDS issue asks for. Returns 0, or 1
// when rumi's own client fails (said on stderr); a ddsperf that gives no
// figures is said on stdout and still returns 0.
int RunDdsBench(const DdsBenchOptions& o);

}  // namespace rumi
