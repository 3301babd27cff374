// rumi-merge-replay: offline replay of the manager's merge on a saved map
// (e.g. <out>/map.rumi.raw, every submap as received), for diagnosing merges
// of a real run without the three processes (manager/merge_replay.h).
//   rumi-merge-replay --map FILE [--config FILE] [--trajectory OUT.txt]
//                     [--no-frame-pairs] [--no-post-culling]
//                     [--session-bench OUT_DIR [--rebuild-every N] [--resends] [--bake]]
// --session-bench replays a live session instead, a rebuild after every N
// submaps, each printing its time per phase and the resident memory
// (manager/session_replay.h). Prints one line per merge attempt and writes
// the largest component's trajectory (TUM) like merged.txt. Exit 0 on
// success, 1 on a runtime error, 2 on a bad command line or config.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <iostream>

#include "apps/config/rumi_config.h"
#include "manager/merge_replay.h"
#include "manager/session_replay.h"

namespace rumi {
namespace {

int Main(int argc, char** argv) {
  CLI::App app{"rumi-merge-replay: re-runs the manager's merge on a saved map"};
  MergeReplayOptions o;
  std::string config_path;
  bool no_frame_pairs = false, no_culling = false;
  app.add_option("--map", o.map_path, "map file to load (e.g. map.rumi.raw)")->required();
  app.add_option("--config", config_path, "rumi YAML config (section manager:)");
  app.add_option("--trajectory", o.trajectory_path, "write the largest component's trajectory here (TUM)");
  app.add_option("--groundtruth", o.groundtruth_path, "ground truth (TUM): print the merge and loop audits (merge_audit.h, loop_audit.h)");
  app.add_flag("--no-frame-pairs", no_frame_pairs, "manager.pair_tracked_frames = false");
  app.add_flag("--no-post-culling", no_culling, "skip redundant-keyframe culling");
  app.add_option("--complete-back-tracks", o.complete_back_px,
                 "track completion radius (px) for back submaps (0 = off)");
  std::string bench_dir;
  SessionReplayOptions so;
  app.add_option("--session-bench", bench_dir,
                 "replay the submaps as a live session into a manager writing to this folder; print each rebuild");
  app.add_option("--rebuild-every", so.rebuild_every, "with --session-bench: rebuild after every N submaps")
      ->check(CLI::Range(1, 100000));
  bool resends = false, verbose = false;
  app.add_flag("--verbose", verbose, "log what the manager logs (info), not only warnings");
  app.add_flag("--resends", resends,
               "with --session-bench: also send each front submap while it grows, as the front resends it "
               "(front.publisher.resend_interval_s); a rebuild counts as one submap received");
  app.add_flag("--bake", so.bake,
               "with --session-bench: bake every settled submap into the base after each rebuild (incremental "
               "manager)");
  app.add_option("--back-pose-jumps", o.back_pose_jump_ratio,
                 "first drop back keyframes registered off the camera path (what back.pose_jump_ratio does)");
  app.add_option("--min-back-observations", o.min_back_observations,
                 "first drop back-submap points seen by fewer keyframes (what back.min_point_observations does)");
  app.add_option("--loop-rounds", o.loop_rounds,
                 "loop closure rounds at most (each as one rebuild of the manager would close them)")
      ->check(CLI::Range(1, 100000));
  CLI11_PARSE(app, argc, argv);

  RumiConfig config;
  try {
    config = LoadRumiConfig(config_path);
  } catch (const ConfigError& e) {
    std::cerr << "rumi-merge-replay: " << e.what() << "\n";
    return 2;
  }
  if (no_frame_pairs) config.manager.pair_tracked_frames = false;
  spdlog::set_level(verbose ? spdlog::level::info : spdlog::level::warn);
  o.manager = so.service.manager = config.manager;
  o.post_culling = !no_culling;
  so.service.grid = config.grid;
  so.service.out_dir = bench_dir;
  so.loop = config.manager_loop;
  if (resends) {
    so.resend_interval_s = config.publisher.resend_interval_s;
    so.resend_min_keyframes = config.publisher.resend_min_keyframes;
  }
  GlobalMap map;
  std::string why;
  const bool ok = LoadReplayMap(o.map_path, o.back_pose_jump_ratio, true, &map, &why) &&
                  (bench_dir.empty() ? ReplayMerges(&map, o, &why) : ReplaySession(map, so, &why));
  if (!ok) std::cerr << "rumi-merge-replay: " << why << "\n";
  return ok ? 0 : 1;
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
