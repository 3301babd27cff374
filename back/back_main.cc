// rumi-back: turns sampled image windows into back submaps with COLMAP.
//   rumi-back --window-dir DIR --config FILE --out DIR [--bench] [--groundtruth FILE]
// processes one window stored as a folder;
//   rumi-back --instance ID [--config FILE] --work DIR
// is the shared-memory mode of `rumi eval run` (back_ipc_main.h, docs/back.md).
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <fstream>

#include "back/back_ipc_main.h"
#include "back/back_options.h"
#include "back/back_result_io.h"
#include "back/back_submap_builder.h"
#include "common/process/subprocess.h"
#include "back/window_dir.h"
#include "common/config.h"
#include "common/camera_config.h"
#include "common/geometry.h"
#include "common/trajectory_eval.h"
#include "ipc/submap_codec.h"
#include "common/logging.h"

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

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rumi-back: COLMAP-built back submaps from sampled image windows"};
  std::string window_dir, config_path, out_dir, gt_path, log_level, instance, work_dir;
  double wait_for_producer_s = 0.0, wait_for_consumer_s = 30.0;
  bool bench = false, keep = false;
  WindowDirOptions wd;
  app.add_option("--window-dir", window_dir, "folder with rgb.txt-style index and images");
  app.add_option("--config", config_path, "rumi config with camera: and back: sections")->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "output folder (result.json, submap_<id>.json, submap_<id>_tum.txt)");
  app.add_option("--instance", instance, "rumi instance id: windows from shared memory (rumi_<ID>_windows)");
  app.add_option("--work", work_dir, "shared-memory mode: folder for back_stats.json");
  app.add_option("--wait-for-producer", wait_for_producer_s,
                 "shared-memory mode: no window producer after this many seconds -> done (0: wait forever)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--wait-for-consumer", wait_for_consumer_s,
                 "shared-memory mode: before closing, wait up to this long for the manager to read all submaps")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--bench", bench, "print the time split per COLMAP step");
  app.add_option("--groundtruth", gt_path, "TUM ground truth: print ATE (Sim3) per submap");
  app.add_option("--first", wd.first, "first listed frame used")->check(CLI::NonNegativeNumber);
  app.add_option("--count", wd.count, "number of frames used (-1 = all)");
  app.add_option("--step", wd.step, "use every step-th frame")->check(CLI::PositiveNumber);
  app.add_option("--scale", wd.scale, "resize images and camera by this factor")->check(CLI::PositiveNumber);
  app.add_flag("--keep-workspace", keep, "keep the COLMAP workspace (overrides back.keep_workspaces)");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides the config)");
  CLI11_PARSE(app, argc, argv);

  BackOptions options;
  PinholeCameraOptions camera;
  IpcOptions ipc;
  std::string config_log_level = "info";
  bool have_camera = false;
  try {
    if (!config_path.empty()) {
      ConfigSection root = LoadConfigFile(config_path);
      ConfigSection back = root.Child("back");
      ReadOptions(back, &options);
      CheckOptions(options, root, "back");
      back.Finish();
      if (root.Has("camera")) {  // file mode needs it; a window over ipc carries its camera
        ConfigSection cs = root.Child("camera");
        ReadOptions(cs, &camera);
        cs.Finish();
        have_camera = true;
      }
      ConfigSection is = root.Child("ipc");
      ReadOptions(is, &ipc);
      is.Finish();
      root.Read("log_level", &config_log_level);
      // Other processes' sections share the file; anything else is a typo.
      for (const char* other : {"front", "sampler", "manager"}) root.Ignore(other);
      root.Finish();
    }
  } catch (const ConfigError& e) {
    SetupLogging("back", "info");
    spdlog::error("{}", e.what());
    return 2;
  }
  if (log_level.empty()) log_level = config_log_level;
  if (!SetupLogging("back", log_level)) spdlog::warn("unknown log level '{}'", log_level);
  if (keep) options.keep_workspaces = true;

  if (!instance.empty()) {
    BackIpcRunOptions run;
    run.back = options;
    run.ipc = ipc;
    run.ipc.instance = instance;
    run.work_dir = work_dir;
    run.wait_for_producer_s = wait_for_producer_s;
    run.wait_for_consumer_s = wait_for_consumer_s;
    std::string why;
    if (!run.ipc.Check(&why)) {
      spdlog::error("--instance '{}': {}", instance, why);
      return 2;
    }
    if (work_dir.empty()) {
      spdlog::error("--instance needs --work DIR (for back_stats.json)");
      return 2;
    }
    struct sigaction sa {};
    sa.sa_handler = OnSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
    return RunBackIpc(run, &g_stop);
  }
  if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());
  if (window_dir.empty() || out_dir.empty() || !have_camera) {
    spdlog::error("file mode needs --window-dir, --out and a --config with a camera: section");
    return 2;
  }

  ImageWindow window;
  std::string error;
  if (!ReadWindowDir(window_dir, camera, wd, 0, &window, &error)) {
    spdlog::error("{}", error);
    return 1;
  }
  spdlog::info("window: {} frames {}x{} from {}", window.frames.size(), window.camera.width,
               window.camera.height, window_dir);
  BackSubmapBuilder builder(options);
  const BackResult result = builder.Build(window);
  if (!WriteBackResult(result, out_dir, &error)) {
    spdlog::error("{}", error);
    return 1;
  }
  // The shared binary format as well (ipc/submap_codec.h), as the manager reads it.
  for (const Submap& s : result.submaps) {
    const std::vector<uint8_t> bytes = EncodeSubmap(s);
    const std::string path = out_dir + "/submap_" + std::to_string(s.id) + ".bin";
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!f) {
      spdlog::error("cannot write {}", path);
      return 1;
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
    std::printf("  status %s, %zu submap(s), %d/%d registered\n", ToString(result.status),
                result.submaps.size(), result.num_registered, result.num_frames);
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
  return result.ok() ? 0 : 4;
}
