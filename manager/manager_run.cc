#include "manager/manager_run.h"

#include "ipc/dds/map_server.h"
#include "manager/map_snapshot_of.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <malloc.h>
#include <thread>

#include "common/process/exit_codes.h"
#include "common/process/notify.h"
#include "common/timestamp.h"
#include "ipc/channel_watch.h"
#include "ipc/dds/map_server.h"
#include "manager/map_snapshot_of.h"

namespace rumi {

const OptionSpec<ManagerLoopOptions>& ManagerLoopOptions::Spec() {
  using O = ManagerLoopOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("manager");
    s->Number("wait_for_producers_s", &O::wait_for_producers_s, AtLeast(0.0), AtMost(86400.0),
              "a producer not seen after this long counts as finished (0: wait forever)");
    s->Number("rebuild_interval_s", &O::rebuild_interval_s, AtLeast(0.0), AtMost(3600.0),
              "at most one global-map rebuild per this many seconds while submaps arrive");
    s->Number("rebuild_max_duty", &O::rebuild_max_duty, AtLeast(0.01), AtMost(1.0),
              "largest share of the time spent rebuilding");
    s->Number("stop_rebuild_max_s", &O::stop_rebuild_max_s, AtLeast(0.0), AtMost(3600.0),
              "on SIGTERM, rebuild once more only if the last rebuild took at most this long");
    s->Number("map_save_interval_s", &O::map_save_interval_s, AtLeast(0.0), AtMost(86400.0),
              "at least this long between two writes of map.rumi and map.rumi.raw while submaps arrive (the "
              "final save is always whole)");
    s->Number("map_save_max_duty", &O::map_save_max_duty, AtLeast(0.01), AtMost(1.0),
              "largest share of the time spent writing map.rumi and map.rumi.raw");
    s->Number("bake_after_s", &O::bake_after_s, AtLeast(0.0), AtMost(86400.0),
              "received submaps unchanged this long (and saved) are baked into the map's base and their raw "
              "copies let go (0: never)");
    return s;
  }();
  return *spec;
}

namespace {

struct Channel {
  SubmapSource source;
  SubmapReceiver rx;
  ProducerWatch watch;
  uint64_t decode_errors = 0;
  PopStatus last = PopStatus::kNotConnected;
  Channel(const char* what, const IpcOptions& o, SubmapSource s, double wait_s)
      : source(s), rx(o, s), watch(what, wait_s) {}
  bool ended(const ManagerRunOptions& run) const {
    const ProducerEnd e = watch.end();
    const bool finished = !run.finish || run.finish->load();
    // Under rumid, finish means the front and the back are done for good: a
    // channel with no segment left (closed, drained and removed before this
    // manager restarted) has nothing more to bring.
    const bool gone = run.finish && finished && last == PopStatus::kNotConnected;
    return ((e == ProducerEnd::kClosed || e == ProducerEnd::kNeverAppeared) && finished) || gone ||
           (e == ProducerEnd::kDied && run.producer_death_ends);
  }
};

// Polls one channel once. Returns true when a message arrived. With the
// journal, the ring slot is let go only once the submap is on disk.
bool PollChannel(Channel* c, ManagerService* service) {
  const uint64_t closed_before = c->rx.ring().closed_segments();
  Submap s;
  const bool hold = service->options().journal;
  const PopStatus st = c->rx.Receive(&s, 0.0, hold);
  if (c->rx.decode_errors() != c->decode_errors) {
    service->CountDecodeErrors(int64_t(c->rx.decode_errors() - c->decode_errors));
    c->decode_errors = c->rx.decode_errors();
  }
  c->watch.Update(c->rx.ring(), st, closed_before);
  c->last = st;
  if (st != PopStatus::kOk) return false;
  if (s.source != c->source) {
    spdlog::warn("manager: {} channel delivered a submap marked {}; taken as it is marked",
                 c->source == SubmapSource::kFront ? "front" : "back",
                 s.source == SubmapSource::kFront ? "front" : "back");
  }
  service->AddSubmap(std::move(s));  // refused ones are logged and counted there
  if (hold) c->rx.Release();
  return true;
}

nlohmann::json StatusJson(const ManagerService& service, const char* state) {
  const ManagerStats& st = service.stats();
  return {{"process", "manager"},
          {"state", state},
          {"submaps_front", st.submaps_front},
          {"submaps_back", st.submaps_back},
          {"components", st.components},
          {"merges", st.merges},
          {"loops", st.loops.closed},
          {"messages", st.messages_front + st.messages_back},
          {"rebuilds", st.rebuilds},
          {"last_rebuild_s", st.last_rebuild_seconds},
          {"trajectory_frames", st.trajectory_frames},
          {"keyframes", st.saved_frames_postculled},
          {"last_save", st.last_save}};
}

// Forwards the front's newest frame pose (the poses ring) to the DDS server
// every few milliseconds, in a thread of its own: the merge loop's rebuilds
// take seconds and must not hold the live pose back.
class PoseForwarder {
 public:
  PoseForwarder(const IpcOptions& ipc, MapServer* server) : rx_(ipc), server_(server) {
    thread_ = std::thread([this] { Loop(); });
  }
  ~PoseForwarder() {
    stop_ = true;
    thread_.join();
  }

