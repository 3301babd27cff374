// rumi-back: turns sampled image windows into back submaps with COLMAP.
//   rumi-back --window-dir DIR --config FILE --out DIR [--bench] [--groundtruth FILE]
// processes one window stored as a folder (RunWindowDir, back/window_dir_run.h);
//   rumi-back --instance ID [--config FILE] --work DIR [--daemon]
// is the process of `rumi eval run` and rumid (RunBackInstance, back/remote/back_instance.h);
//   rumi-back --remote --instance ID [--config FILE] [--name NAME]
// is a worker on another host for a rumi-back with back.mode remote or both
// (back/remote/, docs/back.md).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "apps/config/process_setup.h"
#include "back/remote/back_instance.h"
#include "back/remote/remote_worker.h"
#include "back/window_dir_run.h"
#include "common/process/exit_codes.h"
#include "common/process/subprocess.h"

using namespace rumi;

int main(int argc, char** argv) {
  CLI::App app{"rumi-back: COLMAP-built back submaps from sampled image windows"};
  std::string config_path, log_level, instance, work_dir;
  std::vector<std::string> sets;
  int64_t first_submap_id = 0;
  bool keep = false, daemon = false, remote = false;
  std::string worker_name;
  WindowDirRunOptions file;
  WindowDirOptions& wd = file.window;
  app.add_option("--window-dir", file.window_dir, "folder with rgb.txt-style index and images");
  app.add_option("--config", config_path, "rumi config (every section is checked; camera: for file mode)")
      ->check(CLI::ExistingFile);
  app.add_option("--out", file.out_dir, "output folder (result.json, submap_<id>.json, submap_<id>_tum.txt)");
  app.add_option("--instance", instance, "rumi instance id: windows from shared memory (rumi_<ID>_windows)");
  app.add_option("--work", work_dir, "shared-memory mode: folder for back_stats.json");
  app.add_option("--first-submap-id", first_submap_id, "rumid: back submap ids start here")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--daemon", daemon,
               "rumid: spool windows in --work until built, wait for a restarted front, leave the channel");
  app.add_flag("--remote", remote,
               "a remote back worker: build the windows the rumi-back of --instance offers over DDS (dds: section)");
  app.add_option("--name", worker_name, "with --remote: the worker's name on the wire (default <host>-<pid>)");
  app.add_flag("--bench", file.bench, "print the time split per COLMAP step");
  app.add_flag("--bench-wire", file.bench_wire,
               "with --window-dir: print the window's bytes to a remote worker (raw, PNG) and the PNG times; "
               "builds nothing");
  app.add_option("--groundtruth", file.groundtruth, "TUM ground truth: print ATE (Sim3) per submap");
  app.add_option("--first", wd.first, "first listed frame used")->check(CLI::NonNegativeNumber);
  app.add_option("--count", wd.count, "number of frames used (-1 = all)");
  app.add_option("--step", wd.step, "use every step-th frame")->check(CLI::PositiveNumber);
  app.add_option("--scale", wd.scale, "resize images and camera by this factor")->check(CLI::PositiveNumber);
  app.add_flag("--keep-workspace", keep, "keep the COLMAP workspace (= --set back.keep_workspaces=true)");
  AddConfigSetOptions(&app, &sets,
                      {{"--wait-for-producer", "back.wait_for_producer_s"},
                       {"--wait-for-consumer", "back.wait_for_consumer_s"}});
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  CLI11_PARSE(app, argc, argv);

  if (keep) sets.push_back("back.keep_workspaces=true");
  ProcessSetup setup("back", config_path, log_level, sets);
  if (!setup.Load()) return kExitBadInput;
  const BackOptions& options = setup.config().back;

  if (remote) {
    if (instance.empty()) {
      spdlog::error("--remote needs --instance ID (the dispatching rumi-back's instance)");
      return kExitBadInput;
    }
    RemoteWorkerOptions wo;
    wo.dds = setup.config().dds;
    wo.instance = instance;
    wo.back = options;
    wo.name = worker_name;
    if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
    return RunRemoteWorker(wo, setup.stop());
  }
  if (!instance.empty()) {
    BackRunOptions run;
    run.back = options;
    run.ipc = setup.config().ipc;
    run.ipc.instance = instance;
    run.work_dir = work_dir;
    run.spool = daemon;
    run.producer_death_ends = !daemon;
    run.keep_segments = daemon;
    run.first_submap_id = first_submap_id;
    if (daemon) run.finish = ProcessSignals::finish();
    return RunBackInstance(run, setup.config().dds, setup.stop());
  }
  if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
  if (file.window_dir.empty() || (file.out_dir.empty() && !file.bench_wire) || !setup.config().has_camera) {
    spdlog::error("file mode needs --window-dir, --out and a --config with a camera: section");
    return kExitBadInput;
  }
  file.camera = setup.config().camera;
  file.back = options;
  return RunWindowDir(file);
}
