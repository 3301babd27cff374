#include "manager/merge_replay.h"

#include <fmt/format.h>

#include <cstdio>
#include <iostream>
#include <optional>
#include <vector>

#include "common/pose_jumps.h"
#include "common/trajectory.h"
#include "manager/global_trajectory.h"
#include "manager/loop_audit.h"
#include "manager/loop_closure.h"
#include "manager/map_file.h"
#include "manager/merge.h"
#include "manager/merge_audit.h"
#include "manager/odometry_merge.h"
#include "manager/place_merge.h"
#include "manager/post_culling.h"

namespace rumi {
namespace {

// Track completion and weak-point removal on the back submaps, as the back
// would have done them.
void PrepareBackSubmaps(GlobalMap* map, const MergeReplayOptions& o) {
  if (o.complete_back_px > 0) {
    for (size_t i = 0; i < map->size(); ++i)
      if (map->submap(int(i)).source == SubmapSource::kBack) {
        size_t before = 0;
        for (const MapPoint& p : map->submap(int(i)).points) before += p.observations.size();
        const int n = CompleteTracks(&map->submap(int(i)), o.complete_back_px);
        std::printf("%s: track completion added %d observations to %zu\n", ToString(map->Key(int(i))).c_str(), n,
                    before);
      }
  }
  if (o.min_back_observations > 0) {
    for (size_t i = 0; i < map->size(); ++i)
      if (map->submap(int(i)).source == SubmapSource::kBack) {
        const int n = DropWeakPoints(&map->submap(int(i)), o.min_back_observations);
        std::printf("%s: dropped %d points seen by < %d keyframes, %zu left\n", ToString(map->Key(int(i))).c_str(),
                    n, o.min_back_observations, map->submap(int(i)).points.size());
      }
  }
}

// As the manager's next rebuilds would: the loops left waiting
// (loop_max_solves) are closed on the map corrected so far.
void CloseLoopsAndPrint(GlobalMap* map, const MergeReplayOptions& o, const Trajectory* gt) {
  LoopClosureState loop_state;
  LoopClosureReport loops = CloseLoops(map, o.manager, &loop_state);
  for (int round = 1; loops.waiting > 0 && round < o.loop_rounds; ++round) {
    const std::vector<bool> fresh(map->size(), false);
    const size_t decided = loop_state.decided.size();
    loops = CloseLoops(map, o.manager, &loop_state, &fresh);
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
  if (!gt) return;
  // The loop audit of `rumi eval run`, on the loops of the last round (every
  // loop decided, those of earlier rounds included).
  nlohmann::json rows = nlohmann::json::array();
  for (const LoopReport& l : loops.loops) rows.push_back(LoopReportToJson(l));
  int closed = 0, right = 0, harmful = 0, unjudged = 0;
  auto opt = [](const std::optional<double>& v) { return v ? fmt::format("{:.2f}", *v) : std::string("-"); };
  for (const LoopAuditRow& a : AuditLoopsJson(rows, *gt)) {
    if (!a.closed) continue;
    ++closed;
    right += a.right;
    harmful += a.harmful;
    unjudged += !a.rotation_error_deg;
    if (a.harmful)
      std::cout << fmt::format("loop audit: harmful {} kf {} ({:.2f} s) -> {} kf {} ({:.2f} s): rotation {} deg, "
                               "direction {} deg\n",
                               a.query, a.query_keyframe, a.query_time_s, a.match, a.match_keyframe, a.match_time_s,
                               opt(a.rotation_error_deg), opt(a.direction_error_deg));
  }
  std::cout << fmt::format("loop audit: {} closed: {} right, {} harmful, {} without ground truth\n", closed, right,
                           harmful, unjudged);
}

void PrintMergeReports(const std::vector<MergeReport>& reports) {
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
        r.seconds_weld, r.reason.empty() ? "" : " reason=\"" + r.reason + "\"");
  }
}

// Each merge attempt against the ground truth, on the raw map reloaded.
bool PrintAudit(const std::vector<MergeReport>& reports, const MergeReplayOptions& o, const Trajectory& gt,
                std::string* why) {
  GlobalMap raw;
  if (!LoadReplayMap(o.map_path, o.back_pose_jump_ratio, false, &raw, why)) return false;
  auto opt = [](const std::optional<double>& v) { return v ? fmt::format("{:.4f}", *v) : std::string("-"); };
  for (const MergeAuditRow& m : AuditMerges(raw, AttemptsOf(reports), gt)) {
    std::cout << fmt::format("audit {} {} + {}: accepted={} frames={}+{} ate_a={} ate_b={} ate_joint={} "
                             "ate_a_joint={} harmful={}{}{}\n",
                             m.kind, m.a, m.b, m.accepted, m.a_frames, m.b_frames, opt(m.ate_a), opt(m.ate_b),
                             opt(m.ate_joint), opt(m.ate_a_joint), m.harmful,
                             m.rejected_by.empty() ? "" : " rejected_by=" + m.rejected_by,
                             m.note.empty() ? "" : " note=\"" + m.note + "\"");
  }
  return true;
}

void CullAndPrint(GlobalMap* map, const ManagerOptions& manager) {
  const CullingReport c = CullRedundantKeyframes(map, manager);
  std::printf("post-culling: keyframes %d -> %d (back %d, front %d culled); back keyframes examined %d, "
              "median share of points seen by >= %d others %.2f (needs %.2f); %d front points found in back "
              "keyframes\n",
              c.keyframes_before, c.keyframes_after, c.culled_back, c.culled_front, c.back_examined,
              manager.culling_min_observers, c.back_redundant_share_median, manager.culling_redundant_ratio,
              c.front_points_found);
  std::printf("revisit culled: %d by fused points, %d by loop detections; front keyframes left per submap:",
              c.culled_revisit, c.culled_revisit_detected);
  for (size_t i = 0; i < map->size(); ++i)
    if (map->submap(int(i)).source == SubmapSource::kFront) std::printf(" %zu", map->submap(int(i)).keyframes.size());
  std::printf("\n");
}

}  // namespace

