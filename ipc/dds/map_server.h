#pragma once
// rumi-manager's DDS side (docs/dds.md): a thread with its own participant
// that publishes the state topics (status, grid, events; with ros2_compat
// also rt/<prefix>/map, path, points, pose) whenever the manager hands over
// a new snapshot, and answers requests from the latest snapshot. The manager
// never waits on DDS: Publish swaps a pointer and wakes the thread; replies
// to a slow client block at most dds.reply_block_s per chunk, in this thread.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "ipc/dds/dds_entity.h"
#include "ipc/dds/dds_options.h"
#include "ipc/dds/map_snapshot.h"
#include "rumi_map.h"  // idlc, from rumi_map.idl

namespace rumi {

// The live camera pose (the pose topic).
struct LivePose {
  Timestamp timestamp = 0;
  int state = 0;  // 0 initialising, 1 fine, 2 coarse, 3 lost
  std::string submap;
  bool in_global = false;
  Se3 T_wc;
};

struct MapServerCounters {
  int64_t requests = 0, bad_requests = 0, replies = 0, chunks = 0;
  int64_t write_failures = 0;  // chunk writes that timed out (a slow or vanished client)
  int64_t snapshots = 0;
};

class MapServer {
 public:
  // Creates the participant, topics and thread; nullptr with *why when DDS
  // cannot start (the manager then runs without serving the map).
  static std::unique_ptr<MapServer> Start(const DdsOptions& o, const std::string& instance, std::string* why);
  ~MapServer();

  void Publish(std::shared_ptr<const MapSnapshot> snapshot);
  // A status between snapshots (state changes, the daemon's status):
  // published on the status topic and answered to status requests.
  void PublishStatus(const SnapshotStatus& status);
  // Best effort, never blocks. A pose in a front submap's frame goes out in
  // the global frame when the latest snapshot has that submap in the main
  // component (in_global), else as it is.
  void PublishPose(const LivePose& pose);
  MapServerCounters counters() const;

 private:
  MapServer(const DdsOptions& o, std::string instance);
  bool Open(std::string* why);
  void Loop();
  void PublishState(const MapSnapshot& s);
  void PublishRos(const MapSnapshot& s);
  void Answer(const rumi_dds_Request& r);

  DdsOptions options_;
  std::string instance_;
  DdsEntity participant_;
  dds_entity_t status_w_ = 0, pose_w_ = 0, events_w_ = 0, grid_w_ = 0, reply_w_ = 0, request_r_ = 0;
  dds_entity_t ros_map_w_ = 0, ros_path_w_ = 0, ros_points_w_ = 0, ros_pose_w_ = 0;
  dds_entity_t waitset_ = 0, request_cond_ = 0, wake_ = 0;
  int64_t event_seq_ = 0;
  bool big_grid_said_ = false;  // the grid outgrew the grid topics (logged once)

  mutable std::mutex mutex_;
  std::shared_ptr<const MapSnapshot> latest_;  // guarded by mutex_
  bool fresh_ = false;                         // latest_ not published yet
  SnapshotStatus status_;                      // the newest status, guarded by mutex_
  bool status_fresh_ = false;
  MapServerCounters counters_;                 // guarded by mutex_
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace rumi