 private:
  void Loop() {
    Timestamp last = -1;
    while (!stop_) {
      FramePose p;
      if (rx_.ReceiveNewest(&p) == PopStatus::kOk && p.timestamp != last) {
        last = p.timestamp;
        LivePose live;
        live.timestamp = p.timestamp;
        live.state = p.state == TrackingState::kTracking ? 1
                     : p.state == TrackingState::kCoarse ? 2
                     : p.state == TrackingState::kLost   ? 3
                                                         : 0;
        if (p.submap_id >= 0) live.submap = ToString(SubmapKey{SubmapSource::kFront, p.submap_id});
        live.T_wc = p.T_wc;
        server_->PublishPose(live);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  PoseReceiver rx_;
  MapServer* server_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace

namespace {
// Not before `interval_s`, nor before `last_s * (1 / max_duty - 1)`.
bool DutyDue(double interval_s, double max_duty, double since_last_s, double last_s) {
  const double duty = std::clamp(max_duty, 1e-3, 1.0);
  return since_last_s >= std::max(interval_s, last_s * (1.0 / duty - 1.0));
}
}  // namespace

bool RebuildDue(const ManagerLoopOptions& loop, double since_last_s, double last_rebuild_s) {
  return DutyDue(loop.rebuild_interval_s, loop.rebuild_max_duty, since_last_s, last_rebuild_s);
}

bool MapSaveDue(const ManagerLoopOptions& loop, double since_last_s, double last_save_s) {
  return DutyDue(loop.map_save_interval_s, loop.map_save_max_duty, since_last_s, last_save_s);
}

ManagerExit RunManagerLoop(const ManagerRunOptions& run, ManagerService* service, const std::atomic<bool>* stop,
                           MapServer* server) {
  const auto start = std::chrono::steady_clock::now();
  SnapshotMaker snapshots(run.ipc.instance);
  const auto detail = [&](const char* state) { return StatusDetailJson(*service, StatusJson(*service, state).dump()); };
  const auto publish = [&](const char* state) {
    if (server) server->Publish(snapshots.Make(*service, state, detail(state)));
  };
  // Between snapshots the status alone, every second (rumid's status changes too).
  auto last_status = std::chrono::steady_clock::now();
  const auto publish_status = [&](const char* state) {
    if (!server || SecondsSince(last_status) < 1.0) return;
    last_status = std::chrono::steady_clock::now();
    server->PublishStatus(snapshots.MakeStatus(*service, state, detail(state)));
  };
  publish("running");
  Channel front("front submap", run.ipc, SubmapSource::kFront, run.loop.wait_for_producers_s);
  Channel back("back submap", run.ipc, SubmapSource::kBack, run.loop.wait_for_producers_s);
  Notifier notifier;
  notifier.Ready();
  MapNoticeSender notices(run.ipc);  // tells the front what the map holds (halt/resume)
  auto last_rebuild = start - std::chrono::hours(1);
  auto last_bake_check = start;
  ManagerExit result = ManagerExit::kProducersDone;
  std::string why;
  // cancel: the stop flag while the loop runs (a rebuild on SIGTERM is
  // abandoned whole); none for the final one.
  const auto rebuild = [&](const std::atomic<bool>* cancel, bool map_files) {
    spdlog::info("manager: rebuild {} starting", service->stats().rebuilds + 1);
    notifier.Heartbeat(StatusJson(*service, "rebuilding"), /*force=*/true);
    // The front hears of the new map before it is saved: a halted robot
    // waits for the merge, not for the disk (nor for a save that fails).
    const bool ok = service->Rebuild(&why, cancel, [&] {
      MapNotice n;
      n.front_submap_upto = service->stats().front_submap_upto;
      n.front_submap_end = service->stats().front_submap_upto_end;
      n.components = service->stats().components;
      n.t = WallNowNs();
      notices.Send(n);
    }, map_files);
    last_rebuild = std::chrono::steady_clock::now();
    publish("running");
    if (ok) return true;
    if (stop && stop->load()) spdlog::info("manager: {}", why);  // nothing was changed
    else spdlog::error("manager: {}", why);
    return false;
  };
  for (;;) {
    if (stop && stop->load()) {
      spdlog::info("manager: stop requested");
      result = ManagerExit::kStopped;
      break;
    }
    bool got = false;
    // Finished channels are polled too: a restarted producer is read again.
    for (Channel* c : {&front, &back}) got |= PollChannel(c, service);
    if (front.ended(run) && back.ended(run)) break;
    const bool map_save_due =
        MapSaveDue(run.loop, service->SecondsSinceMapSave(), service->stats().last_map_save_seconds);
    if (service->dirty() && !got &&
        RebuildDue(run.loop, SecondsSince(last_rebuild), service->stats().last_rebuild_seconds)) {
      // Rebuild once the burst is read (got == false: the rings are empty now).
      // A rebuild that cannot save is logged; the loop goes on, nothing received is dropped.
      rebuild(stop, map_save_due);
    } else if (service->map_files_pending() && !service->dirty() && !service->unsaved() && !got && map_save_due) {
      // Submaps stopped arriving: the map file catches up with the map.
      if (!service->WriteOutputs(&why)) spdlog::error("manager: {}", why);
      last_rebuild = std::chrono::steady_clock::now();
      // A rebuild frees a whole copy of the map in small blocks, which glibc
      // keeps in its heaps: while idle, give them back (RSS 2.1 -> 1.2 GiB at
      // 50 submaps). Not after every rebuild: the next one would fault them
      // in again (+3 s at 50 submaps).
      malloc_trim(0);
    } else if (service->unsaved() && !got && SecondsSince(last_rebuild) >= std::max(10.0, run.loop.rebuild_interval_s)) {
      // A full disk: try again every 10 s, not every turn.
      last_rebuild = std::chrono::steady_clock::now();
      if (!service->WriteOutputs(&why)) spdlog::error("manager: still cannot save: {}", why);
    }
    if (!got && SecondsSince(last_bake_check) >= 1.0) {
      last_bake_check = std::chrono::steady_clock::now();
      if (service->BakeSettled(run.loop.bake_after_s) > 0) malloc_trim(0);  // the raw copies' blocks
    }
    notifier.Heartbeat(StatusJson(*service, "idle"));
    publish_status("running");
    if (!got) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // Under rumid (finish) a restarted manager may see no producer at all: an
  // earlier one took what they sent (the journal has it). That is done.
  if (!run.finish && !front.watch.seen() && !back.watch.seen() && result == ManagerExit::kProducersDone)
    result = ManagerExit::kNoProducer;
  if (result == ManagerExit::kStopped) {
    // What the producers sent before they stopped (rumid stops them first).
    const auto drain_start = std::chrono::steady_clock::now();
    while (SecondsSince(drain_start) < 1.0 && (PollChannel(&front, service) || PollChannel(&back, service))) {
    }
  }
  notifier.Stopping();
  const bool quick = service->stats().last_rebuild_seconds <= run.loop.stop_rebuild_max_s;
  if (service->dirty() && (result != ManagerExit::kStopped || quick)) {
    // The whole save follows.
    if (!rebuild(nullptr, /*map_files=*/false)) return ManagerExit::kError;
  } else if (service->dirty()) {
    spdlog::info("manager: last rebuild took {:.1f} s: saving the received submaps, the next start rebuilds",
                 service->stats().last_rebuild_seconds);
  }
  // Under rumid the journal holds every submap received since the last
  // whole save: a stop need not wait for the big files when they are slow to
  // write (the next start reloads the journal and rebuilds).
  const bool whole = !(result == ManagerExit::kStopped && run.service.journal &&
                       service->stats().last_map_save_seconds > run.loop.stop_rebuild_max_s);
  if (!whole && service->map_files_pending())
    spdlog::info("manager: the last map save took {:.1f} s: stopping without one, the journal keeps what arrived "
                 "since; the next start rebuilds",
                 service->stats().last_map_save_seconds);
  if (!service->WriteOutputs(&why, whole)) {
    spdlog::error("manager: {}", why);
    return ManagerExit::kError;
  }
  publish(result == ManagerExit::kStopped ? "stopped" : "done");
  const ManagerStats& st = service->stats();
  spdlog::info("manager: done: {} front + {} back submaps ({} messages, {} resends, {} malformed), {} merges, "
               "{} components, {} frames in merged.txt, keyframes {} -> {}",
               st.submaps_front, st.submaps_back, st.messages_front + st.messages_back, st.resends,
               st.decode_errors, st.merges, st.components, st.trajectory_frames, st.saved_frames,
               st.saved_frames_postculled);
  return result;
}

int RunManager(const ManagerRunOptions& run, const std::atomic<bool>* stop) {
  ManagerService service(run.service);
  std::string why;
  if (!service.Start(&why)) {
    spdlog::error("manager: {}", why);
    return kExitError;
  }
  spdlog::info("manager: instance {}, out {}, map {}{}", run.ipc.instance, run.service.out_dir,
               run.service.MapPath(), run.service.journal ? ", journal on" : "");
  std::unique_ptr<MapServer> server;
  if (run.dds.enabled) {
    server = MapServer::Start(run.dds, run.ipc.instance, &why);
    if (!server) spdlog::error("manager: the map is not served over DDS: {}", why);
  }
  std::unique_ptr<PoseForwarder> poses;
  if (server) poses = std::make_unique<PoseForwarder>(run.ipc, server.get());
  try {
    switch (RunManagerLoop(run, &service, stop, server.get())) {
      case ManagerExit::kProducersDone:
        return kExitDone;
      case ManagerExit::kStopped:
        return kExitStopped;
      case ManagerExit::kNoProducer:
        spdlog::error("manager: no producer appeared within {} s", run.loop.wait_for_producers_s);
        return kExitNoProducer;
      case ManagerExit::kError:
        return kExitError;
    }
  } catch (const std::exception& e) {  // IpcError and the like: name it, do not abort
    spdlog::error("manager: {}", e.what());
  }
  return kExitError;
}

}  // namespace rumi
