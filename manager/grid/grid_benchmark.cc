// The occupancy grid's cost (docs/grid.md): adding one keyframe to a grid
// of a 20 x 20 m room at 5 cm cells (target <= 2 ms), and a whole rebuild
// from 300 keyframes (target <= 200 ms, what a merge or a culling costs).
// Synthetic keyframes: a camera at 1.4 m walking a loop inside the room,
// each seeing 500 map points (walls and furniture from 0 to 2.5 m, a fifth
// of them on the floor), up to 8 m away.
//   build/bin/grid_benchmark
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "manager/grid/grid_builder.h"

namespace rumi {
namespace {

std::vector<GridKeyframe> RoomWalk(int keyframes, int points_per_keyframe, uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const double side = 20;
  std::vector<GridKeyframe> kfs;
  for (int k = 0; k < keyframes; ++k) {
    const double a = 2 * M_PI * k / keyframes;
    const Eigen::Vector3d c(side / 2 + 6 * std::cos(a), side / 2 + 6 * std::sin(a), 1.4);
    GridKeyframe kf;
    kf.timestamp = k * 100000000ll;
    kf.T_wc = Se3(Eigen::Quaterniond(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ())), c);
    while (static_cast<int>(kf.points.size()) < points_per_keyframe) {
      Eigen::Vector3d p;
      if (u(rng) < 0.2) {  // floor
        p = Eigen::Vector3d(c.x() + (u(rng) - 0.5) * 8, c.y() + (u(rng) - 0.5) * 8, 0.0);
      } else {  // a wall of the room
        const double t = u(rng) * side;
        switch (static_cast<int>(u(rng) * 4)) {
          case 0: p = Eigen::Vector3d(t, 0, 0); break;
          case 1: p = Eigen::Vector3d(t, side, 0); break;
          case 2: p = Eigen::Vector3d(0, t, 0); break;
          default: p = Eigen::Vector3d(side, t, 0); break;
        }
        p.z() = u(rng) * 2.5;
      }
      if ((p - c).head<2>().norm() <= 8.0 && p.x() >= 0 && p.y() >= 0 && p.x() <= side && p.y() <= side)
        kf.points.push_back(p);
    }
    kfs.push_back(std::move(kf));
  }
  return kfs;
}

void BM_AddKeyframe(benchmark::State& state) {
  const std::vector<GridKeyframe> kfs = RoomWalk(300, 500);
  GridOptions o;
  GridBuildStats stats;
  OccupancyGrid grid = BuildGrid(kfs, Sim3(), o);  // the room's grid, grown to 20 x 20 m
  size_t k = 0;
  for (auto _ : state) {
    AddKeyframeToGrid(kfs[k++ % kfs.size()], Sim3(), o, &grid, &stats);
    benchmark::DoNotOptimize(grid);
  }
  state.counters["cells"] = static_cast<double>(grid.width()) * grid.height();
  state.counters["rays/kf"] = static_cast<double>(stats.rays_hit + stats.rays_floor) / stats.keyframes;
}
BENCHMARK(BM_AddKeyframe)->Unit(benchmark::kMillisecond);

void BM_RebuildGrid(benchmark::State& state) {
  const std::vector<GridKeyframe> kfs = RoomWalk(static_cast<int>(state.range(0)), 500);
  GridOptions o;
  for (auto _ : state) {
    OccupancyGrid grid = BuildGrid(kfs, Sim3(), o);
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_RebuildGrid)->Arg(300)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace rumi
BENCHMARK_MAIN();
