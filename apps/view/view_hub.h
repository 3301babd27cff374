#pragma once
// What every open page is shown, held once: the feeds (the state folder,
// the manager over DDS) hand each new map, status and pose here once, and
// the hub turns them into the page's JSON and each stream's messages. Many
// tabs cost one snapshot per update, not one per tab. Nothing here blocks a
// feed: each stream has its own bounded queue (ClientQueue).
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "apps/view/client_queue.h"
#include "apps/view/top_view.h"
#include "apps/view/view_options.h"
#include "common/map_server_grid.h"
#include "common/run_metrics.h"
#include "ipc/dds/map_server.h"
#include "ipc/dds/map_snapshot.h"

namespace rumi {

struct ViewHubCounters {
  int64_t map_updates = 0, delta_bytes = 0, pose_messages = 0, file_messages = 0;
  int64_t clients = 0, refused_clients = 0, dropped = 0;  // dropped: of streams already closed
};

class ViewHub {
 public:
  explicit ViewHub(const ViewOptions& o) : options_(o), map_json_(TopViewDelta(TopView(), TopView()).dump()) {}

  // A new map (and the grid with it; grid.ok false: none). Streams get the
  // delta from the previous map.
  void SetMap(const MapSnapshot& map, const SnapshotGrid& grid);
  // status.json as rumid writes it (every second; a few KB): pages get it
  // whole, in /api/state and as the `status` event.
  void SetStatus(const nlohmann::json& status);
  // manager_stats.json at each save: pages get its summary (ManagerSummary)
  // in /api/state and as the `manager_stats` event; its reports, which grow
  // with the session, only whole at /api/manager_stats, when asked.
  void SetManagerStats(const nlohmann::json& stats);
  // front_frames.txt (the timeline of a folder, read again as it grows).
  // Streams get the change since the last timeline (TimelineDelta).
  void SetFrames(const std::vector<FrontFrameLine>& frames);
  // front_samples.txt: the frames the sampler sent the back, by window.
  void SetSamples(const std::vector<FrontSampleLine>& samples);
  // The manager's events (the DDS events topic): merges and closed loops are
  // drawn as links, the last ones listed.
  void AddEvents(const std::vector<SnapshotEvent>& events);
  // The live pose; at most view.pose_hz of them go out.
  void AddPose(const LivePose& pose);

  // GET /api/map: the whole top view (TopViewDelta from nothing).
  std::string MapJson();
  // GET /api/state: status, the manager's summary, the timeline so far (up
  // to the last pose's time) and its seq, the windows, the events and the
  // pose trail.
  std::string StateJson();
  // GET /api/timeline: {seq, timeline}, for a page whose timeline is not a
  // delta's base.
  std::string TimelineJson() const;
  // GET /api/manager_stats: manager_stats.json whole ({} before a save).
  std::string ManagerStatsJson() const;
  // Whether a page looked in the last `within_s` seconds: a stream is open,
  // or /api/map or /api/state was asked for (a still page, ?live=0).
  bool Watched(double within_s) const;
  // GET /api/grid: resolution, origin, size; GET /api/grid.pgm: the cells.
  std::string GridJson() const;
  std::string GridPgm() const;  // "" without a grid

  // A new live stream; nullptr with *why when view.max_clients are open or
  // the hub was closed.
  std::shared_ptr<ClientQueue> Subscribe(std::string* why);
  void Unsubscribe(const std::shared_ptr<ClientQueue>& q);
  // Ends every stream after what it holds, and takes no new one (the server
  // stops; a page's EventSource then stops asking).
  void CloseAll();
  ViewHubCounters counters() const;

 private:
  void Broadcast(const std::string& event, const std::string& data);  // mutex_ held
  std::string GridMeta() const;                                       // mutex_ held

  const ViewOptions options_;
  mutable std::mutex mutex_;
  TopView view_;
  std::string map_json_;
  SnapshotGrid grid_;
  std::optional<Sim3> S_gm_;
  nlohmann::json status_ = nlohmann::json::object();
  nlohmann::json manager_stats_ = nlohmann::json::object();  // whole
  nlohmann::json timeline_ = nlohmann::json::array();  // [t_s, state] at each change of state
  int64_t timeline_seq_ = 0;  // counts the timeline's changes: a delta's base
  nlohmann::json trail_ = nlohmann::json::array();     // [t_s, x, y, yaw] of the recent poses
  nlohmann::json windows_ = nlohmann::json::array();   // [id, first_s, last_s, S1, S2, S3] per window sent
  nlohmann::json events_ = nlohmann::json::array();    // [kind, submap, other, detail], the last kEvents
  double last_pose_s_ = -1e300;  // the last pose sent out
  double pose_t_ = 0;              // the last pose received (its capture time)
  std::chrono::steady_clock::time_point asked_;  // the last /api/map or /api/state
  std::vector<std::shared_ptr<ClientQueue>> clients_;
  bool closed_ = false;
  ViewHubCounters counters_;
};

// One server-sent event: "event: NAME\ndata: DATA\n\n".
std::string SseMessage(const std::string& event, const std::string& data);

// What the page shows of manager_stats.json: its top-level figures and
// words (merges, loop closures, components, the last save, ...), not its
// lists and tables (the merge reports, the loops, the components' submaps).
nlohmann::json ManagerSummary(const nlohmann::json& stats);

// The change from one timeline ([[t_s, state], ...]) to the next:
// {keep: how many entries of `from` stay, add: what follows them}. Applied
// (view.js): from.length = keep, then add appended.
nlohmann::json TimelineDelta(const nlohmann::json& from, const nlohmann::json& to);

}  // namespace rumi
