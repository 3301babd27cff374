#pragma once
// `rumi-back --remote --instance ID`: a back worker on another host. It
// claims the windows a dispatcher (rumi-back with back.mode remote or both)
// offers over Cyclone DDS, builds each with COLMAP exactly as a local back
// does (its own `back:` options: threads, features, timeouts), and sends the
// result back (protocol: remote_protocol.h). Runs until *stop.
#include <atomic>
#include <string>

#include "back/back_options.h"
#include "ipc/dds/dds_options.h"

namespace rumi {

struct RemoteWorkerOptions {
  DdsOptions dds;            // domain, interface, chunk size, topic prefix
  std::string instance;      // the dispatcher's instance (topic namespace)
  BackOptions back;
  std::string name;          // on the wire; "" = <host>-<pid>
  // The worker takes the dispatcher for gone when it has not been matched
  // for back.remote_lease_s while building: the build is cancelled.
};

// Exit code (common/process/exit_codes.h): stopped (by *stop) or error (DDS
// setup). Windows built: logged, one line each.
int RunRemoteWorker(const RemoteWorkerOptions& o, const std::atomic<bool>* stop);

}  // namespace rumi
