// rumi-back: turns sampled image windows into back submaps with COLMAP.
//   rumi-back --window-dir DIR --config FILE --out DIR [--bench] [--groundtruth FILE]
// processes one window stored as a folder;
//   rumi-back --instance ID [--config FILE] --work DIR [--daemon]
// is the process of `rumi eval run` and rumid (RunBack, back/back_run.h);
//   rumi-back --remote --instance ID [--config FILE] [--name NAME]
// is a worker on another host for a rumi-back with back.mode remote or both
// (back/remote/, docs/back.md).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>

#include "back/back_options.h"
#include "back/back_result_io.h"
#include "back/back_run.h"
#include "back/back_submap_builder.h"
#include "back/remote/remote_dispatcher.h"
#include "back/remote/remote_worker.h"
#include "back/window_dir.h"
#include "common/atomic_file.h"
#include "common/geometry.h"
#include "common/process/exit_codes.h"
#include "common/process/subprocess.h"
#include "common/trajectory_eval.h"
#include "apps/config/process_setup.h"
#include "ipc/submap_codec.h"
#include "ipc/window_codec.h"

using namespace rumi;

namespace {

// ATE of one submap's keyframe poses (Sim(3) Umeyama, association 0.02 s).
void PrintAte(const Submap& s, const Trajectory& gt) {
  Trajectory est;
  for (const Keyframe& kf : s.keyframes) est.push_back({kf.timestamp, kf.T_wc()});
  try {
    const AteResult a = ComputeAte(est, gt, AteOptions{});
    std::printf("  submap %lld: ATE (Sim3) %.4f m over %zu poses, rot %.3f deg, scale %.4f\n",
                static_cast<long long>(s.id), a.translation.rmse, a.pairs.size(),
                a.rotation_deg.rmse, a.S_gt_est.scale());
  } catch (const std::exception& e) {
    std::printf("  submap %lld: ATE n/a: %s\n", static_cast<long long>(s.id), e.what());
  }
}

// What back.remote_png saves on the wire, and what it costs each side.
int PrintWireBench(const ImageWindow& w) {
  using Clock = std::chrono::steady_clock;
  const auto secs = [](Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); };
  const size_t raw = EncodedWindowSize(w);
  auto t = Clock::now();
  const std::vector<uint8_t> png = EncodeWindow(w, WindowPixels::kPng);
  const double encode_s = secs(t);
  t = Clock::now();
  ImageWindow back;
  std::string why;
  if (!DecodeWindow(png.data(), png.size(), &back, /*in_place=*/false, &why)) {
    spdlog::error("the PNG window does not decode: {}", why);
    return kExitError;
  }
  const double decode_s = secs(t);
  std::printf("rumi-back wire: %zu frames %dx%d: raw %.2f MB, PNG %.2f MB (%.1f %% of raw), "
              "PNG encode %.2f s, decode %.2f s (one thread)\n",
              w.frames.size(), w.camera.width, w.camera.height, raw / 1e6, png.size() / 1e6,
              100.0 * static_cast<double>(png.size()) / static_cast<double>(raw), encode_s, decode_s);
  return kExitDone;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rumi-back: COLMAP-built back submaps from sampled image windows"};
  std::string window_dir, config_path, out_dir, gt_path, log_level, instance, work_dir;
  std::vector<std::string> sets;
  int64_t first_submap_id = 0;
  bool bench = false, bench_wire = false, keep = false, daemon = false, remote = false;
  std::string worker_name;
  WindowDirOptions wd;
  app.add_option("--window-dir", window_dir, "folder with rgb.txt-style index and images");
  app.add_option("--config", config_path, "rumi config (every section is checked; camera: for file mode)")
      ->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "output folder (result.json, submap_<id>.json, submap_<id>_tum.txt)");
  app.add_option("--instance", instance, "rumi instance id: windows from shared memory (rumi_<ID>_windows)");
  app.add_option("--work", work_dir, "shared-memory mode: folder for back_stats.json");
  app.add_option("--first-submap-id", first_submap_id, "rumid: back submap ids start here")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--daemon", daemon,
               "rumid: spool windows in --work until built, wait for a restarted front, leave the channel");
  app.add_flag("--remote", remote,
               "a remote back worker: build the windows the rumi-back of --instance offers over DDS (dds: section)");
  app.add_option("--name", worker_name, "with --remote: the worker's name on the wire (default <host>-<pid>)");
  app.add_flag("--bench", bench, "print the time split per COLMAP step");
  app.add_flag("--bench-wire", bench_wire,
               "with --window-dir: print the window's bytes to a remote worker (raw, PNG) and the PNG times; "
               "builds nothing");
  app.add_option("--groundtruth", gt_path, "TUM ground truth: print ATE (Sim3) per submap");
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
  BackOptions options = setup.config().back;

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
    std::string why;
    if (!run.ipc.Check(&why)) {
      spdlog::error("--instance '{}': {}", instance, why);
      return kExitBadInput;
    }
    if (work_dir.empty()) {
      spdlog::error("--instance needs --work DIR (for back_stats.json)");
      return kExitBadInput;
    }
    std::unique_ptr<RemoteDispatcher> dispatcher;
    if (options.mode != "local") {
      dispatcher = RemoteDispatcher::Create(setup.config().dds, instance, options, &why);
      if (!dispatcher) {
        spdlog::error("back.mode {}: {}", options.mode, why);
        return kExitError;
      }
      run.remote = dispatcher.get();
    }
    if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
    return RunBack(run, setup.stop());
  }
  if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
  if (window_dir.empty() || (out_dir.empty() && !bench_wire) || !setup.config().has_camera) {
    spdlog::error("file mode needs --window-dir, --out and a --config with a camera: section");
    return kExitBadInput;
  }
  const PinholeCameraOptions& camera = setup.config().camera;
  std::string error;
  ImageWindow window;
  if (!ReadWindowDir(window_dir, camera, wd, 0, &window, &error)) {
    spdlog::error("{}", error);
    return kExitBadInput;
  }
  spdlog::info("window: {} frames {}x{} from {}", window.frames.size(), window.camera.width,
               window.camera.height, window_dir);
  if (bench_wire) return PrintWireBench(window);
  BackSubmapBuilder builder(options);
  const BackResult result = builder.Build(window);
  if (!WriteBackResult(result, out_dir, &error)) {
    spdlog::error("{}", error);
    return kExitError;
  }
  // The shared binary format as well (ipc/submap_codec.h), as the manager reads it.
  for (const Submap& s : result.submaps) {
    if (!WriteFileAtomically(out_dir + "/submap_" + std::to_string(s.id) + ".bin", EncodeSubmap(s), &error)) {
      spdlog::error("{}", error);
      return kExitError;
    }
  }
  if (bench) {
    const BackStepTimes& t = result.times;
    std::printf("rumi-back bench: %d frames %dx%d, %d threads, %d features, matcher %s\n",
                result.num_frames, window.camera.width, window.camera.height, options.num_threads,
                options.max_num_features, options.matcher.c_str());
    std::printf("  step                 wall s    cpu s\n");
    std::printf("  undistort+write     %8.2f\n", t.undistort_write_s);
    std::printf("  feature_extraction  %8.2f %8.2f\n", t.feature_extraction_s, t.feature_extraction_cpu_s);
    std::printf("  matching            %8.2f %8.2f\n", t.matching_s, t.matching_cpu_s);
    std::printf("  mapping             %8.2f %8.2f\n", t.mapping_s, t.mapping_cpu_s);
    std::printf("  read+convert        %8.2f\n", t.read_convert_s);
    std::printf("  total               %8.2f %8.2f\n", t.total_s,
                t.feature_extraction_cpu_s + t.matching_cpu_s + t.mapping_cpu_s);
    std::printf("  status %s, %zu submap(s), %d/%d registered, %d image pairs selected, %s, %s\n",
                ToString(result.status), result.submaps.size(), result.num_registered, result.num_frames,
                result.matched_pairs,
                !result.filled ? "no fill" : result.fill_kept ? "filled (all pairs kept)" : "filled (selection kept)",
                !result.retried ? "no retry" : result.retry_kept ? "retried (retry kept)" : "retried (first kept)");
    for (size_t i = 0; i < result.submaps.size(); ++i)
      std::printf("  submap %lld: %d images, %d points, mean reproj %.3f px, track %.2f\n",
                  static_cast<long long>(result.submaps[i].id), result.stats[i].registered_images,
                  result.stats[i].num_points, result.stats[i].mean_reprojection_error_px,
                  result.stats[i].mean_track_length);
  }
  if (!gt_path.empty()) {
    try {
      const Trajectory gt = ReadTumTrajectory(gt_path);
      for (const Submap& s : result.submaps) PrintAte(s, gt);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
    }
  }
  return result.ok() ? kExitDone : kExitWindowFailed;
}
