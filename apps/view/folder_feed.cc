#include "apps/view/folder_feed.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <functional>

#include "common/atomic_file.h"
#include "ipc/daemon_status.h"
#include "manager/grid/grid_file.h"
#include "manager/map_file.h"
#include "manager/map_snapshot_of.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;
}  // namespace

FolderFeed::FolderFeed(std::string dir, std::shared_ptr<ViewHub> hub, bool read_map)
    : dir_(std::move(dir)), hub_(std::move(hub)), read_map_(read_map) {}

FolderFeed::~FolderFeed() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

bool FolderFeed::Changed(const fs::path& p) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(p, ec);
  if (ec) return false;
  const fs::file_time_type t = fs::last_write_time(p, ec);
  if (ec) return false;
  auto& seen = seen_[p.string()];
  if (seen.first == size && seen.second == t) return false;
  seen = {size, t};
  return true;
}

bool FolderFeed::Poll(std::string* why) {
  const fs::path dir = dir_;
  bool ok = true;
  auto fail = [&](const std::string& w) {
    ok = false;
    if (why) *why = w;
  };
  if (Changed(dir / "status.json")) {
    nlohmann::json st;
    std::string w;
    if (ReadDaemonStatus(dir_, &st, &w))
      hub_->SetStatus(st);
    else
      fail(w);
  }
  // The manager's counts at its last save (merges, loops): what a saved
  // session says of itself, without the DDS events.
  if (Changed(dir / "manager_stats.json")) {
    std::string text, w;
    const nlohmann::json stats =
        ReadFileText((dir / "manager_stats.json").string(), &text, &w) ? nlohmann::json::parse(text, nullptr, false)
                                                                       : nlohmann::json();
    if (stats.is_object())
      hub_->SetManagerStats(stats);
    else
      seen_.erase((dir / "manager_stats.json").string());  // being replaced: next time
  }
  // The map and its grid go together: the grid is drawn in the map's plane.
  const bool grid_changed = Changed(dir / "grid.yaml");
  if (read_map_ && (Changed(dir / "map.rumi") || grid_changed)) {
    GlobalMap map;
    std::string w;
    if (LoadGlobalMap((dir / "map.rumi").string(), &map, &w)) {
      MapSnapshot s;
      FillMapSnapshot(map, &s);
      SnapshotGrid g;
      g.ok = ReadFileText((dir / "grid.yaml").string(), &g.yaml, &w) &&
             ReadMapServerGrid((dir / "grid.yaml").string(), &g.cells, &w);
      hub_->SetMap(s, g);
    } else {
      seen_.erase((dir / "map.rumi").string());  // a save in progress: read it next time
      fail(w);
    }
  }
  // rumid's front writes front/; a run folder of `rumi eval run` has them at the top.
  const auto front_file = [&](const char* name) {
    return fs::exists(dir / "front" / name) ? dir / "front" / name : dir / name;
  };
  // A line being written does not parse: read the file again next time.
  const auto read = [&](const fs::path& p, const std::function<void()>& hand_over) {
    try {
      hand_over();
    } catch (const std::exception& e) {
      seen_.erase(p.string());
      fail(e.what());
    }
  };
  const fs::path frames = front_file("front_frames.txt"), samples = front_file("front_samples.txt");
  if (read_map_ && Changed(frames))  // live: the timeline grows from the pose stream
    read(frames, [&] { hub_->SetFrames(ReadFrontFrames(frames.string())); });
  if (Changed(samples)) read(samples, [&] { hub_->SetSamples(ReadFrontSamples(samples.string())); });
  return ok;
}

void FolderFeed::Start(double interval_s) {
  thread_ = std::thread([this, interval_s] {
    std::string last_why;
    while (!stop_) {
      std::string why;
      if (!Poll(&why) && why != last_why) spdlog::warn("view: {}", why);
      last_why = why;
      for (double t = 0; t < interval_s && !stop_; t += 0.05)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
}

}  // namespace rumi
