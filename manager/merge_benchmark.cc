// Merge of a front and a back submap with 100 keyframes each (pairing, M_com,
// alignment, Sim(3) refinement, fusing, welding BA). Target: <= 1 s.
// And the manager's whole rebuild (ManagerService::Rebuild without the file
// writes) for a session of N losses: how its cost grows as a daemon's map
// collects submaps, from scratch and with the MergeMemo.
//   build-*/bin/merge_benchmark   (counters: per-stage seconds)
#include <benchmark/benchmark.h>

#include <chrono>

#include "common/logging.h"
#include "manager/merge.h"
#include "manager/merge_memo.h"
#include "manager/odometry_merge.h"
#include "manager/place_merge.h"
#include "manager/post_culling.h"
#include "manager/testing/synthetic_submaps.h"

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

// A session with n front submaps of 40 frames, lost for 10 frames between
// them; with backs, a back submap over each loss (the last 10 frames before
// it, the gap and the first 10 after), so everything chains into one map.
// Without backs (COLMAP failed everywhere) only the place merge can join
// the fronts: every pair of front submaps is tried, with ORB descriptors.
struct Session {
  GlobalMap map;
  Session(int n, bool backs) {
    SyntheticSceneOptions so;
    so.num_frames = 50 * n;
    so.num_points = 14 * so.num_frames;
    const SyntheticScene scene = MakeSyntheticScene(so);
    for (int k = 0; k < n; ++k) {
      SyntheticSubmap f = MakeSyntheticFront(scene, k, 50 * k, 50 * k + 39, RandomSim3(100 + k), 200 + k);
      if (!backs) AttachPointDescriptors(&f, scene.points.size(), 5, 8, 300 + k);
      map.AddSubmap(std::move(f.submap));
      if (!backs || k + 1 == n) continue;
      SyntheticSubmapOptions b;
      b.id = k;
      b.source = SubmapSource::kBack;
      b.first_frame = 50 * k + 30;
      b.last_frame = 50 * k + 59;
      b.S_lw = RandomSim3(400 + k);
      b.frame_records = false;
      b.point_id_offset = 500000000 + 1000000LL * k;
      b.seed = 500 + k;
      map.AddSubmap(MakeSyntheticSubmap(scene, b).submap);
    }
  }
};

void BM_RebuildSession(benchmark::State& state) {
  spdlog::set_level(spdlog::level::err);
  const int n = int(state.range(0));
  const Session session(n, state.range(1) != 0);
  ManagerOptions o;
  // With the memo (third argument 1), as in a live session: the map was
  // rebuilt once, then the newest front submap grew (here: its last
  // keyframe moved) and the timed rebuild recomputes only what involves it.
  const bool use_memo = state.range(2) != 0;
  MergeMemo memo;
  GlobalMap input = session.map;
  if (use_memo) {
    GlobalMap warm = session.map;
    MergeAll(&warm, o, &memo);
    PlaceMergeAll(&warm, o, nullptr, &memo);
    for (int i = int(input.size()) - 1; i >= 0; --i) {
      if (input.submap(i).source != SubmapSource::kFront) continue;
      input.submap(i).keyframes.back().T_cw.translation().x() += 0.002;
      break;
    }
  }
  double merge = 0, place = 0, odom = 0, cull = 0;
  int merges = 0, attempts = 0, components = 0, iters = 0;
  for (auto _ : state) {
    GlobalMap map = input;
    auto t = std::chrono::steady_clock::now();
    auto lap = [&t] {
      const auto now = std::chrono::steady_clock::now();
      const double s = std::chrono::duration<double>(now - t).count();
      t = now;
      return s;
    };
    std::vector<MergeReport> reports = MergeAll(&map, o, use_memo ? &memo : nullptr);
    merge += lap();
    for (MergeReport& r : PlaceMergeAll(&map, o, nullptr, use_memo ? &memo : nullptr)) reports.push_back(std::move(r));
    place += lap();
    for (MergeReport& r : OdometryMergeAll(&map, o)) reports.push_back(std::move(r));
    odom += lap();
    CullRedundantKeyframes(&map, o);
    cull += lap();
    attempts = int(reports.size());
    merges = 0;
    for (const MergeReport& r : reports) merges += r.merged;
    components = int(map.ComponentsBySize().size());
    ++iters;
  }
  state.counters["merge_s"] = merge / iters;
  state.counters["place_s"] = place / iters;
  state.counters["odometry_s"] = odom / iters;
  state.counters["cull_s"] = cull / iters;
  state.counters["attempts"] = attempts;
  state.counters["merges"] = merges;
  state.counters["components"] = components;
  state.counters["submaps"] = double(session.map.size());
  if (use_memo) state.counters["replayed"] = memo.hits();
}
// (front submaps, with back submaps, memo)
BENCHMARK(BM_RebuildSession)
    ->Args({4, 1, 0})->Args({8, 1, 0})->Args({16, 1, 0})->Args({32, 1, 0})
    ->Args({4, 0, 0})->Args({8, 0, 0})->Args({16, 0, 0})
    ->Args({8, 1, 1})->Args({32, 1, 1})->Args({16, 0, 1})
    ->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