bool LoadReplayMap(const std::string& path, double jump_ratio, bool print, GlobalMap* map, std::string* why) {
  if (!LoadRawSubmaps(path, map, why)) {
    *why = "cannot load " + path + ": " + *why;
    return false;
  }
  for (size_t i = 0; jump_ratio > 0 && i < map->size(); ++i) {
    Submap& s = map->submap(int(i));
    if (s.source != SubmapSource::kBack) continue;
    const std::vector<size_t> jumps = PoseJumps(s, jump_ratio);
    for (size_t k : jumps)
      if (print)
        std::printf("%s: keyframe %s registered off the camera path, dropped\n", ToString(map->Key(int(i))).c_str(),
                    FormatSeconds(s.keyframes[k].timestamp).c_str());
    DropKeyframesAt(&s, jumps);
  }
  return true;
}

bool ReplayMerges(GlobalMap* map, const MergeReplayOptions& o, std::string* why) {
  PrepareBackSubmaps(map, o);
  auto reports = MergeAll(map, o.manager);
  for (MergeReport& r : PlaceMergeAll(map, o.manager)) reports.push_back(std::move(r));
  for (MergeReport& r : OdometryMergeAll(map, o.manager)) reports.push_back(std::move(r));
  std::optional<Trajectory> gt;
  if (!o.groundtruth_path.empty()) {
    try {
      gt = ReadTumTrajectory(o.groundtruth_path);
    } catch (const std::exception& e) {
      *why = e.what();
      return false;
    }
  }
  CloseLoopsAndPrint(map, o, gt ? &*gt : nullptr);
  PrintMergeReports(reports);
  if (gt && !PrintAudit(reports, o, *gt, why)) return false;
  if (o.post_culling) CullAndPrint(map, o.manager);
  const int root = map->size() ? map->LargestComponent() : -1;
  const auto traj = root >= 0 ? ComputeGlobalTrajectory(*map, root) : std::vector<GlobalPose>();
  int components = 0;
  for (size_t i = 0; i < map->size(); ++i) components += map->Component(int(i)) == int(i);
  std::cout << fmt::format("submaps={} components={} largest_component_frames={}\n", map->size(), components,
                           traj.size());
  try {
    if (!o.trajectory_path.empty()) WriteTumTrajectory(o.trajectory_path, ToTrajectory(traj));
  } catch (const std::exception& e) {
    *why = e.what();
    return false;
  }
  return true;
}

}  // namespace rumi
