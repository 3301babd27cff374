#pragma once
// What the occupancy grid (manager/grid/) takes from the global map: the
// keyframes of one component in the global frame with the points each one
// observes, and the robot's pose source at the component's frames.
#include <vector>

#include "common/trajectory.h"
#include "manager/global_map.h"
#include "manager/grid/grid_builder.h"
#include "manager/grid/grid_file.h"
#include "manager/grid/grid_frame.h"

namespace rumi {

std::vector<GridKeyframe> GridKeyframesOf(const GlobalMap& map, int component);
// Pose-source poses carried by the component's submaps, sorted, one per
// timestamp; empty without a pose source.
Trajectory OdometryOf(const GlobalMap& map, int component);

struct MapGridResult {
  bool ok = false;
  bool no_frame = false;  // no metric frame (no scale, up or floor) or no ray: why says which
  std::string why;
  GridFrame frame;
  GridBuildStats stats;
  int width = 0, height = 0;
  double free_m2 = 0, occupied_m2 = 0;
  MapServerGrid cells;  // as written (grid.pgm)
  std::string yaml;     // grid.yaml as written
  std::string Summary() const;  // one line: size, areas, rays, scale, time
};

// The grid of the map's largest component, written to out_dir as grid.pgm,
// grid.yaml (map_server + rumi's keys), grid.png and grid_trajectory.txt
// (the keyframes in the grid frame). `odometry` empty: the pose source the
// submaps carry. False with why when no metric frame exists (no_frame) or a
// file cannot be written; files of an earlier grid stay as they were.
bool WriteMapGrid(const GlobalMap& map, const GridOptions& options, const Trajectory& odometry,
                  const std::string& out_dir, MapGridResult* result);

}  // namespace rumi
