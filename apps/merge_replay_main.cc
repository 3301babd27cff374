// rumi-merge-replay: offline replay of the manager's merge on a saved map
// (e.g. <out>/map.rumi.raw, every submap as received), for diagnosing merges
// of a real run without the three processes.
//   rumi-merge-replay --map FILE [--config FILE] [--trajectory OUT.txt]
//                     [--no-frame-pairs] [--no-post-culling]
//                     [--session-bench OUT_DIR [--rebuild-every N] [--resends] [--bake]]
// --session-bench replays a live session instead: the submaps go to a
// ManagerService (the manager process's core) one by one in the order they
// ended (with --resends, also each front submap cut as the front resends it
// while it grows), with a rebuild after every N, and each rebuild prints its
// time per phase and the process's resident memory (a benchmark of how the
// manager scales with a long session, without the hour it took). With
// --bake, every settled submap is baked into the base after each rebuild (the
// map files saved first): the manager's incremental mode at its most eager,
// as if manager.bake_after_s had passed for all but the newest front submap.
// Prints one line per merge attempt and writes the largest component's
// trajectory (TUM) like merged.txt. Exit 0 on success, 1 on a runtime error,
// 2 on a bad command line or config.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>

#include "apps/config/rumi_config.h"
#include "common/logging.h"
#include "common/pose_jumps.h"
#include "common/process/process_info.h"
#include "manager/global_trajectory.h"
#include "manager/loop_closure.h"
#include "manager/manager_run.h"
#include "manager/manager_service.h"
#include "manager/map_file.h"
#include "manager/merge.h"
#include "manager/merge_audit.h"
#include "manager/odometry_merge.h"
#include "manager/place_merge.h"
#include "manager/post_culling.h"

