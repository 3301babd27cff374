// rumi-manager: consumes the front and back submap channels of one rumi
// instance, merges the submaps into the global map and keeps the map file,
// the global trajectories and manager_stats.json in the out dir up to date.
//   rumi-manager --instance ID [--config FILE] --out DIR [--map FILE]
//                [--log-level L] [--wait-for-producers S] [--rebuild-interval S]
//                [--rebuild-max-duty F]
// Exit: 0 when both producers closed their channels (or SIGINT/SIGTERM) and
// everything is saved; 1 on a runtime error (an output cannot be written);
// 2 on a bad command line or config; 3 when no producer appeared at all
// within --wait-for-producers (outputs are still written).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <iostream>

#include "common/config.h"
#include "common/logging.h"
#include "manager/manager_service.h"

namespace rumi {
namespace {

std::atomic<bool> g_stop{false};

void OnSignal(int) { g_stop.store(true); }

int Main(int argc, char** argv) {
  CLI::App app{"rumi-manager: merges front and back submaps into the global map"};
  std::string instance, config_path, out_dir, map_path, log_level;
  ManagerRunOptions run;
  app.add_option("--instance", instance, "rumi instance id (shared-memory segments rumi_<ID>_*)")->required();
  app.add_option("--config", config_path, "rumi YAML config (sections manager:, ipc:, log_level)");
  app.add_option("--out", out_dir, "output folder (map.rumi, merged*.txt, manager_stats.json)")->required();
  app.add_option("--map", map_path, "global map file (default <out>/map.rumi); reloaded when present");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  app.add_option("--wait-for-producers", run.wait_for_producers_s,
                 "a producer that has not appeared after this many seconds counts as finished (0: wait forever)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rebuild-interval", run.rebuild_interval_s,
                 "at most one global-map rebuild per this many seconds while submaps arrive")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rebuild-max-duty", run.rebuild_max_duty,
                 "largest share of the time spent rebuilding: after a rebuild of T s, wait T (1/duty - 1) s")
      ->check(CLI::Range(0.01, 1.0));
  CLI11_PARSE(app, argc, argv);

  ManagerProcessConfig config;
  try {
    if (!config_path.empty()) {
      ConfigSection root = LoadConfigFile(config_path);
      ReadManagerProcessConfig(root, &config);
    }
  } catch (const ConfigError& e) {
    SetupLogging("manager", "info");
    spdlog::error("rumi-manager: {}", e.what());
    return 2;
  }
  if (log_level.empty()) log_level = config.log_level;
  SetupLogging("manager", log_level);  // warns itself on an unknown level
  config.ipc.instance = instance;
  std::string why;
  if (!config.ipc.Check(&why)) {
    spdlog::error("rumi-manager: --instance '{}': {}", instance, why);
    return 2;
  }
  run.ipc = config.ipc;

  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sa.sa_flags = SA_RESETHAND;  // a second signal ends it at once (saves are atomic)
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  ManagerServiceOptions so;
  so.manager = config.manager;
  so.out_dir = out_dir;
  so.map_path = map_path;
  ManagerService service(so);
  if (!service.Start(&why)) {
    spdlog::error("rumi-manager: {}", why);
    return 1;
  }
  spdlog::info("rumi-manager: instance {}, out {}, map {}", instance, out_dir, so.MapPath());
  try {
    switch (RunManagerLoop(run, &service, &g_stop)) {
      case ManagerExit::kProducersDone:
      case ManagerExit::kStopped:
        return 0;
      case ManagerExit::kNoProducer:
        spdlog::error("rumi-manager: no producer appeared within {} s", run.wait_for_producers_s);
        return 3;
      case ManagerExit::kError:
        return 1;
    }
  } catch (const std::exception& e) {  // IpcError and the like: name it, do not abort
    spdlog::error("rumi-manager: {}", e.what());
    return 1;
  }
  return 1;
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
