// Merge of a front and a back submap with 100 keyframes each (pairing, M_com,
// alignment, Sim(3) refinement, fusing, welding BA). Target: <= 1 s.
//   build-manager/bin/merge_benchmark   (counters: per-stage seconds)
#include <benchmark/benchmark.h>

#include "common/logging.h"
#include "manager/merge.h"
#include "manager/synthetic_submaps.h"

namespace rumi {
namespace {

struct Fixture {
  GlobalMap map;
  int front = -1, back = -1;
  explicit Fixture(int points) {
    SyntheticSceneOptions so;
    so.num_frames = 180;
    so.num_points = points;
    const SyntheticScene scene = MakeSyntheticScene(so);
    SyntheticSubmapOptions f;
    f.id = 1;
    f.first_frame = 0;
    f.last_frame = 99;
    f.S_lw = RandomSim3(1);
    f.max_octave = 3;
    f.pose_noise_m = 0.01;
    f.pose_noise_rad = 0.002;
    f.seed = 2;
    SyntheticSubmapOptions b = f;
    b.id = 1;
    b.source = SubmapSource::kBack;
    b.first_frame = 80;
    b.last_frame = 179;
    b.S_lw = RandomSim3(3);
    b.max_octave = 0;
    b.frame_records = false;
    b.point_id_offset = 1000000;
    b.seed = 4;
    front = map.AddSubmap(MakeSyntheticSubmap(scene, f).submap);
    back = map.AddSubmap(MakeSyntheticSubmap(scene, b).submap);
  }
};

void BM_Merge100x100(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  const Fixture fx(int(state.range(0)));
  ManagerOptions o;
  o.welding_min_covisible = int(state.range(1));
  const SearchSet search = BuildSearchSet({&fx.map.submap(fx.front)}, {&fx.map.submap(fx.back)}, o.search_n);
  double align = 0, refine = 0, weld = 0, window = 0, residuals = 0, obs = 0, common = 0;
  int n = 0;
  for (auto _ : state) {
    state.PauseTiming();
    GlobalMap map = fx.map;
    state.ResumeTiming();
    const MergeReport r = MergePair(&map, fx.front, fx.back, search, o);
    if (!r.merged) state.SkipWithError(("merge rejected: " + r.reason).c_str());
    align += r.seconds_align;
    refine += r.seconds_refine;
    weld += r.seconds_weld;
    window += r.welding.window_keyframes;
    residuals += r.welding.residuals;
    common += r.common_points;
    ++n;
  }
  for (const Keyframe& kf : fx.map.submap(fx.front).keyframes)
    for (int64_t p : kf.point_ids) obs += p >= 0;
  if (n > 0) {
    state.counters["align_s"] = align / n;
    state.counters["refine_s"] = refine / n;
    state.counters["weld_s"] = weld / n;
    state.counters["window_kf"] = window / n;
    state.counters["ba_residuals"] = residuals / n;
    state.counters["common_pts"] = common / n;
    state.counters["front_obs"] = obs;
  }
}
// (scene points, welding covisibility threshold)
BENCHMARK(BM_Merge100x100)->Args({1500, 15})->Args({3000, 15})->Args({3000, 100})->Unit(benchmark::kMillisecond)
    ->Iterations(3);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