namespace rumi {
namespace {

Timestamp LastTime(const Submap& s) {
  Timestamp t = 0;
  for (const Keyframe& kf : s.keyframes) t = std::max(t, kf.timestamp);
  for (const FrameRecord& f : s.frames) t = std::max(t, f.timestamp);
  return t;
}

// One submap as the manager receives it: a finished submap, or (with
// resends) a front submap still being built, cut at `until`.
struct SessionEvent {
  Timestamp at;
  int submap;
  bool resend;
};

// Submaps in the order they ended; with resends, each front submap is also
// sent cut at every resend_interval_s of its time, once it has
// resend_min_keyframes (what front_publisher.cc does while it tracks).
std::vector<SessionEvent> SessionEvents(const GlobalMap& raw, const FrontPublisherOptions* resends) {
  std::vector<SessionEvent> events;
  for (size_t i = 0; i < raw.size(); ++i) {
    const Submap& s = raw.submap(int(i));
    events.push_back({LastTime(s), int(i), false});
    if (!resends || resends->resend_interval_s <= 0 || s.source != SubmapSource::kFront || s.keyframes.empty())
      continue;
    const Timestamp step = SecondsToNs(resends->resend_interval_s);
    for (Timestamp t = s.keyframes.front().timestamp + step; t < LastTime(s); t += step) {
      const auto kfs = std::count_if(s.keyframes.begin(), s.keyframes.end(),
                                     [&](const Keyframe& kf) { return kf.timestamp <= t; });
      if (kfs >= resends->resend_min_keyframes) events.push_back({t, int(i), true});
    }
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const SessionEvent& a, const SessionEvent& b) { return a.at < b.at; });
  return events;
}

int SessionBench(const GlobalMap& raw, const RumiConfig& config, const std::string& out, int every, bool resends,
                 bool bake) {
  const std::vector<SessionEvent> events = SessionEvents(raw, resends ? &config.publisher : nullptr);
  ManagerServiceOptions so;
  so.manager = config.manager;
  so.grid = config.grid;
  so.out_dir = out;
  std::error_code ec;
  std::filesystem::remove(so.MapPath(), ec);
  std::filesystem::remove(so.MapPath() + ".raw", ec);
  std::filesystem::remove_all(RawBakedDir(so.MapPath() + ".raw"), ec);
  ManagerService service(so);
  std::string why;
  if (!service.Start(&why)) {
    std::cerr << "rumi-merge-replay: " << why << "\n";
    return 1;
  }
  std::cout << "rebuild\tsubmaps\tkeyframes\tkept\tcomponents\tcomputed\treplayed\ttotal_s\tcopy_s\tmerge_s\t"
               "place_s\todometry_s\tculling_s\tfront_search_s\trevisit_s\trevisit_fused\trevisit_replayed\tsave_raw_s\tsave_map_s\toutputs_s\t"
               "frames\tbaked\trss_mib\n";
  size_t finished = 0;
  for (size_t i = 0; i < events.size(); ++i) {
    const SessionEvent& e = events[i];
    service.AddSubmap(e.resend ? SubmapUntil(raw.submap(e.submap), e.at) : raw.submap(e.submap));
    finished += !e.resend;
    if ((i + 1) % size_t(every) != 0 && i + 1 != events.size()) continue;
    const auto t0 = std::chrono::steady_clock::now();
    // The map file and the raw submaps as the manager's loop writes them.
    const bool map_files = i + 1 == events.size() ||
                           MapSaveDue(config.manager_loop, service.SecondsSinceMapSave(),
                                      service.stats().last_map_save_seconds);
    if (!service.Rebuild(&why, nullptr, {}, map_files)) {
      std::cerr << "rumi-merge-replay: " << why << "\n";
      return 1;
    }
    if (bake) {
      if (service.map_files_pending() && !service.WriteOutputs(&why)) {
        std::cerr << "rumi-merge-replay: " << why << "\n";
        return 1;
      }
      service.BakeSettled(1e-9);
    }
    const ManagerStats& st = service.stats();
    const ManagerStats::Phases& p = st.last_rebuild_phases;
    std::cout << fmt::format("{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{}\t{}\t{:.2f}\t{:.2f}\t{:.2f}\t{}\t{}\t{:.0f}\n",
                             st.rebuilds, finished, st.saved_frames, st.saved_frames_postculled, st.components,
                             st.merge_attempts - st.merges_replayed, st.merges_replayed, SecondsSince(t0), p.copy,
                             p.merge, p.place, p.odometry, p.culling, st.culling.seconds_front_search,
                             st.culling.seconds_revisit, st.culling.revisit_fused, st.culling.revisit_submaps_replayed, p.save_raw, p.save_map, p.outputs,
                             st.trajectory_frames, st.baked, ResidentMiB())
              << std::flush;
  }
  return 0;
}

int Main(int argc, char** argv) {
  CLI::App app{"rumi-merge-replay: re-runs the manager's merge on a saved map"};
  std::string map_path, config_path, traj_path, gt_path;
  bool no_frame_pairs = false, no_culling = false;
  int min_back_obs = 0;
  int loop_rounds = 1000;
  double jump_ratio = 0;
  double complete_px = 0;
  app.add_option("--map", map_path, "map file to load (e.g. map.rumi.raw)")->required();
  app.add_option("--config", config_path, "rumi YAML config (section manager:)");
  app.add_option("--trajectory", traj_path, "write the largest component's trajectory here (TUM)");
  app.add_option("--groundtruth", gt_path, "ground truth (TUM): print the merge audit (merge_audit.h)");
  app.add_flag("--no-frame-pairs", no_frame_pairs, "manager.pair_tracked_frames = false");
  app.add_flag("--no-post-culling", no_culling, "skip redundant-keyframe culling");
  app.add_option("--complete-back-tracks", complete_px, "track completion radius (px) for back submaps (0 = off)");
  std::string bench_dir;
  int rebuild_every = 1;
  app.add_option("--session-bench", bench_dir,
                 "replay the submaps as a live session into a manager writing to this folder; print each rebuild");
  app.add_option("--rebuild-every", rebuild_every, "with --session-bench: rebuild after every N submaps")
      ->check(CLI::Range(1, 100000));
  bool resends = false, bake = false, verbose = false;
  app.add_flag("--verbose", verbose, "log what the manager logs (info), not only warnings");
  app.add_flag("--resends", resends,
               "with --session-bench: also send each front submap while it grows, as the front resends it "
               "(front.publisher.resend_interval_s); a rebuild counts as one submap received");
  app.add_flag("--bake", bake,
               "with --session-bench: bake every settled submap into the base after each rebuild (incremental "
               "manager)");
  app.add_option("--back-pose-jumps", jump_ratio,
                 "first drop back keyframes registered off the camera path (what back.pose_jump_ratio does)");
  app.add_option("--min-back-observations", min_back_obs,
                 "first drop back-submap points seen by fewer keyframes (what back.min_point_observations does)");
  app.add_option("--loop-rounds", loop_rounds,
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

  GlobalMap map;
  std::string why;
  if (!LoadRawSubmaps(map_path, &map, &why)) {
    std::cerr << "rumi-merge-replay: cannot load " << map_path << ": " << why << "\n";
    return 1;
  }
  // The audit reloads the raw map: it gets the same removal, silently.
  const auto drop_jumps = [&](GlobalMap* m, bool print) {
    for (size_t i = 0; jump_ratio > 0 && i < m->size(); ++i) {
      Submap& s = m->submap(int(i));
      if (s.source != SubmapSource::kBack) continue;
      const std::vector<size_t> jumps = PoseJumps(s, jump_ratio);
      for (size_t k : jumps)
        if (print)
          std::printf("%s: keyframe %s registered off the camera path, dropped\n", ToString(m->Key(int(i))).c_str(),
                      FormatSeconds(s.keyframes[k].timestamp).c_str());
      DropKeyframesAt(&s, jumps);
    }
  };
  drop_jumps(&map, true);
  if (!bench_dir.empty()) return SessionBench(map, config, bench_dir, rebuild_every, resends, bake);
  if (complete_px > 0) {
    for (size_t i = 0; i < map.size(); ++i)
      if (map.submap(int(i)).source == SubmapSource::kBack) {
        size_t before = 0;
        for (const MapPoint& p : map.submap(int(i)).points) before += p.observations.size();
        const int n = CompleteTracks(&map.submap(int(i)), complete_px);
        std::printf("%s: track completion added %d observations to %zu\n", ToString(map.Key(int(i))).c_str(), n, before);
      }
  }
  if (min_back_obs > 0) {
    for (size_t i = 0; i < map.size(); ++i)
      if (map.submap(int(i)).source == SubmapSource::kBack) {
        const int n = DropWeakPoints(&map.submap(int(i)), min_back_obs);
        std::printf("%s: dropped %d points seen by < %d keyframes, %zu left\n", ToString(map.Key(int(i))).c_str(), n,
                    min_back_obs, map.submap(int(i)).points.size());
      }
  }
  auto reports = MergeAll(&map, config.manager);
  for (MergeReport& r : PlaceMergeAll(&map, config.manager)) reports.push_back(std::move(r));
  for (MergeReport& r : OdometryMergeAll(&map, config.manager)) reports.push_back(std::move(r));
  LoopClosureState loop_state;
  LoopClosureReport loops = CloseLoops(&map, config.manager, &loop_state);
  // As the manager's next rebuilds would: the loops left waiting
  // (loop_max_solves) are closed on the map corrected so far.
  for (int round = 1; loops.waiting > 0 && round < loop_rounds; ++round) {
    const std::vector<bool> fresh(map.size(), false);
    const size_t decided = loop_state.decided.size();
    loops = CloseLoops(&map, config.manager, &loop_state, &fresh);
    if (loop_state.decided.size() == decided) break;  // no loop decided this round: the next would not either
  }
  std::cout << fmt::format("loop closure: {} keyframes searched, {} candidates verified, {} detections, {} loops "
                           "closed, {} keyframes moved, detect {:.2f} s, close {:.2f} s\n",
                           loops.keyframes_queried, loops.candidates_verified, loops.detections, loops.closed,
                           loops.keyframes_moved, loops.seconds_detect, loops.seconds_close);
  for (const LoopReport& l : loops.loops)
    std::cout << fmt::format("loop {} kf {} ({:.2f} s) -> {} kf {} ({:.2f} s): support={} inliers={}/{} closed={} "
                             "shift={:.4f} ({:.1f} % of depth) rot={:.2f}deg scale={:+.4f} reason=\"{}\"\n",
                             ToString(l.edge.query_submap), l.edge.query_keyframe, NsToSeconds(l.edge.query_time),
                             ToString(l.edge.match_submap), l.edge.match_keyframe, NsToSeconds(l.edge.match_time),
                             l.support, l.edge.inliers, l.edge.matches, l.closed, l.shift, 100 * l.shift_ratio,
                             l.rotation_deg, l.scale_change, l.reason);
  for (const MergeReport& r : reports) {
    std::cout << fmt::format(
        "{} + {}: merged={} keyframe_pairs={} frame_pairs={} common_points={} inliers={} inlier_ratio={:.3f} "
        "method={} scale={:.4f} refine_rmse={:.2f}->{:.2f}px poses_agree={}/{} pose_deg={:.2f} pose_offset={:.3f} "
        "fused={} weld_shift={:.4f}/{:.4f}{} align={:.4f}s refine={:.4f}s weld={:.4f}s{}\n",
        ToString(r.front), ToString(r.back), r.merged, r.keyframe_pairs, r.frame_pairs, r.common_points, r.inliers,
        r.inlier_ratio, r.init_method.empty() ? "-" : r.init_method, r.S_bf.scale(), r.refine_initial_rmse_px,
        r.refine_final_rmse_px, r.agreeing_pairs, r.pose_pairs, r.pose_angle_deg, r.pose_offset_ratio,
        r.fused_points, r.welding.median_shift_ratio, r.welding.max_shift_ratio,
        r.welding.applied ? "" : r.welding.reverted ? "(not applied)" : "(off)", r.seconds_align, r.seconds_refine,
        r.seconds_weld,
        r.reason.empty() ? "" : " reason=\"" + r.reason + "\"");
  }
  if (!gt_path.empty()) {
    GlobalMap raw;
    if (!LoadRawSubmaps(map_path, &raw, &why)) {
      std::cerr << "rumi-merge-replay: cannot load " << map_path << ": " << why << "\n";
      return 1;
    }
    drop_jumps(&raw, false);
    Trajectory gt;
    try {
      gt = ReadTumTrajectory(gt_path);
    } catch (const std::exception& e) {
      std::cerr << "rumi-merge-replay: " << e.what() << "\n";
      return 1;
    }
    auto opt = [](const std::optional<double>& v) { return v ? fmt::format("{:.4f}", *v) : std::string("-"); };
    for (const MergeAuditRow& m : AuditMerges(raw, AttemptsOf(reports), gt)) {
      std::cout << fmt::format("audit {} {} + {}: accepted={} frames={}+{} ate_a={} ate_b={} ate_joint={} "
                               "ate_a_joint={} harmful={}{}{}\n",
                               m.kind, m.a, m.b, m.accepted, m.a_frames, m.b_frames, opt(m.ate_a), opt(m.ate_b),
                               opt(m.ate_joint), opt(m.ate_a_joint), m.harmful,
                               m.rejected_by.empty() ? "" : " rejected_by=" + m.rejected_by,
                               m.note.empty() ? "" : " note=\"" + m.note + "\"");
    }
  }
  if (!no_culling) {
    const CullingReport c = CullRedundantKeyframes(&map, config.manager);
    std::printf("post-culling: keyframes %d -> %d (back %d, front %d culled); back keyframes examined %d, "
                "median share of points seen by >= %d others %.2f (needs %.2f); %d front points found in back "
                "keyframes\n",
                c.keyframes_before, c.keyframes_after, c.culled_back, c.culled_front, c.back_examined,
                config.manager.culling_min_observers, c.back_redundant_share_median,
                config.manager.culling_redundant_ratio, c.front_points_found);
    std::printf("revisit culled: %d by fused points, %d by loop detections; front keyframes left per submap:",
                c.culled_revisit, c.culled_revisit_detected);
    for (size_t i = 0; i < map.size(); ++i)
      if (map.submap(int(i)).source == SubmapSource::kFront) std::printf(" %zu", map.submap(int(i)).keyframes.size());
    std::printf("\n");
  }
  const int root = map.size() ? map.LargestComponent() : -1;
  const auto traj = root >= 0 ? ComputeGlobalTrajectory(map, root) : std::vector<GlobalPose>();
  int components = 0;
  for (size_t i = 0; i < map.size(); ++i) components += map.Component(int(i)) == int(i);
  std::cout << fmt::format("submaps={} components={} largest_component_frames={}\n", map.size(), components,
                           traj.size());
  try {
    if (!traj_path.empty()) WriteTumTrajectory(traj_path, ToTrajectory(traj));
  } catch (const std::exception& e) {
    std::cerr << "rumi-merge-replay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace rumi

int main(int argc, char** argv) { return rumi::Main(argc, argv); }
