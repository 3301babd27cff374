#pragma once
// rumi-merge-replay --session-bench (apps/merge_replay_main.cc): a live
// session replayed from its saved submaps. They go to a ManagerService (the
// manager process's core) one by one in the order they ended (with resends,
// also each front submap cut as the front resends it while it grows), with a
// rebuild after every N, and each rebuild prints its time per phase and the
// process's resident memory: a benchmark of how the manager scales with a
// long session, without the hour it took.
#include <string>

#include "manager/global_map.h"
#include "manager/manager_run.h"
#include "manager/manager_service.h"

namespace rumi {

struct SessionReplayOptions {
  ManagerServiceOptions service;   // manager:, grid: and out_dir (its map files are removed first)
  ManagerLoopOptions loop;         // when the map files are saved (MapSaveDue), as the manager's loop does
  int rebuild_every = 1;           // rebuild after every N submaps received
  // > 0: each front submap is also sent cut every resend_interval_s of its
  // time once it has resend_min_keyframes (what the front's publisher does
  // while it tracks: front.publisher.resend_*); 0: finished submaps only.
  double resend_interval_s = 0;
  int resend_min_keyframes = 5;
  // Bake every settled submap into the base after each rebuild (the map
  // files saved first): the incremental manager at its most eager, as if
  // manager.bake_after_s had passed for all but the newest front submap.
  bool bake = false;
};

// Prints a header and one tab-separated line per rebuild on stdout. False
// with *why when the service cannot start, rebuild or save.
bool ReplaySession(const GlobalMap& raw, const SessionReplayOptions& o, std::string* why);

}  // namespace rumi
