#include "manager/merge.h"

#include <algorithm>
#include <chrono>

#include "common/logging.h"
#include "common/timestamp.h"
#include "manager/common_points.h"
#include "manager/merge_memo.h"
#include "manager/sim3_alignment.h"
#include "manager/sim3_refine.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {
MergeReport Reject(MergeReport r, const std::string& why) { return RejectMerge(std::move(r), "merge", why); }
}  // namespace

MergeReport RejectMerge(MergeReport r, const char* kind, const std::string& why) {
  r.reason = why;
  spdlog::info("{} {} <-> {} rejected: {}", kind, ToString(r.front), ToString(r.back), why);
  return r;
}

void TransformSubmap(const Sim3& S, Submap* s) {
  for (Keyframe& kf : s->keyframes) kf.T_cw = S.TransformPose(kf.T_wc()).Inverse();
  for (MapPoint& p : s->points) p.position = S * p.position;
  for (FrameRecord& f : s->frames) f.T_wc = S.TransformPose(f.T_wc);
}

bool JoinComponents(GlobalMap* map, int front, int back, const Sim3& S_bf) {
  const Sim3 S_gf = map->ToGlobal(front), S_gb = map->ToGlobal(back);
  const bool front_moved = map->NumKeyframes(map->Component(front)) <= map->NumKeyframes(map->Component(back));
  if (front_moved) {
    map->MoveComponent(front, S_gb * S_bf * S_gf.Inverse());
  } else {
    map->MoveComponent(back, S_gf * S_bf.Inverse() * S_gb.Inverse());
  }
  map->Union(front, back);
  return front_moved;
}

std::vector<std::pair<int, int>> AgreeingInliers(const Submap& F, const Submap& B,
                                                 const std::vector<PointMatch>& matches,
                                                 const std::vector<char>& inliers, const Sim3& S_bf, double threshold) {
  const SubmapIndex fi(F), bi(B);
  std::vector<std::pair<int, int>> out;
  for (size_t m = 0; m < matches.size(); ++m) {
    if (!inliers[m]) continue;
    const int f = fi.Point(matches[m].front_point_id), b = bi.Point(matches[m].back_point_id);
    if (f < 0 || b < 0) continue;
    if ((S_bf * F.points[f].position - B.points[b].position).norm() <= threshold) out.emplace_back(f, b);
  }
  return out;
}

void CommitMerge(GlobalMap* map, int front, int back, const std::vector<std::pair<int, int>>& agreeing,
                 const std::vector<int64_t>& seeds, const ManagerOptions& options, MergeReport* report) {
  MergeReport& r = *report;
  r.front_moved = JoinComponents(map, front, back, r.S_bf);

  // Fuse the inliers that still agree in 3D after refinement: the front
  // duplicate takes the back point's position and is linked to it.
  const auto t0 = std::chrono::steady_clock::now();
  Submap& Fm = map->submap(front);
  const Submap& B = map->submap(back);
  const Sim3 S_fb = r.S_bf.Inverse();
  std::vector<std::pair<int64_t, int64_t>> fused;
  for (const auto& [f, b] : agreeing) {
    Fm.points[size_t(f)].position = S_fb * B.points[size_t(b)].position;
    fused.emplace_back(Fm.points[size_t(f)].id, B.points[size_t(b)].id);
    map->fused().push_back({front, Fm.points[size_t(f)].id, back, B.points[size_t(b)].id});
  }
  r.fused_points = int(fused.size());

  if (options.welding_ba) {
    const auto window = WeldingWindow(Fm, seeds, options.welding_min_covisible, options.welding_max_keyframes);
    r.welding = WeldWindow(map, front, back, window, fused, options);
  }
  r.seconds_weld = SecondsSince(t0);
}

