// rumi-manager: consumes the front and back submap channels of one rumi
// instance, merges the submaps into the global map and keeps the map file,
// the global trajectories and manager_stats.json in the out dir up to date
// (RunManager, manager/manager_run.h).
//   rumi-manager --instance ID [--config FILE] --out DIR [--map FILE]
//                [--log-level L] [--wait-for-producers S] [--rebuild-interval S]
//                [--rebuild-max-duty F] [--daemon]
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
  double wait_for_producers_s = -1, rebuild_interval_s = -1, rebuild_max_duty = -1;
  bool daemon = false;
  app.add_option("--instance", instance, "rumi instance id (shared-memory segments rumi_<ID>_*)")->required();
  app.add_option("--config", config_path, "rumi YAML config (every section is checked)");
  app.add_option("--out", out_dir, "output folder (map.rumi, merged*.txt, manager_stats.json)")->required();
  app.add_option("--map", map_path, "global map file (default <out>/map.rumi); reloaded when present");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  app.add_option("--wait-for-producers", wait_for_producers_s, "overrides manager.wait_for_producers_s")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rebuild-interval", rebuild_interval_s, "overrides manager.rebuild_interval_s")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rebuild-max-duty", rebuild_max_duty, "overrides manager.rebuild_max_duty")
      ->check(CLI::Range(0.01, 1.0));
  app.add_flag("--daemon", daemon,
               "rumid: journal every received submap, wait for restarted producers instead of ending");
  CLI11_PARSE(app, argc, argv);

  ProcessSetup setup("manager", config_path, log_level);
  if (!setup.Load()) return kExitBadInput;
  ManagerRunOptions run;
  run.service.manager = setup.config().manager;
  run.service.grid = setup.config().grid;
  run.service.out_dir = out_dir;
  run.service.map_path = map_path;
  run.service.journal = daemon;
  run.loop = setup.config().manager_loop;
  if (wait_for_producers_s >= 0) run.loop.wait_for_producers_s = wait_for_producers_s;
  if (rebuild_interval_s >= 0) run.loop.rebuild_interval_s = rebuild_interval_s;
  if (rebuild_max_duty >= 0) run.loop.rebuild_max_duty = rebuild_max_duty;
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
