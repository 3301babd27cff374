#pragma once
// What the DDS server answers from: an immutable copy of the manager's
// product after a rebuild (rumi-manager builds it, manager/map_snapshot_of.h,
// and hands it over by pointer swap; the merge loop never waits on DDS).
// Poses and points are in the global frame of the main component.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/timestamp.h"
#include "manager/grid/grid_file.h"

namespace rumi {

struct SnapshotStatus {
  std::string instance;
  std::string state;  // starting | running | rebuilding | done | stopping
  int64_t stamp_ns = 0;  // wall clock when built
  int64_t rebuilds = 0;
  int submaps_front = 0, submaps_back = 0, components = 0, keyframes = 0, trajectory_frames = 0;
  int64_t points = 0;
  std::string last_save, grid, json;
};

struct SnapshotKeyframe {
  int64_t id = -1;
  Timestamp timestamp = 0;
  std::string submap;  // "front#3"
  int component = 0;   // 0: main
  Se3 T_wc;            // camera -> global (of its component)
};

struct SnapshotPose {
  Timestamp timestamp = 0;
  bool from_back = false;
  Se3 T_wc;
};

struct SnapshotSubmap {
  std::string key;
  int component = 0;
  int keyframes = 0;
  int64_t points = 0;
  Timestamp first = 0, last = 0;
  Sim3 S_gl;
};

struct SnapshotGrid {
  bool ok = false;
  MapServerGrid cells;  // map_server values
  std::string yaml;     // grid.yaml as written
  Sim3 S_gm;            // global (main component) -> grid frame (metric, z up)
};

// What happened since the previous snapshot (the events topic).
struct SnapshotEvent {
  std::string kind;  // received | merged | rejected | culled | saved
  std::string submap, other;
  Sim3 S;            // merged: submap -> other
  std::string detail;
};

struct MapSnapshot {
  int64_t seq = 0;  // the rebuild it comes from
  SnapshotStatus status;
  std::vector<Eigen::Vector3f> points;           // main component
  std::vector<SnapshotKeyframe> keyframes;       // main component first
  std::vector<SnapshotPose> trajectory;          // main component, by time
  std::vector<SnapshotSubmap> submaps;
  SnapshotGrid grid;
  std::vector<SnapshotEvent> events;
};

}  // namespace rumi
