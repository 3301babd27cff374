// Loop closure's cost as the map grows (#51: "loop detected -> corrected map
// <= 2 s p95 at 1k keyframes"): a room walked for N keyframes (0.25 s apart,
// a lap in 24 s, drifting), as one front submap.
//   BM_LoopSearch/N: every keyframe searched (place index query, verification)
//     and the first loop_max_solves loops closed: a map loaded whole.
//   BM_LoopRebuild/N: the state warm (searches and decisions kept, as the
//     manager keeps them), the loops closed again on the raw map: what each
//     later rebuild pays.
//   build-*/bin/loop_closure_benchmark
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "manager/loop_closure.h"
#include "manager/testing/synthetic_walk.h"

namespace rumi {
namespace {

const Walk& WalkOf(int keyframes) {
  static std::map<int, std::unique_ptr<Walk>> cache;
  auto& w = cache[keyframes];
  if (!w) {
    WalkOptions o;
    o.keyframes = keyframes;
    // A lighter drift than the test's: 10 laps of it stay a room.
    o.yaw_per_kf = 0.0005;
    o.shift_per_kf = 0.001;
    o.scale_per_kf = 0.0002;
    w = std::make_unique<Walk>(MakeRoomWalk(o));
  }
  return *w;
}

void Report(benchmark::State& state, const LoopClosureReport& r, const Walk& w, const GlobalMap& map) {
  state.counters["loops_closed"] = r.closed;
  state.counters["detections"] = r.detections;
  state.counters["detect_s"] = r.seconds_detect;
  state.counters["close_s"] = r.seconds_close;
  state.counters["keyframe_ate"] = KeyframeAte(w, map);
  GlobalMap raw;
  raw.AddSubmap(w.submap);
  state.counters["keyframe_ate_before"] = KeyframeAte(w, raw);
  state.counters["loops_waiting"] = r.waiting;  // loop_max_solves: for the next rebuild
  state.counters["loops_refused"] = double(r.loops.size()) - r.closed - r.waiting;
}

void BM_LoopSearch(benchmark::State& state) {
  const Walk& w = WalkOf(int(state.range(0)));
  LoopClosureReport r;
  GlobalMap map;
  for (auto _ : state) {
    state.PauseTiming();
    map = GlobalMap();
    map.AddSubmap(w.submap);
    LoopClosureState s;
    state.ResumeTiming();
    r = CloseLoops(&map, ManagerOptions(), &s);
  }
  Report(state, r, w, map);
}
BENCHMARK(BM_LoopSearch)->Arg(400)->Arg(1000)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_LoopRebuild(benchmark::State& state) {
  const Walk& w = WalkOf(int(state.range(0)));
  LoopClosureState s;
  GlobalMap map;
  map.AddSubmap(w.submap);
  CloseLoops(&map, ManagerOptions(), &s);  // searches memoised
  LoopClosureReport r;
  for (auto _ : state) {
    state.PauseTiming();
    map = GlobalMap();
    map.AddSubmap(w.submap);
    state.ResumeTiming();
    r = CloseLoops(&map, ManagerOptions(), &s);
  }
  Report(state, r, w, map);
}
BENCHMARK(BM_LoopRebuild)->Arg(400)->Arg(1000)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
