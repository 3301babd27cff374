#pragma once
// rumid: runs rumi-front, rumi-back and rumi-manager for one configured
// source and keeps them running (docs/daemon.md).
//
// Start: the state folder is locked (one rumid per folder), stale
// shared-memory segments of dead instances are removed, the manager starts
// (it reloads the saved map and the submaps it had received), then the back,
// then the front on the source. READY=1 goes to systemd once all three said
// READY. A crashed child is restarted with backoff (Supervisor): a restarted
// front starts a new submap (fresh ids) where the stream is now, a restarted
// back retries the window it was on once, a restarted manager reloads the map.
// A crash loop, or a child that rejects its config, stops the daemon with an
// error. WATCHDOG=1 goes to systemd every WatchdogSec/2 while every child is
// alive and the manager's loop turned within daemon.manager_stall_s; STATUS=
// carries a one-line summary; status.json the whole picture (`rumi status`).
//
// SIGTERM/SIGINT: STOPPING=1, then the front (no more frames), the back
// (its COLMAP step cancelled) and the manager (final atomic save) are
// stopped in turn within daemon.stop_timeout_s; the instance's segments are
// removed; exit 0. A second signal kills at once. SIGHUP: the config is read
// again, the log level applied here and in the children.
//
// A finite source (a dataset without loop, a video file) ends the session:
// the front exits at its end, the back builds what it has, the manager saves,
// and rumid exits 0.
#include <atomic>
#include <string>

#include "apps/config/rumi_config.h"

namespace rumi {

struct DaemonRunOptions {
  RumiConfig config;
  std::string config_path;  // handed to the children
  std::string instance;     // resolved (command line, config, config file name)
  std::string state_dir;    // resolved
  std::string bin_dir;      // resolved: where rumi-front/back/manager are
  // config.source came from the command line (--dataset), not the file: the
  // front gets it on its command line too.
  bool source_overridden = false;
};

// Returns the exit code (common/process/exit_codes.h).
// *forward_hangup (optional) is set after rumid re-read its config on SIGHUP:
// the daemon forwards SIGHUP to the children and lowers it.
int RunDaemon(const DaemonRunOptions& o, const std::atomic<bool>* stop, std::atomic<bool>* forward_hangup);

}  // namespace rumi
