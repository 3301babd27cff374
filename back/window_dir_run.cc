#include "back/window_dir_run.h"

#include <chrono>
#include <cstdio>

#include "back/back_result_io.h"
#include "back/back_submap_builder.h"
#include "common/atomic_file.h"
#include "common/geometry.h"
#include "common/logging.h"
#include "common/process/exit_codes.h"
#include "common/trajectory_eval.h"
#include "ipc/submap_codec.h"
#include "ipc/window_codec.h"

namespace rumi {
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
  const size_t raw = EncodedWindowSize(w);
  auto t = Clock::now();
  const std::vector<uint8_t> png = EncodeWindow(w, WindowPixels::kPng);
  const double encode_s = SecondsSince(t);
  t = Clock::now();
  ImageWindow back;
  std::string why;
  if (!DecodeWindow(png.data(), png.size(), &back, /*in_place=*/false, &why)) {
    spdlog::error("the PNG window does not decode: {}", why);
    return kExitError;
  }
  const double decode_s = SecondsSince(t);
  std::printf("rumi-back wire: %zu frames %dx%d: raw %.2f MB, PNG %.2f MB (%.1f %% of raw), "
              "PNG encode %.2f s, decode %.2f s (one thread)\n",
              w.frames.size(), w.camera.width, w.camera.height, raw / 1e6, png.size() / 1e6,
              100.0 * static_cast<double>(png.size()) / static_cast<double>(raw), encode_s, decode_s);
  return kExitDone;
}

// The time split per COLMAP step, and what came of each attempt.
void PrintBench(const BackResult& result, const ImageWindow& window, const BackOptions& options) {
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

}  // namespace

int RunWindowDir(const WindowDirRunOptions& o) {
  std::string error;
  ImageWindow window;
  if (!ReadWindowDir(o.window_dir, o.camera, o.window, 0, &window, &error)) {
    spdlog::error("{}", error);
    return kExitBadInput;
  }
  spdlog::info("window: {} frames {}x{} from {}", window.frames.size(), window.camera.width,
               window.camera.height, o.window_dir);
  if (o.bench_wire) return PrintWireBench(window);
  BackSubmapBuilder builder(o.back);
  const BackResult result = builder.Build(window);
  if (!WriteBackResult(result, o.out_dir, &error)) {
    spdlog::error("{}", error);
    return kExitError;
  }
  // The shared binary format as well (ipc/submap_codec.h), as the manager reads it.
  for (const Submap& s : result.submaps) {
    if (!WriteFileAtomically(o.out_dir + "/submap_" + std::to_string(s.id) + ".bin", EncodeSubmap(s), &error)) {
      spdlog::error("{}", error);
      return kExitError;
    }
  }
  if (o.bench) PrintBench(result, window, o.back);
  if (!o.groundtruth.empty()) {
    try {
      const Trajectory gt = ReadTumTrajectory(o.groundtruth);
      for (const Submap& s : result.submaps) PrintAte(s, gt);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
    }
  }
  return result.ok() ? kExitDone : kExitWindowFailed;
}

}  // namespace rumi
