// The link's MAC cost per datagram and per frame on this host
// (docs/robot_link.md, "Security": the robot's figure is scaled from
// Espressif's published SHA-256 throughput, not from this).
#include <benchmark/benchmark.h>

#include <cstring>
#include <vector>

#include "rumi_link_auth.h"

namespace {

void BM_SealDatagram(benchmark::State& state) {
  uint8_t key[RL_KEY_SIZE];
  std::memset(key, 7, sizeof(key));
  std::vector<uint8_t> d(RL_MAX_DATAGRAM, 0x55);
  const size_t len = static_cast<size_t>(state.range(0));
  d[4] = RL_FLAG_AUTH;
  for (auto _ : state) benchmark::DoNotOptimize(rl_seal(key, d.data(), len, d.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(len));
}
// A full fragment, and a heartbeat.
BENCHMARK(BM_SealDatagram)->Arg(RL_MAX_DATAGRAM - RL_TAG_SIZE)->Arg(RL_HEADER_SIZE + 24);

}  // namespace

BENCHMARK_MAIN();
