// rumi-manager: consumes the front and back submap channels of one rumi
// instance, merges the submaps into the global map and keeps the map file,
// the global trajectories and manager_stats.json in the out dir up to date
// (RunManager, manager/manager_run.h).
//   rumi-manager --instance ID [--config FILE] --out DIR [--map FILE]
//                [--log-level L] [--set KEY=VALUE]... [--daemon]
//                (--wait-for-producers, --rebuild-interval, --rebuild-max-duty: --set aliases)
// Exit codes: common/process/exit_codes.h (0 both producers closed their
// channels and everything is saved; 5 stopped by SIGTERM/SIGINT before that;
// 1 an output cannot be written; 2 a bad command line or config; 3 no
// producer appeared within --wait-for-producers).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "common/process/exit_codes.h"
#include "apps/config/process_setup.h"
#include "manager/manager_run.h"

namespace rumi {
namespace {

int Main(int argc, char** argv) {
  CLI::App app{"rumi-manager: merges front and back submaps into the global map"};
  std::string instance, config_path, out_dir, map_path, log_level;
  std::vector<std::string> sets;
  bool daemon = false;
  app.add_option("--instance", instance, "rumi instance id (shared-memory segments rumi_<ID>_*)")->required();
  app.add_option("--config", config_path, "rumi YAML config (every section is checked)");
  app.add_option("--out", out_dir, "output folder (map.rumi, merged*.txt, manager_stats.json)")->required();
  app.add_option("--map", map_path, "global map file (default <out>/map.rumi); reloaded when present");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  AddConfigSetOptions(&app, &sets,
                      {{"--wait-for-producers", "manager.wait_for_producers_s"},
                       {"--rebuild-interval", "manager.rebuild_interval_s"},
                       {"--rebuild-max-duty", "manager.rebuild_max_duty"}});
  app.add_flag("--daemon", daemon,
               "rumid: journal every received submap, wait for restarted producers instead of ending");
  CLI11_PARSE(app, argc, argv);

  ProcessSetup setup("manager", config_path, log_level, sets);
  if (!setup.Load()) return kExitBadInput;
  ManagerRunOptions run;
  run.service.manager = setup.config().manager;
  run.service.grid = setup.config().grid;
  run.service.out_dir = out_dir;
  run.service.map_path = map_path;
  run.service.journal = daemon;
  run.loop = setup.config().manager_loop;
  run.ipc = setup.config().ipc;
  run.dds = setup.config().dds;
  run.ipc.instance = instance;
  run.producer_death_ends = !daemon;
  if (daemon) run.finish = ProcessSignals::finish();
  std::string why;
  if (!run.ipc.Check(&why)) {
    spdlog::error("rumi-manager: --instance '{}': {}", instance, why);
    return kExitBadInput;
  }
  return RunManager(run, setup.stop());
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
