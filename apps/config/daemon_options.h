#pragma once
// Options of rumid, the supervisor (config section `daemon:`).
#include <string>

#include "common/option_spec.h"

namespace rumi {

struct DaemonOptions {
  // The instance: shared-memory names, the notify socket, the default state
  // folder. Several instances (robots) run side by side. The command line's
  // --instance wins; "" = the config file's name without .yaml.
  std::string instance;
  // Where the map, the received submaps, the trajectories, the status and
  // the children's logs live. "" = $STATE_DIRECTORY (systemd's StateDirectory=)
  // or /var/lib/rumi/<instance>.
  std::string state_dir;
  // Folder of rumi-front, rumi-back and rumi-manager; "" = rumid's own folder.
  std::string bin_dir;
  // journal: the children write to rumid's stderr (systemd's journal);
  // files: state_dir/logs/<child>.log.
  std::string child_output = "journal";
  // SIGTERM/SIGINT: everything has stopped (front, back, manager in turn,
  // final save) within this many seconds, or what is left is killed.
  double stop_timeout_s = 10.0;
  // Restarts: a crashed child starts again after restart_backoff_initial_s,
  // doubling up to restart_backoff_max_s; more than crash_loop_restarts
  // crashes within crash_loop_window_s give up on it (rumid then exits with
  // an error, and systemd's Restart= decides).
  double restart_backoff_initial_s = 0.5;
  double restart_backoff_max_s = 30.0;
  int crash_loop_restarts = 5;
  double crash_loop_window_s = 120.0;
  // A running child that sent no heartbeat for this long is stalled
  // (stopped, deadlocked): rumid kills it and restarts it as after a crash,
  // with or without systemd. The manager's loop beats between rebuilds (a
  // rebuild blocks it), and rumid sends WATCHDOG=1 to systemd only while the
  // manager's beat is younger than manager_stall_s. The front and the back
  // beat from a thread of their own; the back's may wait behind COLMAP at
  // idle priority on a busy machine, so it gets the longest.
  double front_stall_s = 30.0;
  double back_stall_s = 300.0;
  double manager_stall_s = 60.0;
  // status.json in the state folder is rewritten this often.
  double status_interval_s = 1.0;

  static const OptionSpec<DaemonOptions>& Spec();
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

}  // namespace rumi
