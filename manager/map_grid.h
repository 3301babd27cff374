#pragma once
// What the occupancy grid (manager/grid/) takes from the global map: the
// keyframes of one component in the global frame with the points each one
// observes, and the robot's pose source at the component's frames.
#include <map>
#include <string>
#include <utility>
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

// The grid rumi-manager keeps from one save to the next. New keyframes are
// added to it (the Bayes filter per keyframe) as long as every keyframe
// already in it stayed where it was and the grid frame stayed (within a
// quarter cell and 0.1 deg, in the grid frame); when a merge, a culling or
// a front resend moved or removed one, or the frame moved, it is rebuilt
// from all keyframes: the grid follows the map.
class LiveGrid {
 public:
  // The grid of `kfs` in frame *f. When the frame is kept, *f becomes the
  // grid's (the estimate moved less than the tolerance).
  const OccupancyGrid& Update(const std::vector<GridKeyframe>& kfs, GridFrame* f, const GridOptions& o,
                              GridBuildStats* stats);
  const OccupancyGrid& grid() const { return grid_; }
  bool last_incremental() const { return last_incremental_; }
  int last_added() const { return last_added_; }
  int64_t rebuilds() const { return rebuilds_; }
  int64_t incremental_updates() const { return incremental_; }
  std::string last_rebuild_reason() const { return reason_; }

 private:
  struct Placed {
    Eigen::Vector3d centre;  // grid frame
    Eigen::Quaterniond q;    // grid frame
    size_t points = 0;
  };
  bool have_ = false;
  Sim3 S_gm_;
  OccupancyGrid grid_;
  GridBuildStats stats_;  // of the grid as it is (all keyframes in it)
  std::map<std::pair<Timestamp, int>, Placed> placed_;  // (timestamp, n-th keyframe with it)
  bool last_incremental_ = false;
  int last_added_ = 0;
  int64_t rebuilds_ = 0, incremental_ = 0;
  std::string reason_;
};

struct MapGridResult {
  bool ok = false;
  bool no_frame = false;  // no metric frame (no scale, up or floor) or no ray: why says which
  std::string why;
  GridFrame frame;
  GridBuildStats stats;
  int width = 0, height = 0;
  double free_m2 = 0, occupied_m2 = 0;
  bool incremental = false;  // keyframes added to the kept grid (else built anew)
  int added = 0;             // keyframes added by this update
  std::string rebuild_reason;
  MapServerGrid cells;  // as written (grid.pgm)
  std::string yaml;     // grid.yaml as written
  std::string Summary() const;  // one line: size, areas, rays, scale, time
};

// The grid of the map's largest component, written to out_dir as grid.pgm,
// grid.yaml (map_server + rumi's keys), grid.png and grid_trajectory.txt
// (the keyframes in the grid frame). `odometry` empty: the pose source the
// submaps carry. False with why when no metric frame exists (no_frame) or a
// file cannot be written; files of an earlier grid stay as they were.
// With `live`, the grid kept there is updated instead of built anew.
bool WriteMapGrid(const GlobalMap& map, const GridOptions& options, const Trajectory& odometry,
                  const std::string& out_dir, MapGridResult* result, LiveGrid* live = nullptr);

}  // namespace rumi
