// rumi-dds-bench: the map service's speed against Cyclone's own ddsperf, on
// this machine, in one run (docs/dds.md, docs/results/; RunDdsBench,
// ipc/dds/dds_bench.h). A child process serves a synthetic snapshot
// (--points points); this process queries it: the status round trip
// (p50/p99 over --rounds calls) and the fetch of all points in one page (the
// reply in chunks). Then ddsperf ping/pong on the same transport: 64 B round
// trips, and round trips of the points' byte count. Prints the figures and
// the ratios the DDS issue asks for.
//   rumi-dds-bench [--points 100000] [--rounds 2000] [--fetches 30] [--domain 77]
// With --manager RAW (a saved map.rumi.raw): does serving cost the manager?
// (RunDdsServingBench, manager/dds_serving_bench.h) Feeds the first
// --submaps submaps of RAW one at a time into a manager service, rebuilding
// and saving after each, three times: without DDS; with the server, a 30 Hz
// pose stream and a `rumi query pose --follow` client reading; and with that
// client stopped (SIGSTOP) so it reads nothing. Prints the rebuild (+ save)
// and snapshot times of each.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>

#include "ipc/dds/dds_bench.h"
#include "manager/dds_serving_bench.h"

namespace rumi {
namespace {

int Main(int argc, char** argv) {
  CLI::App app{"rumi-dds-bench: the DDS map service against ddsperf on this machine"};
  DdsBenchOptions o;
  DdsServingBenchOptions m;
  int domain = 77;
  int64_t chunk_bytes = DdsOptions().chunk_bytes;
  app.add_option("--chunk-bytes", chunk_bytes, "dds.chunk_bytes of the server")->capture_default_str();
  app.add_option("--manager", m.raw, "a map.rumi.raw: time the manager with and without serving");
  app.add_option("--submaps", m.submaps, "with --manager: how many submaps to feed")->capture_default_str();
  app.add_option("--repeat", m.repeat, "with --manager: passes of the three modes")->capture_default_str();
  app.add_option("--points", o.points, "points in the served map (one page)")->capture_default_str();
  app.add_option("--rounds", o.rounds, "status round trips")->capture_default_str();
  app.add_option("--fetches", o.fetches, "fetches of all points")->capture_default_str();
  app.add_option("--domain", domain, "DDS domain (keep it apart from live ones)")->capture_default_str();
  app.add_option("--ddsperf-seconds", o.ddsperf_s, "seconds per ddsperf run")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::string why;
  o.dds.domain_id = domain;
  o.dds.max_page_points = std::max(o.points, 1);
  o.dds.chunk_bytes = chunk_bytes;
  if (!o.dds.Check(&why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 2;
  }
  if (m.raw.empty()) return RunDdsBench(o);
  spdlog::set_level(spdlog::level::warn);
  m.dds = o.dds;
  return RunDdsServingBench(m);
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
