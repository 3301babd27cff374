#include "apps/config/daemon_options.h"

#include "ipc/channels.h"

namespace rumi {

const OptionSpec<DaemonOptions>& DaemonOptions::Spec() {
  using O = DaemonOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("daemon");
    s->Text("instance", &O::instance, "instance name; '': the config file's name", "[A-Za-z0-9_-]{0,32}",
            [](const std::string& v) { return v.empty() ? std::string() : InstanceIdProblem(v); });
    s->Text("state_dir", &O::state_dir, "state folder; '': $STATE_DIRECTORY or /var/lib/rumi/<instance>");
    s->Text("bin_dir", &O::bin_dir, "folder of rumi-front/back/manager; '': rumid's own");
    s->Choice("child_output", &O::child_output, {"journal", "files"},
              "children's output: rumid's stderr (the journal) or state_dir/logs/<child>.log");
    s->Number("stop_timeout_s", &O::stop_timeout_s, Above(0.0), AtMost(3600.0),
              "SIGTERM: everything stopped and saved within this long, or killed");
    s->Number("restart_backoff_initial_s", &O::restart_backoff_initial_s, Above(0.0), AtMost(3600.0),
              "first wait before restarting a crashed child (doubles)");
    s->Number("restart_backoff_max_s", &O::restart_backoff_max_s, Above(0.0), AtMost(3600.0),
              "longest wait before a restart");
    s->Number("crash_loop_restarts", &O::crash_loop_restarts, AtLeast(0), AtMost(1000),
              "more crashes than this within crash_loop_window_s: give up on the child");
    s->Number("crash_loop_window_s", &O::crash_loop_window_s, Above(0.0), AtMost(86400.0), "crash-loop window");
    s->Number("front_stall_s", &O::front_stall_s, Above(0.0), AtMost(86400.0),
              "a front without a heartbeat for this long is killed and restarted");
    s->Number("back_stall_s", &O::back_stall_s, Above(0.0), AtMost(86400.0),
              "a back without a heartbeat for this long is killed and restarted");
    s->Number("manager_stall_s", &O::manager_stall_s, Above(0.0), AtMost(86400.0),
              "a manager whose loop has not turned for this long is killed and restarted (and no WATCHDOG=1 "
              "goes to systemd meanwhile)");
    s->Number("status_interval_s", &O::status_interval_s, AtLeast(0.05), AtMost(3600.0),
              "status.json is rewritten this often");
    s->Rule("restart_backoff_max_s must be >= restart_backoff_initial_s",
            [](const O& o) { return o.restart_backoff_max_s >= o.restart_backoff_initial_s; });
    return s;
  }();
  return *spec;
}

}  // namespace rumi
