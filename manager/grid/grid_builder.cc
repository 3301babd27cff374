#include "manager/grid/grid_builder.h"

#include <chrono>

namespace rumi {

const OptionSpec<GridOptions>& GridOptions::Spec() {
  using O = GridOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("grid");
    s->Flag("enabled", &O::enabled, "build the occupancy grid");
    s->Number("floor_band_m", &O::floor_band_m, AtLeast(0.0), AtMost(10.0), "points below this height are floor");
    s->Number("robot_height_m", &O::robot_height_m, Above(0.0), AtMost(100.0),
              "points above this height are overhead (not obstacles)");
    s->Inline(&O::cells, OccupancyGridOptions::Spec());
    s->Inline(&O::frame, GridFrameOptions::Spec());
    s->Rule("floor_band_m < robot_height_m", [](const O& o) { return o.floor_band_m < o.robot_height_m; });
    return s;
  }();
  return *spec;
}

void AddKeyframeToGrid(const GridKeyframe& kf, const Sim3& S_gm, const GridOptions& o, OccupancyGrid* grid,
                       GridBuildStats* stats) {
  const Eigen::Vector3d c = S_gm * kf.T_wc.translation();
  for (const Eigen::Vector3d& pm : kf.points) {
    const Eigen::Vector3d p = S_gm * pm;
    if (p.z() > o.robot_height_m) {
      ++stats->points_overhead;
      continue;
    }
    const bool hit = p.z() >= o.floor_band_m;
    if (!grid->AddRay3d(c, p, hit)) {
      ++stats->rays_refused;
      continue;
    }
    ++(hit ? stats->rays_hit : stats->rays_floor);
  }
  ++stats->keyframes;
}

OccupancyGrid BuildGrid(const std::vector<GridKeyframe>& keyframes, const Sim3& S_gm, const GridOptions& options,
                        GridBuildStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  GridBuildStats local;
  OccupancyGrid grid(options.cells, options.floor_band_m, options.robot_height_m);
  for (const GridKeyframe& kf : keyframes) AddKeyframeToGrid(kf, S_gm, options, &grid, &local);
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats = local;
  return grid;
}

}  // namespace rumi
