#include "apps/view/view_hub.h"

#include <algorithm>
#include <array>
#include <map>
#include <sstream>

namespace rumi {
namespace {

constexpr size_t kTrail = 600;  // poses kept for a page that opens late
constexpr size_t kEvents = 200;  // map events kept (every merge and loop of a long session: a few dozen)

// The timeline's words: LivePose numbers its states 0 initialising, 1 fine,
// 2 coarse, 3 lost; front_frames.txt by TrackingState.
const char* LiveStateName(int state) {
  switch (state) {
    case 1: return "tracking";
    case 2: return "coarse";
    case 3: return "lost";
    default: return "initializing";
  }
}

// Appends [t, state] when the state changed since the timeline's last
// entry; whether it did (view.js extends its copy from the poses alike).
bool Extend(nlohmann::json* timeline, double t, const std::string& state) {
  if (!timeline->empty() && timeline->back()[1] == state) return false;
  timeline->push_back({t, state});
  return true;
}

}  // namespace

std::string SseMessage(const std::string& event, const std::string& data) {
  return "event: " + event + "\ndata: " + data + "\n\n";
}

nlohmann::json ManagerSummary(const nlohmann::json& stats) {
  nlohmann::json summary = nlohmann::json::object();
  if (!stats.is_object()) return summary;
  for (const auto& [key, value] : stats.items())
    if (value.is_primitive()) summary[key] = value;
  return summary;
}

nlohmann::json TimelineDelta(const nlohmann::json& from, const nlohmann::json& to) {
  size_t keep = 0;
  while (keep < from.size() && keep < to.size() && from[keep] == to[keep]) ++keep;
  nlohmann::json add = nlohmann::json::array();
  for (size_t i = keep; i < to.size(); ++i) add.push_back(to[i]);
  return {{"keep", keep}, {"add", std::move(add)}};
}

void ViewHub::Broadcast(const std::string& event, const std::string& data) {
  const std::string m = SseMessage(event, data);
  for (const auto& q : clients_) q->Push(m);
}

void ViewHub::SetMap(const MapSnapshot& map, const SnapshotGrid& grid) {
  std::optional<Sim3> S_gm;
  if (grid.ok) S_gm = MapToGridFromYaml(grid.yaml);
  TopView truth = MakeTopView(map, S_gm, options_.cells_across);
  std::lock_guard<std::mutex> lock(mutex_);
  truth.seq = view_.seq + 1;  // the hub's own numbering: a page asks for a base it knows
  TopView next = ShownTopView(view_, truth, options_.move_tolerance_cells);
  const std::string delta = TopViewDelta(view_, next).dump();
  view_ = std::move(next);
  map_json_ = TopViewDelta(TopView(), view_).dump();
  // Pages fetch the grid's cells again only when they changed.
  const bool grid_changed = grid.ok != grid_.ok || grid.yaml != grid_.yaml || grid.cells.pixels != grid_.cells.pixels;
  grid_ = grid;
  S_gm_ = S_gm;
  ++counters_.map_updates;
  counters_.delta_bytes += static_cast<int64_t>(delta.size());
  Broadcast("map", delta);
  if (grid_changed) Broadcast("grid", GridMeta());
}

void ViewHub::SetStatus(const nlohmann::json& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status_ = status;
  ++counters_.file_messages;
  Broadcast("status", status_.dump());
}

void ViewHub::SetManagerStats(const nlohmann::json& stats) {
  const nlohmann::json summary = ManagerSummary(stats);
  std::lock_guard<std::mutex> lock(mutex_);
  manager_stats_ = stats;
  ++counters_.file_messages;
  Broadcast("manager_stats", summary.dump());
}

void ViewHub::SetFrames(const std::vector<FrontFrameLine>& frames) {
  nlohmann::json timeline = nlohmann::json::array();
  for (const FrontFrameLine& f : frames)
    if (!f.skipped) Extend(&timeline, NsToSeconds(f.t), ToString(f.state));
  if (!frames.empty()) timeline.push_back({NsToSeconds(frames.back().t), "end"});
  std::lock_guard<std::mutex> lock(mutex_);
  if (timeline == timeline_) return;
  nlohmann::json delta = TimelineDelta(timeline_, timeline);
  delta["base"] = timeline_seq_;
  delta["seq"] = ++timeline_seq_;
  timeline_ = std::move(timeline);
  Broadcast("timeline", delta.dump());
}

void ViewHub::SetSamples(const std::vector<FrontSampleLine>& samples) {
  std::map<int64_t, std::array<double, 5>> by_window;  // first, last, S1, S2, S3
  for (const FrontSampleLine& l : samples) {
    const double t = NsToSeconds(l.t);
    auto [it, fresh] = by_window.try_emplace(l.window_id, std::array<double, 5>{t, t, 0, 0, 0});
    it->second[0] = std::min(it->second[0], t);
    it->second[1] = std::max(it->second[1], t);
    if (l.set >= 1 && l.set <= 3) it->second[size_t(1 + l.set)] += 1;
  }
  nlohmann::json w = nlohmann::json::array();
  for (const auto& [id, a] : by_window) w.push_back({id, a[0], a[1], int(a[2]), int(a[3]), int(a[4])});
  std::lock_guard<std::mutex> lock(mutex_);
  if (w == windows_) return;
  windows_ = std::move(w);
  Broadcast("windows", windows_.dump());
}

void ViewHub::AddEvents(const std::vector<SnapshotEvent>& events) {
  if (events.empty()) return;
  nlohmann::json add = nlohmann::json::array();
  for (const SnapshotEvent& e : events) add.push_back({e.kind, e.submap, e.other, e.detail});
  std::lock_guard<std::mutex> lock(mutex_);
  events_.insert(events_.end(), add.begin(), add.end());
  if (events_.size() > kEvents) events_.erase(events_.begin(), events_.begin() + (events_.size() - kEvents));
  Broadcast("events", add.dump());
}

void ViewHub::AddPose(const LivePose& p) {
  const double t = NsToSeconds(p.timestamp);
  nlohmann::json j = {{"t", t}, {"state", LiveStateName(p.state)}, {"submap", p.submap}};
  std::lock_guard<std::mutex> lock(mutex_);
  pose_t_ = t;
  const bool state_changed = Extend(&timeline_, t, j["state"]);
  timeline_seq_ += state_changed;
  // A change of state always goes out (the timeline); otherwise pose_hz.
  if (!state_changed && t - last_pose_s_ < 1.0 / options_.pose_hz && t >= last_pose_s_) return;
  last_pose_s_ = t;
  if (p.in_global) {
    const Eigen::Vector3d pp = PlanePose(p.T_wc, S_gm_);
    j["x"] = pp.x();
    j["y"] = pp.y();
    j["yaw"] = pp.z();
    trail_.push_back({t, pp.x(), pp.y(), pp.z()});
    if (trail_.size() > kTrail) trail_.erase(trail_.begin(), trail_.begin() + (trail_.size() - kTrail));
  }
  ++counters_.pose_messages;
  Broadcast("pose", j.dump());
}

std::string ViewHub::MapJson() {
  std::lock_guard<std::mutex> lock(mutex_);
  asked_ = std::chrono::steady_clock::now();
  return map_json_;
}

std::string ViewHub::StateJson() {
  std::lock_guard<std::mutex> lock(mutex_);
  asked_ = std::chrono::steady_clock::now();
  const nlohmann::json state = {{"status", status_},
                                 {"manager_stats", ManagerSummary(manager_stats_)},
                                 {"timeline", timeline_},
                                 {"timeline_seq", timeline_seq_},
                                 {"pose_t", pose_t_},
                                 {"windows", windows_},
                                 {"events", events_},
                                 {"trail", trail_}};
  return state.dump();
}

std::string ViewHub::TimelineJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return nlohmann::json({{"seq", timeline_seq_}, {"timeline", timeline_}}).dump();
}