MergeReport MergePair(GlobalMap* map, int front, int back, const SearchSet& search, const ManagerOptions& options) {
  MergeReport r;
  r.front = map->Key(front);
  r.back = map->Key(back);
  if (map->Connected(front, back)) return Reject(r, "already connected");
  const Submap& F = map->submap(front);
  const Submap& B = map->submap(back);

  auto t0 = std::chrono::steady_clock::now();
  const std::vector<KeyframePair> pairs = PairKeyframes(F, B, search, options.pairing_max_dt_ns);
  std::vector<FramePair> frame_pairs;
  if (options.pair_tracked_frames)
    frame_pairs = PairTrackedFrames(F, B, search, options.pairing_max_dt_ns, pairs, options.pair_neighbour_keyframes);
  r.keyframe_pairs = int(pairs.size());
  r.frame_pairs = int(frame_pairs.size());
  if (r.keyframe_pairs + r.frame_pairs < options.min_keyframe_pairs)
    return Reject(r, "too few keyframe pairs (" + std::to_string(pairs.size()) + " + " +
                         std::to_string(frame_pairs.size()) + " frame pairs)");
  const CommonPoints common =
      FindCommonPoints(F, B, pairs, frame_pairs, options.match_radius_px, options.pair_ratio);
  const AlignmentResult align = AlignSubmaps(F, B, pairs, common, options, frame_pairs);
  r.common_points = align.num_point_matches;
  r.inliers = align.num_inliers;
  r.inlier_ratio = align.inlier_ratio;
  r.init_method = align.method;
  r.S_bf_initial = align.S_bf;
  r.aligned = !align.method.empty();
  r.seconds_align = SecondsSince(t0);
  if (!align.ok) {
    if (r.aligned) r.rejected_by = "alignment";
    return Reject(r, align.reason);
  }

  t0 = std::chrono::steady_clock::now();
  const Sim3RefineResult refine = RefineSim3(F, B, common.matches, &align.inliers, align.S_bf, options);
  r.seconds_refine = SecondsSince(t0);
  if (!refine.ok) return Reject(r, "refinement failed: " + refine.message);
  r.S_bf = refine.S_bf;
  r.refined = true;
  r.refine_initial_rmse_px = refine.initial_rmse_px;
  r.refine_final_rmse_px = refine.final_rmse_px;
  const auto agreeing = AgreeingInliers(F, B, common.matches, align.inliers, r.S_bf, align.inlier_threshold);
  const MergeVerification v = VerifyMerge(F, B, pairs, frame_pairs, r.S_bf, r.inliers, int(agreeing.size()),
                                          r.refine_final_rmse_px, options);
  r.pose_pairs = v.pose_pairs;
  r.agreeing_pairs = v.agreeing_pairs;
  r.pose_angle_deg = v.median_angle_deg;
  r.pose_offset_ratio = v.median_offset_ratio;
  if (options.verify_merges && !v.ok) {
    r.rejected_by = v.check;
    return Reject(r, "verification (" + v.check + "): " + v.why);
  }

  std::vector<int64_t> seeds;
  for (const auto& p : pairs) seeds.push_back(F.keyframes[p.front_keyframe].id);
  for (const auto& p : frame_pairs)
    for (int k : p.front_keyframes) seeds.push_back(F.keyframes[k].id);
  CommitMerge(map, front, back, agreeing, seeds, options, &r);
  r.merged = true;
  spdlog::info(
      "merged {} with {} ({} side moved): {} + {} frame pairs, {} common points, inlier ratio {:.2f} ({}), scale {:.4f}, refine rmse "
      "{:.2f} -> {:.2f} px, {} fused, welding {} kf {:.2f} -> {:.2f} px (shift median {:.4f}, max {:.4f}{}), {} of {} paired poses agree ({:.2f} deg, {:.3f})",
      ToString(r.front), ToString(r.back), r.front_moved ? "front" : "back", r.keyframe_pairs, r.frame_pairs, r.common_points, r.inlier_ratio, r.init_method,
      r.S_bf.scale(), r.refine_initial_rmse_px, r.refine_final_rmse_px, r.fused_points,
      r.welding.window_keyframes, r.welding.initial_rmse_px, r.welding.final_rmse_px, r.welding.median_shift_ratio,
      r.welding.max_shift_ratio, r.welding.applied ? "" : r.welding.reverted ? ": not applied" : ": off", r.agreeing_pairs, r.pose_pairs,
      r.pose_angle_deg, r.pose_offset_ratio);
  return r;
}

std::vector<MergeReport> MergeAll(GlobalMap* map, const ManagerOptions& options, MergeMemo* memo,
                                  const std::atomic<bool>* cancel) {
  std::vector<const Submap*> fronts, backs;
  for (size_t i = 0; i < map->size(); ++i)
    (map->submap(int(i)).source == SubmapSource::kBack ? backs : fronts).push_back(&map->submap(int(i)));
  const SearchSet search = BuildSearchSet(fronts, backs, options.search_n);
  if (memo) memo->BeginRun(*map, search, options.pairing_max_dt_ns);
  std::vector<MergeReport> reports;
  std::vector<std::pair<size_t, size_t>> tried;  // data unchanged: no retry
  for (bool progress = true; progress;) {
    progress = false;
    for (size_t f = 0; f < map->size(); ++f) {
      if (map->submap(int(f)).source != SubmapSource::kFront) continue;
      for (size_t b = 0; b < map->size(); ++b) {
        if (map->submap(int(b)).source != SubmapSource::kBack || map->Connected(int(f), int(b))) continue;
        if (std::find(tried.begin(), tried.end(), std::make_pair(f, b)) != tried.end()) continue;
        if (cancel && cancel->load()) break;
        tried.emplace_back(f, b);
        reports.push_back(memo ? memo->Merge(map, int(f), int(b), search, options)
                               : MergePair(map, int(f), int(b), search, options));
        progress |= reports.back().merged;
      }
    }
  }
  if (memo) memo->EndRun();
  return reports;
}

}  // namespace rumi
