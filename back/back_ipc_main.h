#pragma once
// rumi-back's shared-memory mode (`rumi-back --instance ID --work DIR`).
// Compiled into the rumi-back executable only (it links ipc/); the rumi_back
// library stays transport-free.
#include <atomic>
#include <string>

#include "back/back_options.h"
#include "ipc/channels.h"

namespace rumi {

struct BackIpcRunOptions {
  BackOptions back;
  IpcOptions ipc;                     // ipc.instance = --instance
  std::string work_dir;               // back_stats.json goes here
  double wait_for_producer_s = 0.0;   // no window producer after this long -> done (0: wait forever)
  double wait_for_consumer_s = 30.0;  // before closing: wait this long for the manager to read everything
};

// Runs until the window producer has closed its channel (or died, or never
// appeared within wait_for_producer_s) and every queued window is built, or
// until *stop is set (SIGINT/SIGTERM: the running COLMAP step is cancelled).
// Writes work_dir/back_stats.json after every window and at the end.
// Returns the process exit code: 0 done or stopped, 1 on an error (IPC
// attach refused, stats not writable).
int RunBackIpc(const BackIpcRunOptions& o, const std::atomic<bool>* stop);

}  // namespace rumi
