#pragma once
// rumid's status.json (`rumi status`, docs/daemon.md): what the daemon, its
// children and the instance's rings are doing, built from the supervisor.
#include <chrono>
#include <string>

#include <nlohmann/json.hpp>

#include "common/process/supervisor.h"

namespace rumi {

// What the supervision loop knows that the supervisor does not.
struct DaemonStatusFacts {
  std::string instance, config_path, state_dir;
  std::string state = "starting";  // starting | running | finishing | stopping | failed | stopped
  std::string failure;  // empty unless failed
  std::string started;  // local wall clock at start, ISO 8601
  std::chrono::steady_clock::time_point started_at;
  double status_interval_s = 0;
  std::string source;   // "kind path", for a front that has not said its own
  std::string view;     // the web view's address; "" when it is off
  int front = -1, back = -1, manager = -1;  // children in the supervisor
};

// The whole status.json, "summary" included (ipc/daemon_status.h).
nlohmann::json DaemonStatusJson(const DaemonStatusFacts& facts, const Supervisor& sup);

}  // namespace rumi
