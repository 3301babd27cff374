// `rumi calibrate --images DIR --board 9x6 --out camera.yaml`: the camera's
// intrinsics and distortion from photos of a chessboard (docs/calibrate.md),
// written as the `camera:` section of a rumi config; refused, naming what was
// wrong, when the photos cannot give a trustworthy one.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include <atomic>
#include <chrono>

#include "common/atomic_file.h"
#include "common/calibration.h"
#include "common/process/exit_codes.h"
#include "common/process/signals.h"
#include "common/trajectory_plot.h"
#include "ipc/link/link_endpoint.h"
#include "ipc/link/link_frame_image.h"
#include "apps/config/rumi_config.h"
#include "apps/cli/commands.h"

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

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// `--link`: views picked from the robot's stream while a person moves the
// board in front of it (docs/calibrate.md "From the robot's link"). The robot
// is asked to stand still. Ends when the views calibrate (at least
// `target` of them and the coverage reached), at the timeout, or on Ctrl-C;
// then the views it has are calibrated (and refused if they cannot be).
std::vector<CalibrationImage> CollectFromLink(const LinkOptions& lo, int target, double timeout_s,
                                              const std::string& save_dir, const CalibrationOptions& o,
                                              std::ostream& log) {
  const std::string& bind = lo.bind;
  const int robot_id = lo.robot_id;
  std::unique_ptr<LinkEndpoint> link;
  try {
    link = std::make_unique<LinkEndpoint>(lo);
  } catch (const std::exception& e) {
    Fail(e.what(), kExitBadInput);
  }
  if (!save_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(save_dir, ec);
    if (ec) Fail("--save-views " + save_dir + ": " + ec.message(), kExitError);
  }
  link->SetHalt(true);  // the board moves, not the robot
  log << "listening on " << bind << " for robot " << robot_id << " (asked to stand still); hold the "
      << o.board_cols << "x" << o.board_rows << " board still in view, then move it; " << target
      << " views wanted\n";
  log.flush();
  ProcessSignals::Install();
  const std::atomic<bool>* stop = ProcessSignals::stop();
  CalibrationViewPicker picker(o);
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  size_t next_try = static_cast<size_t>(target);
  uint64_t frames = 0, unreadable = 0, other_size = 0;
  while (!stop->load() && elapsed() < timeout_s) {
    LinkFrameOut f;
    if (!link->NextFrame(&f, 200, stop)) continue;
    ++frames;
    const std::string name = "link_" + std::to_string(f.frame.frame_id) + ".png";
    const CalibrationViewPicker::Verdict v = picker.Offer(DecodeLinkFrame(f.frame), name);
    unreadable += v == CalibrationViewPicker::Verdict::kUnreadable;
    other_size += v == CalibrationViewPicker::Verdict::kOtherSize;
    if (v != CalibrationViewPicker::Verdict::kKept) continue;
    const CalibrationImage& view = picker.views().back();
    if (!save_dir.empty()) {
      try {
        WritePng((std::filesystem::path(save_dir) / name).string(), view.grey);
      } catch (const std::exception& e) {
        Fail(e.what(), kExitError);
      }
    }
    std::vector<std::string> empty;
    const double coverage = picker.Coverage(&empty);
    log << fmt::format("view {:>2}: {} ({}x{}), coverage {:.0f} %{}\n", picker.views().size(), name,
                       view.grey.cols, view.grey.rows, 100 * coverage,
                       empty.empty() ? "" : " (little or nothing in: " + Join(empty) + ")");
    log.flush();
    if (picker.views().size() < next_try || coverage < o.min_coverage) continue;
    const CalibrationResult r = CalibrateCamera(picker.views(), o);
    if (r.ok) break;
    log << "not yet: " << r.why << "\n";
    log.flush();
    next_try = picker.views().size() + 3;
  }
  log << fmt::format("{} frames in {:.0f} s, {} views kept", frames, elapsed(), picker.views().size());
  if (unreadable) log << ", " << unreadable << " frames did not decode";
  if (other_size) log << ", " << other_size << " frames of another size than the first";
  log << (frames ? "" : ": nothing came from the robot (is it streaming to this address?)") << "\n";
  return picker.views();
}

}  // namespace

void RegisterCalibrateCommand(CLI::App* app) {
  struct Args {
    std::string images, link, board = "9x6", out, save_views, link_key;
    int robot_id = 1, views = 20;
    double timeout_s = 300;
    bool overwrite = false, link_insecure = false;
    CalibrationOptions o;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app->add_subcommand(
      "calibrate", "camera intrinsics and distortion from photos of a chessboard: writes a rumi camera: section");
  CLI::Option* images =
      cmd->add_option("--images", a->images, "folder of photos of the board, all by the camera at the size it streams");
  CLI::Option* link = cmd->add_option("--link", a->link,
                                      "or: pick the views from the robot's stream, listening on HOST:PORT "
                                      "(source.link.bind)");
  images->excludes(link);
  link->excludes(images);
  cmd->add_option("--robot-id", a->robot_id, "--link: the robot's id")->capture_default_str()->check(CLI::Range(0, 65535));
  cmd->add_option("--link-key", a->link_key, "--link: the robot's key file (source.link.key_file)");
  cmd->add_flag("--link-insecure", a->link_insecure, "--link: an unauthenticated link (source.link.insecure)");
  cmd->add_option("--views", a->views, "--link: calibrate once this many views are kept (and the coverage reached)")
      ->capture_default_str()
      ->check(CLI::Range(3, 1000));
  cmd->add_option("--timeout-s", a->timeout_s, "--link: stop picking after this long and calibrate what was kept")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--save-views", a->save_views, "--link: write every kept view here as PNG (for --images later)");
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
    if (a->images.empty() == a->link.empty()) Fail("give --images DIR or --link HOST:PORT", kExitBadInput);
    // Without --out stdout is the config alone (`> camera.yaml` works).
    std::ostream& log = a->out.empty() ? std::cerr : std::cout;
    std::vector<CalibrationImage> images;
    if (!a->link.empty()) {
      if (a->link_key.empty() == !a->link_insecure)
        Fail("--link needs the robot's key (--link-key FILE, as source.link.key_file) or, for an "
             "unauthenticated lab link, --link-insecure",
             kExitBadInput);
      LinkOptions lo;
      lo.bind = a->link;
      lo.robot_id = a->robot_id;
      lo.key_file = a->link_key;
      lo.insecure = a->link_insecure;
      images = CollectFromLink(lo, a->views, a->timeout_s, a->save_views, o, log);
    } else {
      try {
        images = ReadCalibrationImages(a->images);
      } catch (const std::exception& e) {
        Fail(e.what(), kExitBadInput);
      }
    }
    const CalibrationResult r = CalibrateCamera(images, o);
    log << (a->link.empty() ? a->images : "link " + a->link) << ": " << r.Summary() << "\n";
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
