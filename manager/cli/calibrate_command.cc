// `rumi calibrate --images DIR --board 9x6 --out camera.yaml`: the camera's
// intrinsics and distortion from photos of a chessboard (docs/calibrate.md),
// written as the `camera:` section of a rumi config; refused, naming what was
// wrong, when the photos cannot give a trustworthy one.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "common/atomic_file.h"
#include "common/calibration.h"
#include "common/process/exit_codes.h"
#include "configs/rumi_config.h"
#include "manager/cli/commands.h"

namespace rumi::cli {
namespace {

[[noreturn]] void Fail(const std::string& why, int code) {
  std::cerr << "rumi calibrate: " << why << "\n";
  throw CLI::RuntimeError(code);
}

// "9x6" -> 9, 6.
bool ParseBoard(const std::string& s, int* cols, int* rows) {
  int n = 0;
  return std::sscanf(s.c_str(), "%dx%d%n", cols, rows, &n) == 2 && n == static_cast<int>(s.size());
}

}  // namespace

void RegisterCalibrateCommand(CLI::App* app) {
  struct Args {
    std::string images, board = "9x6", out;
    bool overwrite = false;
    CalibrationOptions o;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app->add_subcommand(
      "calibrate", "camera intrinsics and distortion from photos of a chessboard: writes a rumi camera: section");
  cmd->add_option("--images", a->images, "folder of photos of the board, all by the camera at the size it streams")
      ->required();
  cmd->add_option("--board", a->board, "inner corners COLSxROWS (a board of 10x7 squares is 9x6)")
      ->capture_default_str();
  cmd->add_option("--square", a->o.square_m, "side of a square, metres (the intrinsics do not depend on it)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--pattern", a->o.pattern, "calibration target (ChArUco: planned)")
      ->capture_default_str()
      ->check(CLI::IsMember({"chessboard"}));
  cmd->add_option("--min-views", a->o.min_views, "refuse with fewer photos showing the whole board")
      ->capture_default_str();
  cmd->add_option("--min-coverage", a->o.min_coverage, "refuse when the boards reach less of the image (0-1)")
      ->capture_default_str();
  cmd->add_option("--max-rms", a->o.max_rms_px, "refuse above this reprojection RMS, pixels")->capture_default_str();
  cmd->add_option("--k3-min-views", a->o.k3_min_views, "fit k3 from this many views on (else 0)")
      ->capture_default_str();
  cmd->add_option("--out", a->out, "write the config here (default: print it)");
  cmd->add_flag("--overwrite", a->overwrite, "replace an existing --out file");
  cmd->callback([a] {
    CalibrationOptions& o = a->o;
    if (!ParseBoard(a->board, &o.board_cols, &o.board_rows))
      Fail("--board '" + a->board + "': give the inner corners as COLSxROWS, e.g. 9x6", kExitBadInput);
    std::string why;
    if (!o.Check(&why)) Fail(why, kExitBadInput);
    if (!a->out.empty() && !a->overwrite && std::filesystem::exists(a->out))
      Fail(a->out + " exists: choose another --out (then merge its camera: section into your config) or add "
           "--overwrite",
           kExitBadInput);
    std::vector<CalibrationImage> images;
    try {
      images = ReadCalibrationImages(a->images);
    } catch (const std::exception& e) {
      Fail(e.what(), kExitBadInput);
    }
    const CalibrationResult r = CalibrateCamera(images, o);
    // Without --out stdout is the config alone (`> camera.yaml` works).
    (a->out.empty() ? std::cerr : std::cout) << a->images << ": " << r.Summary() << "\n";
    if (!r.ok) Fail("refused, nothing written", kExitBadInput);

    const std::string yaml = CalibrationConfigYaml(r, o);
    try {  // what every rumi process will make of it
      LoadRumiConfigString(yaml, a->out.empty() ? "<calibration>" : a->out);
    } catch (const ConfigError& e) {
      Fail(std::string("the written section does not load back: ") + e.what(), kExitError);
    }
    if (a->out.empty()) {
      std::cout << yaml;
      return;
    }
    if (!WriteFileAtomically(a->out, yaml, &why)) Fail(why, kExitError);
    try {
      const RumiConfig c = LoadRumiConfig(a->out);
      if (!c.has_camera || std::abs(c.camera.fx - r.camera.fx) > 1e-6 * r.camera.fx)
        Fail(a->out + ": reads back other than written", kExitError);
    } catch (const ConfigError& e) {
      Fail(e.what(), kExitError);
    }
    std::cout << "wrote " << a->out << ": put its camera: section into your config (docs/calibrate.md)\n";
  });
}

}  // namespace rumi::cli
