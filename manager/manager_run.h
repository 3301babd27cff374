#pragma once
// rumi-manager as a process (`rumi-manager --instance ID --out DIR`,
// docs/manager.md): front and back submaps from the instance's channels into
// the global map. rumi-manager's main, `rumi eval run` and rumid all run it
// through RunManager.
#include <atomic>

#include "common/option_spec.h"
#include "ipc/channels.h"
#include "ipc/dds/dds_options.h"
#include "manager/manager_service.h"

namespace rumi {

// The keys of `manager:` that drive the process loop (ManagerOptions holds
// the merge ones).
struct ManagerLoopOptions {
  // A channel whose producer has not appeared after this long counts as
  // finished (0: wait forever).
  double wait_for_producers_s = 0;
  // At most one rebuild per this many seconds while submaps keep arriving;
  // the final one runs at exit regardless.
  double rebuild_interval_s = 1.0;
  // A rebuild costs more as the map collects submaps (culling, and merges
  // of changed submaps: merge_benchmark BM_RebuildSession). After a rebuild
  // of T s the next one waits at least T (1 / duty - 1) s (0.5: as long
  // again), so rebuilding takes at most this share of the time: the realtime
  // front shares the cores.
  double rebuild_max_duty = 0.5;
  // On SIGTERM the final rebuild runs only when the last one took at most
  // this long; otherwise the received submaps are saved as they are and the
  // next start rebuilds (a stop stays within rumid's stop timeout).
  double stop_rebuild_max_s = 4.0;
  // The map file and the raw submaps (map.rumi, map.rumi.raw) are rewritten
  // whole, which grows with the session (15 s for both at 50 submaps,
  // docs/results/2026-11-25-manager-session.md): a rebuild writes them only
  // when this long has passed since the last time, and when that is at
  // least the last write's duration times (1 / map_save_max_duty - 1). The
  // trajectories, grid and stats are written after every rebuild, and the
  // final save (exit, stop) is always whole. Nothing received is at risk in
  // between: rumid's journal holds every submap from the moment it arrives.
  double map_save_interval_s = 30.0;
  double map_save_max_duty = 0.1;
  // Received submaps unchanged for this long (and saved in the map file)
  // are baked into the base in their merged, culled form and their raw
  // copies let go (ManagerService::BakeSettled): a session's memory then
  // follows the mapped place, not the session's length. Longer than a back
  // window takes to arrive, so most windows pair with the front submaps
  // before they are culled. 0: never (every received submap stays raw, as
  // an evaluation wants).
  double bake_after_s = 300.0;
  static const OptionSpec<ManagerLoopOptions>& Spec();
};

struct ManagerRunOptions {
  ManagerServiceOptions service;
  ManagerLoopOptions loop;
  IpcOptions ipc;
  DdsOptions dds;  // enabled: the map is served over DDS (docs/dds.md)
  // `rumi eval run`: a producer that died is finished. rumid: it is
  // restarted, so the manager waits for it.
  bool producer_death_ends = true;
  // rumid: closed channels end the manager only once this is set (SIGUSR1:
  // the source ended and the back finished); nullptr: closed channels end it.
  const std::atomic<bool>* finish = nullptr;
};

// Whether a rebuild may start `since_last_s` after the last one ended, which
// took `last_rebuild_s`: not before rebuild_interval_s, and not before
// last_rebuild_s * (1 / rebuild_max_duty - 1).
bool RebuildDue(const ManagerLoopOptions& loop, double since_last_s, double last_rebuild_s);
// Whether a rebuild writes the map file and the raw submaps too, the last
// write of them having ended `since_last_s` ago and taken `last_save_s`.
bool MapSaveDue(const ManagerLoopOptions& loop, double since_last_s, double last_save_s);

enum class ManagerExit { kProducersDone, kStopped, kNoProducer, kError };

// Consumes the instance's front and back submap channels until both
// producers closed them (or died, with producer_death_ends, or never
// appeared within wait_for_producers_s) and the rings are drained, or *stop
// is set. Rebuilds as submaps arrive (rate-limited) and once more at the end;
// reports its status (notify: a heartbeat per loop turn).
// With a server, a snapshot of the map goes to it after every rebuild and at
// the end (it never waits on DDS).
class MapServer;
ManagerExit RunManagerLoop(const ManagerRunOptions& run, ManagerService* service, const std::atomic<bool>* stop,
                           MapServer* server = nullptr);

// The whole process: starts the service (reloads the map) and, with
// dds.enabled, the DDS server (a server that cannot start is logged, and the
// manager runs on without it), then runs the loop.
// Returns the exit code (common/process/exit_codes.h).
int RunManager(const ManagerRunOptions& run, const std::atomic<bool>* stop);

}  // namespace rumi
