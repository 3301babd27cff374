// `rumi status`: what a running rumid instance is doing, from the status.json
// it rewrites every second in its state folder (ipc/daemon_status.h).
#include <fmt/format.h>
#include <iostream>
#include <memory>

#include "common/process/process_info.h"
#include "common/timestamp.h"
#include "apps/cli/commands.h"
#include "ipc/daemon_status.h"
#include "apps/daemon/state_dir.h"

namespace rumi::cli {

void RegisterStatusCommand(CLI::App* app) {
  struct Args {
    std::string instance = "default", state_dir;
    bool json = false, brief = false, csv = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app->add_subcommand("status", "what a running rumid instance is doing (children, map, back queue)");
  cmd->add_option("--instance", a->instance, "instance name (its state folder: /var/lib/rumi/<instance>)");
  cmd->add_option("--state-dir", a->state_dir, "the instance's state folder (overrides --instance)");
  cmd->add_flag("--json", a->json, "print status.json as it is, for scripts");
  cmd->add_flag("--brief", a->brief, "one line: state, source, tracking, submaps, merges, back queue");
  cmd->add_flag("--csv", a->csv, "a CSV header and one line of figures (memory, fds, rebuilds: scripts/soak.sh)");
  cmd->callback([a] {
    const std::string dir = ResolveStateDir(a->state_dir, "", a->instance);
    nlohmann::json st;
    std::string why;
    if (!ReadDaemonStatus(dir, &st, &why)) {
      std::cerr << "rumi status: " << why << "\n";
      throw CLI::RuntimeError(1);
    }
    const DaemonLiveness l = CheckDaemonLiveness(st, NsToSeconds(WallNowNs()));
    const bool alive = l.alive;
    const std::string stale =
        l.stale ? fmt::format("STALE: status.json was last written {:.0f} s ago; rumid (pid {}) runs but does not "
                              "write it (stopped or hung?)",
                              l.age_s, st.value("pid", 0))
                : "";
    if (a->json) {
      st["alive"] = alive;
      st["stale"] = l.stale;
      std::cout << st.dump(2) << "\n";
    } else if (a->csv) {
      std::cout << DaemonStatusCsv(st, true);
    } else if (a->brief) {
      std::cout << (alive ? "" : "not running: ") << (l.stale ? "stale: " : "") << DaemonSummary(st) << "\n";
    } else {
      if (!stale.empty()) std::cout << stale << "\n";
      std::cout << FormatDaemonStatus(st, alive);
    }
    if (!alive) throw CLI::RuntimeError(3);  // scripts: not running
    if (l.stale) throw CLI::RuntimeError(4);  // running, but what it says is old
  });
}

}  // namespace rumi::cli
