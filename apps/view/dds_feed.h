#pragma once
// Feeds a ViewHub from rumi-manager over DDS (docs/dds.md), as any other
// client of the map service: the live pose (the pose topic) as it comes,
// the map's events (merges, loops), and the map (points, keyframes,
// submaps, grid) fetched once each time the status topic says the manager
// rebuilt, whatever the number of pages open.
// The manager never waits on it: its server answers from its last snapshot.
#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "apps/view/view_hub.h"
#include "ipc/dds/dds_options.h"

namespace rumi {

class DdsFeed {
 public:
  DdsFeed(const DdsOptions& dds, std::string instance, std::shared_ptr<ViewHub> hub);
  ~DdsFeed();  // stops both threads (each waits at most a few seconds on DDS)
  void Start();

 private:
  void FollowPoses();
  void FollowMap();

  const DdsOptions dds_;
  const std::string instance_;
  const std::shared_ptr<ViewHub> hub_;
  std::atomic<bool> stop_{false};
  std::thread pose_thread_, map_thread_;
};

}  // namespace rumi
