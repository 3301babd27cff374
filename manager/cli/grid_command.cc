// `rumi grid RUN`: the 2D occupancy grid of a saved map (a rumid state folder,
// an eval run folder, or a map file): grid.pgm + grid.yaml (ROS map_server),
// grid.png (preview with the trajectory) and grid_trajectory.txt (TUM, in the
// grid's frame) in the run folder or --out.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "common/trajectory.h"
#include "configs/rumi_config.h"
#include "manager/cli/commands.h"
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

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
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
    if (map.size() == 0) Fail(map_path.string() + ": the map holds no submap");
    const int component = map.LargestComponent();
    const std::vector<GridKeyframe> kfs = GridKeyframesOf(map, component);
    Trajectory odometry;
    try {
      odometry = a->odometry.empty() ? OdometryOf(map, component) : ReadTumTrajectory(a->odometry);
    } catch (const std::exception& e) {
      Fail(e.what());
    }
    const GridFrame frame = EstimateGridFrame(kfs, odometry, o.frame);
    if (!frame.ok) Fail("no metric grid: " + frame.why, 4);
    GridBuildStats stats;
    const OccupancyGrid grid = BuildGrid(kfs, frame.S_gm, o, &stats);

    std::error_code ec;
    fs::create_directories(out, ec);
    Trajectory traj;  // the keyframes' path, in the grid frame
    std::vector<Eigen::Vector2d> path;
    for (const GridKeyframe& k : kfs) {
      traj.push_back({k.timestamp, frame.S_gm.TransformPose(k.T_wc)});
      path.push_back(traj.back().T_wc.translation().head<2>());
    }
    const auto& q = frame.S_gm.rotation();
    const auto& t = frame.S_gm.translation();
    const std::vector<std::string> extra = {
        "# rumi: the grid frame is metric, z up, the floor at z = 0",
        "rumi_scale_source: " + frame.scale_source,
        "rumi_up_source: " + frame.up_source,
        "rumi_camera_height_m: " + Fixed(frame.camera_height_m, 4),
        "rumi_map_to_grid: {s: " + Fixed(frame.S_gm.scale(), 9) + ", q_xyzw: [" + Fixed(q.x(), 9) + ", " +
            Fixed(q.y(), 9) + ", " + Fixed(q.z(), 9) + ", " + Fixed(q.w(), 9) + "], t: [" + Fixed(t.x(), 6) + ", " +
            Fixed(t.y(), 6) + ", " + Fixed(t.z(), 6) + "]}",
        "rumi_keyframes: " + std::to_string(stats.keyframes)};
    if (!WriteMapServerGrid(grid, (out / "grid.pgm").string(), (out / "grid.yaml").string(), extra, &why) ||
        !WriteGridPreview(grid, path, (out / "grid.png").string(), &why))
      Fail(why);
    try {
      WriteTumTrajectory((out / "grid_trajectory.txt").string(), traj);
    } catch (const std::exception& e) {
      Fail(e.what());
    }
    int counts[3] = {0, 0, 0};
    for (int r = 0; r < grid.height(); ++r)
      for (int c = 0; c < grid.width(); ++c) ++counts[static_cast<int>(grid.State(c, r))];
    const double cell2 = grid.resolution() * grid.resolution();
    std::cout << "grid " << grid.width() << " x " << grid.height() << " cells of " << grid.resolution() << " m: "
              << Fixed(counts[1] * cell2, 2) << " m^2 free, " << Fixed(counts[2] * cell2, 2) << " m^2 occupied; "
              << stats.keyframes << " keyframes, " << stats.rays_hit << " obstacle rays, " << stats.rays_floor
              << " floor rays, " << stats.points_overhead << " points overhead; scale from " << frame.scale_source
              << ", camera " << Fixed(frame.camera_height_m, 3) << " m above the floor; " << Fixed(stats.seconds, 3)
              << " s\n"
              << "wrote " << (out / "grid.yaml").string() << ", grid.pgm, grid.png, grid_trajectory.txt\n";
  });
}

void AddEvalGridCommand(CLI::App* eval) {
  struct Args {
    std::string run, sequence;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = eval->add_subcommand(
      "grid", "score a grid (rumi grid's output) against a generated sequence's true floor plan: IoU and coverage");
  cmd->add_option("run", a->run, "folder holding grid.yaml and grid_trajectory.txt")->required();
  cmd->add_option("sequence", a->sequence, "the `rumi synth` folder (floorplan.yaml, groundtruth.txt)")->required();
  cmd->add_flag("--json", a->json, "one JSON object");
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
    const GridScore g = ScoreGrid(est, truth, fit.S_gt_est.Inverse());
    if (a->json) {
      std::cout << "{\"occupied_iou\": " << Fixed(g.occupied_iou, 4) << ", \"free_iou\": " << Fixed(g.free_iou, 4)
                << ", \"coverage\": " << Fixed(g.coverage, 4) << ", \"true_free_cells\": " << g.true_free
                << ", \"true_occupied_cells\": " << g.true_occupied << ", \"observed_cells\": " << g.observed
                << ", \"alignment_scale\": " << Fixed(fit.S_gt_est.scale(), 4)
                << ", \"alignment_rmse_m\": " << Fixed(fit.translation.rmse, 4) << "}\n";
    } else {
      std::cout << "occupied IoU " << Fixed(g.occupied_iou, 3) << ", free IoU " << Fixed(g.free_iou, 3)
                << " (observed area), coverage of the true free space " << Fixed(100 * g.coverage, 1) << " %; "
                << g.observed << " cells compared; trajectory aligned with scale "
                << Fixed(fit.S_gt_est.scale(), 3) << ", RMSE " << Fixed(fit.translation.rmse, 3) << " m\n";
    }
  });
}

}  // namespace rumi::cli
