// `rumi synth`: writes a generated challenge sequence with exact ground truth
// (see docs/synth.md), a contact sheet, or a calibration report.
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <cstdio>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "common/synth/synth_calibration.h"
#include "common/synth/synthetic_sequence.h"
#include "apps/cli/commands.h"
#include "manager/grid/grid_builder.h"
#include "manager/grid/grid_score.h"

namespace rumi::cli {
namespace {
namespace fs = std::filesystem;

// The scene's true floor plan (walls and furniture cut at the grid's robot
// band), as a map_server grid beside the sequence: what `rumi eval grid`
// scores a grid against.
bool WriteFloorPlan(const SynthOptions& o, const std::string& out, double robot_height_m, double resolution_m) {
  const SyntheticSequence seq(o);
  GridOptions g;
  if (robot_height_m > 0) g.robot_height_m = robot_height_m;
  if (resolution_m > 0) g.cells.resolution_m = resolution_m;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e9), hi = -lo;
  for (const auto& [a, b] : seq.scene().free_space) {
    lo = lo.cwiseMin(a.head<2>());
    hi = hi.cwiseMax(b.head<2>());
  }
  if (!(lo.x() < hi.x())) return true;  // no free space declared: nothing to draw
  const MapServerGrid plan =
      RasterizeFloorPlan([&](const Eigen::Vector3d& p) { return seq.scene().Clearance(p); },
                         lo.array() - 0.5, hi.array() + 0.5, g.cells.resolution_m, g.floor_band_m, g.robot_height_m);
  std::string why;
  const std::string band = "rumi_band_m: [" + std::to_string(g.floor_band_m) + ", " +
                           std::to_string(g.robot_height_m) + "]";
  if (!WriteMapServerGrid(plan, (fs::path(out) / "floorplan.pgm").string(),
                          (fs::path(out) / "floorplan.yaml").string(),
                          {"# rumi synth: the true floor plan, world frame (groundtruth.txt)", band}, &why)) {
    spdlog::error("synth: {}", why);
    return false;
  }
  return true;
}


struct SynthArgs {
  std::string out;
  std::string scenario = "smooth";
  std::string size = "640x480";
  std::string contact_sheet;
  bool calibrate = false;
  bool bench = false;
  bool orb_only = false;
  double sift_peak = 0;
  double grid_robot_height = 0;  // floorplan.pgm's band top; 0: grid.robot_height_m's default
  double grid_resolution = 0;    // floorplan.pgm's cell; 0: grid.resolution_m's default
  bool floorplan_only = false;
  SynthOptions o;
};

bool ParseSize(const std::string& s, int* w, int* h) {
  char x = 0;
  char extra = 0;
  return std::sscanf(s.c_str(), "%d%c%d%c", w, &x, h, &extra) == 3 && (x == 'x' || x == 'X');
}

int RunSynth(SynthArgs& a) {
  if (!ParseSynthScenario(a.scenario, &a.o.scenario)) {
    spdlog::error("unknown scenario '{}'", a.scenario);
    return 2;
  }
  if (!ParseSize(a.size, &a.o.width, &a.o.height)) {
    spdlog::error("bad --size '{}': expected WIDTHxHEIGHT, e.g. 640x480", a.size);
    return 2;
  }
  std::string why;
  if (!a.o.Check(&why)) {
    spdlog::error("synth: {}", why);
    return 2;
  }
  try {
    if (a.bench) {
      const SyntheticSequence seq(a.o);
      const auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < seq.num_frames(); ++i) (void)seq.Render(i);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("synth bench: scenario %s, %d frames %dx%d, %d thread(s): %.2f s, %.1f ms/frame, %.1f fps\n",
                  a.scenario.c_str(), seq.num_frames(), a.o.width, a.o.height, a.o.threads, s,
                  1e3 * s / seq.num_frames(), seq.num_frames() / s);
      return 0;
    }
    if (!a.contact_sheet.empty()) {
      const cv::Mat sheet = SynthContactSheet(a.o, 8, 160, 120);
      if (!cv::imwrite(a.contact_sheet, sheet)) {
        spdlog::error("cannot write {}", a.contact_sheet);
        return 1;
      }
      spdlog::info("contact sheet written to {}", a.contact_sheet);
      if (a.out.empty()) return 0;
    }
    if (a.out.empty()) {
      spdlog::error("synth: output folder required");
      return 2;
    }
    if (a.calibrate) {
      SynthCalibrationOptions co;
      co.work_dir = a.out;
      co.run_colmap = !a.orb_only;
      co.sift_peak_threshold = a.sift_peak;
      const SynthCalibrationReport r = CalibrateSynth(a.o, co);
      std::printf("%s\n", r.Summary().c_str());
      return r.ok ? 0 : 1;
    }
    if (a.floorplan_only) {
      fs::create_directories(a.out);
      return WriteFloorPlan(a.o, a.out, a.grid_robot_height, a.grid_resolution) ? 0 : 1;
    }
    const SynthWriteResult r = SynthesizeSequence(a.o, a.out);
    spdlog::info("synth: wrote {} frames ({} dropped) to {} in {:.1f} s; path {:.2f} m", r.frames_written,
                 r.frames_dropped, a.out, r.render_seconds, r.path_length_m);
    if (!WriteFloorPlan(a.o, a.out, a.grid_robot_height, a.grid_resolution)) return 1;
  } catch (const std::exception& e) {
    spdlog::error("synth: {}", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

void RegisterSynthCommand(CLI::App* app) {
  auto args = std::make_shared<SynthArgs>();
  CLI::App* sub = app->add_subcommand(
      "synth", "generate a challenge sequence with exact ground truth (TUM layout)");
  sub->add_option("out", args->out, "output folder (rgb/, rgb.txt, groundtruth.txt, odometry.txt, imu.csv, camera.yaml, scenario.json)");
  sub->add_option("--scenario", args->scenario, "smooth, blur, dark, drop, weak, kidnap, corridor")
      ->capture_default_str();
  sub->add_option("--seed", args->o.seed, "random seed (same seed -> identical bytes)")->capture_default_str();
  sub->add_option("--frames", args->o.frames, "number of frames (including dropped ones)")->capture_default_str();
  sub->add_option("--fps", args->o.fps, "frame rate")->capture_default_str();
  sub->add_option("--size", args->size, "WIDTHxHEIGHT")->capture_default_str();
  sub->add_option("--hard-start", args->o.hard_start, "first frame of the hard stretch (-1: 40 %)")
      ->capture_default_str();
  sub->add_option("--hard-length", args->o.hard_length, "hard stretch length in frames (-1: scenario default)")
      ->capture_default_str();
  sub->add_option("--hard-period", args->o.hard_period,
                  "repeat the hard stretch every N frames (dark, drop; 0: once): a loss every few seconds")
      ->capture_default_str();
  sub->add_option("--threads", args->o.threads, "render threads (1 or 2)")->capture_default_str();
  sub->add_option("--supersample", args->o.supersample, "n x n rays per pixel (1: 4x faster, aliased edges)")
      ->capture_default_str();
  sub->add_option("--noise", args->o.noise_sigma, "read noise sigma, grey levels")->capture_default_str();
  sub->add_option("--blur-rate", args->o.blur_peak_rate_deg, "blur: peak yaw rate, deg/s")->capture_default_str();
  sub->add_option("--blur-shake", args->o.blur_shake_rate_deg, "blur: 8 Hz shake angular speed, deg/s")
      ->capture_default_str();
  sub->add_option("--blur-gain", args->o.blur_gain, "blur: exposure gain in the stretch")->capture_default_str();
  sub->add_option("--blur-exposure", args->o.blur_exposure_frac, "blur: shutter time / frame interval in the stretch")
      ->capture_default_str();
  sub->add_option("--drop-turn", args->o.drop_turn_deg, "drop: yaw turned while frames are missing, deg")
      ->capture_default_str();
  sub->add_option("--dark-gain", args->o.dark_gain, "dark: exposure gain at the bottom")->capture_default_str();
  sub->add_option("--weak-amplitude", args->o.weak_amplitude, "weak/corridor: texture amplitude left")
      ->capture_default_str();
  sub->add_option("--contact-sheet", args->contact_sheet, "write an 8-thumbnail PNG contact sheet here");
  sub->add_option("--grid-robot-height", args->grid_robot_height,
                  "top of the band floorplan.pgm is cut at, metres (as grid.robot_height_m; default its default)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--grid-resolution", args->grid_resolution,
                  "cell side of floorplan.pgm, metres (as grid.resolution_m; default its default)")
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--floorplan-only", args->floorplan_only,
                "write only floorplan.pgm/.yaml (same scenario, seed and options), no frames");
  sub->add_flag("--calibrate", args->calibrate,
                "check the hard stretch: ORB counts and a COLMAP exhaustive run on a window (slow); OUT is the work folder");
  sub->add_flag("--orb-only", args->orb_only, "with --calibrate: ORB counts only, no COLMAP");
  sub->add_option("--sift-peak-threshold", args->sift_peak, "with --calibrate: COLMAP SIFT peak threshold (0: its default)");
  sub->add_flag("--bench", args->bench, "render all frames in memory and print the speed");
  sub->callback([args] {
    const int rc = RunSynth(*args);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace rumi::cli
