// rumid: the rumi daemon (RunDaemon, apps/daemon/daemon.h; docs/daemon.md).
//   rumid --config FILE [--instance NAME] [--state-dir DIR] [--bin-dir DIR] [--log-level L]
// Under systemd (rumid@.service): Type=notify, WatchdogSec, StateDirectory.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <atomic>
#include <filesystem>
#include <iostream>

#include "common/process/exit_codes.h"
#include "common/process/subprocess.h"
#include "apps/config/process_setup.h"
#include "ipc/channels.h"
#include "apps/daemon/daemon.h"
#include "apps/daemon/state_dir.h"

namespace rumi {
namespace {

std::atomic<bool> g_hangup{false};

int Main(int argc, char** argv) {
  CLI::App app{"rumid: runs rumi-front, rumi-back and rumi-manager on a live source and keeps them running"};
  std::string config_path, instance, state_dir, bin_dir, log_level, dataset_kind, dataset_path;
  app.add_option("--config", config_path, "rumi YAML config (source:, daemon:, and every part)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--instance", instance, "instance name (default: daemon.instance, else the config file's name)");
  app.add_option("--state-dir", state_dir,
                 "state folder (default: daemon.state_dir, $STATE_DIRECTORY, /var/lib/rumi/<instance>)");
  app.add_option("--bin-dir", bin_dir, "folder of rumi-front/back/manager (default: daemon.bin_dir, rumid's own)");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  app.add_option("--dataset", dataset_kind,
                 "replay a dataset as the live source (tum|euroc|icl|kitti|folder; overrides source:); its "
                 "calibration: PATH/camera.yaml when there is one (rumi synth), else the dataset's own")
      ->check(CLI::IsMember({"tum", "euroc", "icl", "kitti", "folder"}));
  app.add_option("path", dataset_path, "the dataset folder (with --dataset)");
  CLI11_PARSE(app, argc, argv);
  if (dataset_kind.empty() != dataset_path.empty()) {
    std::cerr << "rumid: --dataset KIND needs the dataset's folder, and a folder needs --dataset KIND\n";
    return kExitBadInput;
  }

  ProcessSetup setup("rumid", config_path, log_level);
  if (!setup.Load()) return kExitBadInput;
  setup.set_reload_hook([] { g_hangup.store(true); });
  const RumiConfig& c = setup.config();
  DaemonRunOptions o;
  o.config = c;
  if (!dataset_kind.empty()) {
    SourceOptions& s = o.config.source;
    s.kind = "dataset";
    s.dataset = dataset_kind;
    s.path = std::filesystem::absolute(dataset_path).string();
    const std::filesystem::path cam = std::filesystem::path(s.path) / "camera.yaml";
    s.calibration = std::filesystem::exists(cam) ? cam.string() : "dataset";
    o.source_overridden = true;
  }
  o.config_path = std::filesystem::absolute(config_path).string();
  o.instance = !instance.empty() ? instance
               : !c.daemon.instance.empty() ? c.daemon.instance
                                            : std::filesystem::path(config_path).stem().string();
  const std::string problem = InstanceIdProblem(o.instance);
  if (!problem.empty()) {
    spdlog::error("rumid: {} (--instance or daemon.instance)", problem);
    return kExitBadInput;
  }
  o.state_dir = ResolveStateDir(state_dir, c.daemon.state_dir, o.instance);
  o.bin_dir = !bin_dir.empty() ? bin_dir : !c.daemon.bin_dir.empty() ? c.daemon.bin_dir : ExecutableDir();
  // The hook only raises the flag; the daemon's loop forwards SIGHUP to the children.
  return RunDaemon(o, setup.stop(), &g_hangup);
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
