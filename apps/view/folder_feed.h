#pragma once
// Feeds a ViewHub from a state folder: map.rumi, grid.yaml/.pgm,
// status.json, manager_stats.json, front_frames.txt and front_samples.txt,
// each read again when it changed (its size or time). `rumi view STATE_DIR` shows a finished session this way;
// rumid's view reads its own folder for the daemon's status and, without
// DDS, for the map (at each of the manager's saves).
#include <atomic>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include "apps/view/view_hub.h"

namespace rumi {

class FolderFeed {
 public:
  // read_map false: the map comes from elsewhere (the manager over DDS).
  FolderFeed(std::string dir, std::shared_ptr<ViewHub> hub, bool read_map);
  ~FolderFeed();  // stops the thread
  // One look: what changed since the last hands the hub its new version.
  // False with *why when a file that changed could not be read (the hub keeps
  // what it had; the next look tries again).
  bool Poll(std::string* why);
  // Polls every interval_s on a thread of its own until destroyed.
  void Start(double interval_s);

 private:
  bool Changed(const std::filesystem::path& p);

  const std::string dir_;
  const std::shared_ptr<ViewHub> hub_;
  const bool read_map_;
  std::map<std::string, std::pair<uintmax_t, std::filesystem::file_time_type>> seen_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace rumi