std::string ViewHub::ManagerStatsJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return manager_stats_.dump();
}

bool ViewHub::Watched(double within_s) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !clients_.empty() ||
         std::chrono::duration<double>(std::chrono::steady_clock::now() - asked_).count() < within_s;
}

std::string ViewHub::GridJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return GridMeta();
}

std::string ViewHub::GridMeta() const {
  if (!grid_.ok) return nlohmann::json({{"ok", false}}).dump();
  const MapServerGrid& g = grid_.cells;
  return nlohmann::json({{"ok", true},
                         {"resolution", g.resolution},
                         {"origin", {g.origin.x(), g.origin.y(), g.origin.z()}},
                         {"width", g.width},
                         {"height", g.height},
                         {"frame", S_gm_ ? "grid" : "map"}})
      .dump();
}

std::string ViewHub::GridPgm() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!grid_.ok) return "";
  const MapServerGrid& g = grid_.cells;
  std::ostringstream out;
  out << "P5\n" << g.width << " " << g.height << "\n255\n";
  out.write(reinterpret_cast<const char*>(g.pixels.data()), static_cast<std::streamsize>(g.pixels.size()));
  return out.str();
}

std::shared_ptr<ClientQueue> ViewHub::Subscribe(std::string* why) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_ || static_cast<int>(clients_.size()) >= options_.max_clients) {
    ++counters_.refused_clients;
    *why = closed_ ? "the view is stopping" : "too many live views open (view.max_clients)";
    return nullptr;
  }
  auto q = std::make_shared<ClientQueue>(static_cast<size_t>(options_.client_queue));
  clients_.push_back(q);
  ++counters_.clients;
  return q;
}

void ViewHub::Unsubscribe(const std::shared_ptr<ClientQueue>& q) {
  q->Close();
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = std::find(clients_.begin(), clients_.end(), q);
  if (it == clients_.end()) return;
  counters_.dropped += q->dropped();
  clients_.erase(it);
}

void ViewHub::CloseAll() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  for (const auto& q : clients_) q->Close();
}

ViewHubCounters ViewHub::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  ViewHubCounters c = counters_;
  for (const auto& q : clients_) c.dropped += q->dropped();
  return c;
}

}  // namespace rumi
