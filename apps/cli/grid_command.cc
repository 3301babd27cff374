// `rumi grid RUN`: the 2D occupancy grid of a saved map (a rumid state folder,
// an eval run folder, or a map file): grid.pgm + grid.yaml (ROS map_server),
// grid.png (preview with the trajectory) and grid_trajectory.txt (TUM, in the
// grid's frame) in the run folder or --out.
#include <filesystem>
#include <fmt/format.h>
#include <iostream>
#include <memory>
#include <sstream>

#include "common/trajectory.h"
#include "apps/config/rumi_config.h"
#include "apps/cli/commands.h"
#include "common/trajectory_eval.h"
#include "manager/grid/grid_file.h"
#include "manager/grid/grid_score.h"
#include "manager/map_file.h"
#include "manager/map_grid.h"

namespace rumi::cli {
namespace fs = std::filesystem;

namespace {

[[noreturn]] void Fail(const std::string& why, int code = 1) {
  std::cerr << "rumi grid: " << why << "\n";
  throw CLI::RuntimeError(code);
}

}  // namespace

void RegisterGridCommand(CLI::App* app) {
  struct Args {
    std::string run, config, odometry, out;
    double camera_height = -1;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app->add_subcommand("grid", "2D occupancy grid of a saved map (ROS map_server PGM + YAML, PNG)");
  cmd->add_option("run", a->run, "a rumid state folder, an eval run folder (holding map.rumi) or a map file")
      ->required();
  cmd->add_option("--config", a->config, "rumi config (its grid: section)");
  cmd->add_option("--camera-height", a->camera_height, "camera above the floor, metres (the scale without odometry)");
  cmd->add_option("--odometry", a->odometry, "the robot's poses (TUM, metric, z up); default: those in the map");
  cmd->add_option("--out", a->out, "folder for the grid files (default: the run folder)");
  cmd->callback([a] {
    GridOptions o;
    try {
      o = LoadRumiConfig(a->config).grid;
    } catch (const ConfigError& e) {
      Fail(e.what(), 2);
    }
    if (a->camera_height >= 0) o.frame.camera_height_m = a->camera_height;
    std::string why;
    if (!o.Check(&why)) Fail("grid: " + why, 2);
    const fs::path run = a->run;
    if (!fs::exists(run)) Fail(a->run + ": no such folder or map file");
    const fs::path map_path = fs::is_directory(run) ? run / "map.rumi" : run;
    const fs::path out = a->out.empty() ? (fs::is_directory(run) ? run : run.parent_path()) : fs::path(a->out);
    GlobalMap map;
    if (!LoadGlobalMap(map_path.string(), &map, &why)) Fail(why);
    Trajectory odometry;
    try {
      if (!a->odometry.empty()) odometry = ReadTumTrajectory(a->odometry);
    } catch (const std::exception& e) {
      Fail(e.what());
    }
    MapGridResult r;
    if (!WriteMapGrid(map, o, odometry, out.string(), &r)) Fail(map_path.string() + ": " + r.why, r.no_frame ? 4 : 1);
    std::cout << r.Summary() << "\nwrote " << (out / "grid.yaml").string()
              << ", grid.pgm, grid.png, grid_trajectory.txt\n";
  });
}

void AddEvalGridCommand(CLI::App* eval) {
  struct Args {
    std::string run, sequence, diff;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = eval->add_subcommand(
      "grid", "score a grid (rumi grid's output) against a generated sequence's true floor plan: IoU and coverage");
  cmd->add_option("run", a->run, "folder holding grid.yaml and grid_trajectory.txt")->required();
  cmd->add_option("sequence", a->sequence, "the `rumi synth` folder (floorplan.yaml, groundtruth.txt)")->required();
  cmd->add_flag("--json", a->json, "one JSON object");
  cmd->add_option("--diff", a->diff,
                  "PNG of the comparison in the truth's frame: walls found black, called free red, unknown blue; "
                  "free found white, unknown light grey, called a wall orange");
  cmd->callback([a] {
    const fs::path run = a->run, seq = a->sequence;
    MapServerGrid est, truth;
    std::string why;
    if (!ReadMapServerGrid((run / "grid.yaml").string(), &est, &why)) Fail(why);
    if (!ReadMapServerGrid((seq / "floorplan.yaml").string(), &truth, &why)) Fail(why);
    AteResult fit;
    try {
      fit = ComputeAte(ReadTumTrajectory((run / "grid_trajectory.txt").string()),
                       ReadTumTrajectory((seq / "groundtruth.txt").string()), AteOptions());
    } catch (const std::exception& e) {
      Fail(std::string("aligning the grid's trajectory to the ground truth: ") + e.what());
    }
    std::vector<CellMatch> labels;
    const GridScore g = ScoreGrid(est, truth, fit.S_gt_est.Inverse(), a->diff.empty() ? nullptr : &labels);
    if (!a->diff.empty() && !WriteGridComparison(truth, labels, a->diff, &why)) Fail(why);
    if (a->json) {
      std::cout << fmt::format(
          "{{\"occupied_iou\": {:.4f}, \"free_iou\": {:.4f}, \"coverage\": {:.4f}, \"true_free_cells\": {}, "
          "\"true_occupied_cells\": {}, \"observed_cells\": {}, \"alignment_scale\": {:.4f}, "
          "\"alignment_rmse_m\": {:.4f}, \"walls_found\": {}, \"walls_as_free\": {}, \"walls_unknown\": {}, "
          "\"false_walls\": {}}}\n",
          g.occupied_iou, g.free_iou, g.coverage, g.true_free, g.true_occupied, g.observed, fit.S_gt_est.scale(),
          fit.translation.rmse, g.walls_found, g.walls_as_free, g.walls_unknown, g.false_walls);
    } else {
      std::cout << fmt::format(
          "occupied IoU {:.3f}, free IoU {:.3f} (observed area), coverage of the true free space {:.1f} %; {} cells "
          "compared; trajectory aligned with scale {:.3f}, RMSE {:.3f} m\n"
          "true wall cells: {} found, {} called free, {} unknown; {} free cells called a wall\n",
          g.occupied_iou, g.free_iou, 100 * g.coverage, g.observed, fit.S_gt_est.scale(), fit.translation.rmse,
          g.walls_found, g.walls_as_free, g.walls_unknown, g.false_walls);
    }
  });
}

}  // namespace rumi::cli
