#pragma once
// Turns the manager's current product into the snapshot the DDS server
// answers from (ipc/dds/map_snapshot.h), and the events since the
// previous one (new submaps, merges and rejections of real attempts,
// culling, saves).
#include <memory>
#include <set>
#include <string>
#include <utility>

#include "ipc/dds/map_snapshot.h"
#include "manager/manager_service.h"

namespace rumi {

// The map part of a snapshot (submaps, keyframes, the main component's
// points, the global trajectory, the counts in status) from a global map:
// the manager's after a rebuild, or one loaded from map.rumi (`rumi view`).
void FillMapSnapshot(const GlobalMap& map, MapSnapshot* s);

class SnapshotMaker {
 public:
  explicit SnapshotMaker(std::string instance) : instance_(std::move(instance)) {}
  // state: the manager's (running, rebuilding, done, stopping); status_json:
  // the status line rumi status shows for the manager.
  std::shared_ptr<const MapSnapshot> Make(const ManagerService& service, const std::string& state,
                                          const std::string& status_json);
  // The status alone, between snapshots (counts of the map from the last one).
  SnapshotStatus MakeStatus(const ManagerService& service, const std::string& state,
                            const std::string& status_json) const;

 private:
  std::string instance_;
  int64_t seq_ = 0;
  std::set<std::string> submaps_;
  std::set<std::pair<std::string, std::string>> merges_, rejections_;
  std::set<std::string> loops_;  // closed loops announced (query keyframe > match keyframe)
  int culled_ = -1;
  std::string last_save_;
  SnapshotStatus last_;  // of the last snapshot
};

// What the status topic's `json` holds: {"manager": manager_status} plus,
// under rumid, {"daemon": <state>/status.json} (what `rumi status` shows).
std::string StatusDetailJson(const ManagerService& service, const std::string& manager_status_json);
// The robot link's typed figures from that JSON (daemon.front.link); not
// present when there is no link (or the JSON is not what rumid writes).
SnapshotLink LinkFromStatusJson(const std::string& status_detail_json);

}  // namespace rumi
