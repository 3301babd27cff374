// rumi-back: turns sampled image windows into back submaps with COLMAP.
//   rumi-back --window-dir DIR --config FILE --out DIR [--bench] [--groundtruth FILE]
// processes one window stored as a folder. The shared-memory mode
// (--instance ID) is the integration point for ipc/ (see TODO below).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <fstream>

#include "back/back_options.h"
#include "back/back_result_io.h"
#include "back/back_submap_builder.h"
#include "back/process_runner.h"
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rumi-back: COLMAP-built back submaps from sampled image windows"};
  std::string window_dir, config_path, out_dir, gt_path, log_level = "info";
  int64_t instance = -1;
  bool bench = false, keep = false;
  WindowDirOptions wd;
  app.add_option("--window-dir", window_dir, "folder with rgb.txt-style index and images");
  app.add_option("--config", config_path, "rumi config with camera: and back: sections")->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "output folder (result.json, submap_<id>.json, submap_<id>_tum.txt)");
  app.add_option("--instance", instance, "rumi instance id: read windows from shared memory (not yet)");
  app.add_flag("--bench", bench, "print the time split per COLMAP step");
  app.add_option("--groundtruth", gt_path, "TUM ground truth: print ATE (Sim3) per submap");
  app.add_option("--first", wd.first, "first listed frame used")->check(CLI::NonNegativeNumber);
  app.add_option("--count", wd.count, "number of frames used (-1 = all)");
  app.add_option("--step", wd.step, "use every step-th frame")->check(CLI::PositiveNumber);
  app.add_option("--scale", wd.scale, "resize images and camera by this factor")->check(CLI::PositiveNumber);
  app.add_flag("--keep-workspace", keep, "keep the COLMAP workspace (overrides back.keep_workspaces)");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off");
  CLI11_PARSE(app, argc, argv);
  if (!SetupLogging("back", log_level)) spdlog::warn("unknown log level '{}'", log_level);

  BackOptions options;
  PinholeCameraOptions camera;
  bool have_camera = false;
  try {
    if (!config_path.empty()) {
      ConfigSection root = LoadConfigFile(config_path);
      ConfigSection back = root.Child("back");
      ReadOptions(back, &options);
      CheckOptions(options, root, "back");
      back.Finish();
      if (root.Has("camera")) {
        ConfigSection cs = root.Child("camera");
        ReadOptions(cs, &camera);
        cs.Finish();
        have_camera = true;
      }
      // Other processes' sections may share the file: only ours are checked strictly.
    }
  } catch (const ConfigError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (keep) options.keep_workspaces = true;
  if (options.low_priority) spdlog::info("priority: {}", LowerOwnPriority());

  if (instance >= 0) {
    // TODO(ipc): --instance mode. Open the instance's window ring (ipc/) and
    // submap ring, then loop: pop ImageWindow -> WindowQueue (capacity
    // options.max_queue_windows, drop oldest) -> BackSubmapBuilder::Build ->
    // push each Submap (source kBack) or the failure report; stop on SIGTERM
    // through the builder's cancel flag.
    spdlog::error("--instance mode needs the shared-memory transport (ipc/), not written yet");
    return 3;
  }
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
