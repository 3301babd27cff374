#pragma once
// Builds the occupancy grid from keyframes and the map points they observe:
// each keyframe casts, on the floor plane, one ray from its centre to each of
// its points. Points in the robot's height band (above the floor band, up to
// robot_height_m) are obstacles (full ISM); floor points are free evidence
// only; points above the robot (ceilings, shelves it passes under) are not
// used. The grid is rebuilt whole from the keyframes whenever the map moves
// (a merge, a culling), so it follows the map, never the other way round.
#include <string>
#include <vector>

#include "common/option_spec.h"
#include "manager/grid/grid_frame.h"
#include "manager/grid/occupancy_grid.h"

namespace rumi {

struct GridOptions {
  bool enabled = true;
  double floor_band_m = 0.05;   // points below this height are the floor
  double robot_height_m = 0.6;  // points above this are overhead
  OccupancyGridOptions cells;   // resolution_m, clamps, ism: ...
  GridFrameOptions frame;       // camera_height_m, ...
  static const OptionSpec<GridOptions>& Spec();  // section `grid:`
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

struct GridBuildStats {
  int keyframes = 0;
  int64_t rays_hit = 0, rays_floor = 0, points_overhead = 0, rays_refused = 0;
  double seconds = 0;
};

// Adds one keyframe (map frame) to `grid` through the map -> grid transform.
void AddKeyframeToGrid(const GridKeyframe& kf, const Sim3& S_gm, const GridOptions& options, OccupancyGrid* grid,
                       GridBuildStats* stats);
// A new grid from all keyframes.
OccupancyGrid BuildGrid(const std::vector<GridKeyframe>& keyframes, const Sim3& S_gm, const GridOptions& options,
                        GridBuildStats* stats = nullptr);

}  // namespace rumi
