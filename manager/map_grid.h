#pragma once
// What the occupancy grid (manager/grid/) takes from the global map: the
// keyframes of one component in the global frame with the points each one
// observes, and the robot's pose source at the component's frames.
#include <vector>

#include "common/trajectory.h"
#include "manager/global_map.h"
#include "manager/grid/grid_frame.h"

namespace rumi {

std::vector<GridKeyframe> GridKeyframesOf(const GlobalMap& map, int component);
// Pose-source poses carried by the component's submaps, sorted, one per
// timestamp; empty without a pose source.
Trajectory OdometryOf(const GlobalMap& map, int component);

}  // namespace rumi
