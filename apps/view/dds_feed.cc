#include "apps/view/dds_feed.h"

#include <chrono>

#include "ipc/dds/map_client.h"

namespace rumi {
namespace {

constexpr double kConnectS = 2.0, kCallS = 5.0;  // bounds a stop too

void Nap(const std::atomic<bool>& stop, double s) {
  for (double t = 0; t < s && !stop; t += 0.05) std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

// One call; false on a time out or a refusal (nothing to serve yet).
bool Ask(MapClient* c, int32_t kind, int64_t page, MapReply* r) {
  rumi_dds_Request q{};
  q.kind = kind;
  q.page = page;
  q.submap = const_cast<char*>("");
  std::string why;
  return c->Call(q, kCallS, r, &why) && r->code == rumi_dds_CODE_OK;
}

// The map of one rebuild: every page of points of one map version, the
// keyframes, the submaps and the grid. False when the map changed under it
// (the next status asks again) or the manager did not answer.
bool FetchMap(MapClient* c, MapSnapshot* s, SnapshotGrid* g) {
  MapReply r;
  if (!Ask(c, rumi_dds_KIND_POINTS, 0, &r)) return false;
  const int64_t seq = r.map_seq;
  s->seq = seq;
  s->points = std::move(r.points);
  for (int64_t page = 1, pages = r.pages; page < pages; ++page) {
    MapReply p;
    if (!Ask(c, rumi_dds_KIND_POINTS, page, &p) || p.map_seq != seq) return false;
    s->points.insert(s->points.end(), p.points.begin(), p.points.end());
  }
  MapReply k, m;
  if (!Ask(c, rumi_dds_KIND_KEYFRAMES, 0, &k) || !Ask(c, rumi_dds_KIND_SUBMAP, 0, &m)) return false;
  if (k.map_seq != seq || m.map_seq != seq) return false;
  s->keyframes = std::move(k.keyframes);
  s->submaps = std::move(m.submaps);
  MapReply gr;
  if (Ask(c, rumi_dds_KIND_GRID, 0, &gr)) *g = gr.grid;  // none yet: UNAVAILABLE
  g->ok = g->cells.width > 0;
  return true;
}

}  // namespace

DdsFeed::DdsFeed(const DdsOptions& dds, std::string instance, std::shared_ptr<ViewHub> hub)
    : dds_(dds), instance_(std::move(instance)), hub_(std::move(hub)) {}

DdsFeed::~DdsFeed() {
  stop_ = true;
  if (pose_thread_.joinable()) pose_thread_.join();
  if (map_thread_.joinable()) map_thread_.join();
}

void DdsFeed::Start() {
  pose_thread_ = std::thread([this] { FollowPoses(); });
  map_thread_ = std::thread([this] { FollowMap(); });
}

// Each thread has its own client (participant): a long map fetch never
// holds up the pose.
void DdsFeed::FollowPoses() {
  std::unique_ptr<MapClient> c;
  while (!stop_) {
    std::string why;
    if (!c) c = MapClient::Connect(dds_, instance_, kConnectS, &why);
    if (!c) {
      Nap(stop_, 1.0);
      continue;
    }
    // Returns at a stop, or when no pose came for a while (the front is
    // restarting, or the session ended): follow again.
    c->FollowPose(kConnectS, [this](const LivePose& p) {
      hub_->AddPose(p);
      return !stop_.load();
    });
  }
}

void DdsFeed::FollowMap() {
  int64_t shown = -1;  // the rebuild shown
  // With no page looking (no stream, no request for a minute), the map is
  // fetched at most every 30 s: a page that opens gets one that recent at
  // once, and the next rebuild's within a second; the manager serves little
  // for a view nobody looks at.
  constexpr double kUnwatchedS = 30, kLookedS = 60;
  auto last = std::chrono::steady_clock::now() - std::chrono::hours(1);
  std::unique_ptr<MapClient> c;
  while (!stop_) {
    std::string why;
    if (!c) c = MapClient::Connect(dds_, instance_, kConnectS, &why);
    SnapshotStatus st;
    if (c) hub_->AddEvents(c->TakeEvents());
    if (!c || !c->LatestStatus(kConnectS, &st, &why)) {
      c.reset();
      Nap(stop_, 1.0);
      continue;
    }
    const bool watched = hub_->Watched(kLookedS) ||
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - last).count() >= kUnwatchedS;
    if (st.rebuilds != shown && st.keyframes > 0 && watched) {
      MapSnapshot s;
      SnapshotGrid g;
      if (FetchMap(c.get(), &s, &g)) {
        hub_->SetMap(s, g);
        shown = st.rebuilds;
        last = std::chrono::steady_clock::now();
      }
    }
    Nap(stop_, 0.5);
  }
}

}  // namespace rumi
