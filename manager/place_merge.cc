#include "manager/place_merge.h"

#include "manager/merge_memo.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <opencv2/core.hpp>

#include "common/descriptor_match.h"
#include "common/logging.h"
#include "common/orb_extractor.h"
#include "common/timestamp.h"
#include "manager/sim3_alignment.h"
#include "manager/sim3_refine.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

MergeReport Reject(MergeReport r, const std::string& why) { return RejectMerge(std::move(r), "place merge", why); }

// Descriptors (32-byte ORB rows, packed) of the points that qualify, and
// their indices.
std::vector<uint8_t> PointDescriptors(const Submap& s, std::vector<int>* index) {
  std::vector<uint8_t> d;
  index->clear();
  for (size_t i = 0; i < s.points.size(); ++i) {
    const MapPoint& p = s.points[i];
    if (p.observations.size() < 2 || p.descriptor.type() != CV_8U || p.descriptor.cols != 32 ||
        p.descriptor.rows < 1)
      continue;
    const uint8_t* row = p.descriptor.ptr<uint8_t>(0);
    d.insert(d.end(), row, row + 32);
    index->push_back(int(i));
  }
  return d;
}

// Keyframes of `s` observing the most of the given points (welding seeds).
std::vector<int64_t> SeedKeyframes(const Submap& s, const std::vector<int64_t>& point_ids, size_t max_seeds) {
  const SubmapIndex idx(s);
  std::map<int64_t, int> votes;
  for (int64_t id : point_ids) {
    const int p = idx.Point(id);
    if (p < 0) continue;
    for (const auto& o : s.points[p].observations) ++votes[o.keyframe_id];
  }
  std::vector<std::pair<int, int64_t>> v;
  for (const auto& [kf, n] : votes) v.emplace_back(-n, kf);
  std::sort(v.begin(), v.end());
  std::vector<int64_t> seeds;
  for (size_t i = 0; i < v.size() && i < max_seeds; ++i) seeds.push_back(v[i].second);
  return seeds;
}

}  // namespace

std::vector<PointMatch> MatchMapPoints(const Submap& a, const Submap& b, int max_hamming, double ratio) {
  std::vector<int> ia, ib;
  const std::vector<uint8_t> da = PointDescriptors(a, &ia), db = PointDescriptors(b, &ib);
  std::vector<PointMatch> out;
  for (const auto& [ra, rb] : MatchDescriptors(da.data(), da.size() / 32, db.data(), db.size() / 32,
                                                 {max_hamming, ratio, /*mutual=*/false}))
    out.push_back({a.points[size_t(ia[size_t(ra)])].id, b.points[size_t(ib[size_t(rb)])].id, 1});
  std::sort(out.begin(), out.end(),
            [](const PointMatch& x, const PointMatch& y) { return x.front_point_id < y.front_point_id; });
  return out;
}

MergeReport PlaceMergePair(GlobalMap* map, int a, int b, const ManagerOptions& options) {
  MergeReport r;
  r.kind = "place";
  r.front = map->Key(a);
  r.back = map->Key(b);
  r.init_method = "place-ransac";
  if (map->Connected(a, b)) return Reject(r, "already connected");
  const Submap& A = map->submap(a);
  const Submap& B = map->submap(b);
  auto t0 = std::chrono::steady_clock::now();
  const std::vector<PointMatch> matches = MatchMapPoints(A, B, options.place_max_hamming, options.place_ratio);
  r.common_points = int(matches.size());
  if (r.common_points < options.place_min_inliers)
    return Reject(r, "too few descriptor matches (" + std::to_string(r.common_points) + " < " +
                         std::to_string(options.place_min_inliers) + ")");
  const SubmapIndex ai(A), bi(B);
  std::vector<Eigen::Vector3d> src, dst;
  for (const PointMatch& m : matches) {
    src.push_back(A.points[ai.Point(m.front_point_id)].position);
    dst.push_back(B.points[bi.Point(m.back_point_id)].position);
  }
  const double threshold = options.ransac_threshold_ratio * SceneRadius(dst);
  if (!(threshold > 0)) return Reject(r, "degenerate scene (all matched points coincide)");
  const RansacSim3Result rs =
      RansacSim3(src, dst, threshold, options.place_ransac_iterations, options.ransac_seed);
  r.seconds_align = SecondsSince(t0);
  if (!rs.ok) return Reject(r, "no Sim(3) from " + std::to_string(matches.size()) + " descriptor matches");
  r.inliers = rs.num_inliers;
  r.inlier_ratio = double(rs.num_inliers) / double(matches.size());
  r.S_bf_initial = rs.transform;
  r.aligned = true;
  r.rejected_by = "alignment";  // until the RANSAC's checks pass
  if (r.inliers < options.place_min_inliers)
    return Reject(r, "too few inliers (" + std::to_string(r.inliers) + " of " + std::to_string(matches.size()) +
                         " < " + std::to_string(options.place_min_inliers) + ")");
  if (r.inlier_ratio < options.place_min_inlier_ratio)
    return Reject(r, "inlier ratio " + std::to_string(r.inlier_ratio) + " < " +
                         std::to_string(options.place_min_inlier_ratio));
  r.rejected_by.clear();

  t0 = std::chrono::steady_clock::now();
  const Sim3RefineResult refine = RefineSim3(A, B, matches, &rs.inliers, rs.transform, options);
  r.seconds_refine = SecondsSince(t0);
  if (!refine.ok) return Reject(r, "refinement failed: " + refine.message);
  r.S_bf = refine.S_bf;
  r.refined = true;
  r.refine_initial_rmse_px = refine.initial_rmse_px;
  r.refine_final_rmse_px = refine.final_rmse_px;
  if (!(refine.final_rmse_px <= options.place_max_rmse_px))
    return Reject(r, "refined reprojection RMSE " + std::to_string(refine.final_rmse_px) + " px > " +
                         std::to_string(options.place_max_rmse_px));
  // The refined Sim(3) must still hold the RANSAC's support.
  const auto agreeing = AgreeingInliers(A, B, matches, rs.inliers, r.S_bf, threshold);
  const int kept = int(agreeing.size());
  if (kept < options.place_min_inliers)
    return Reject(r, "refined Sim(3) keeps " + std::to_string(kept) + " inliers");
  r.inliers = kept;

  std::vector<int64_t> matched;
  for (const auto& fb : agreeing) matched.push_back(A.points[size_t(fb.first)].id);
  CommitMerge(map, a, b, agreeing, SeedKeyframes(A, matched, 10), options, &r);
  r.merged = true;
  spdlog::info(
      "place merge {} with {} ({} side moved): {} descriptor matches, {} inliers ({:.2f}), scale {:.4f}, refine rmse "
      "{:.2f} -> {:.2f} px, {} fused, welding {} kf {:.2f} -> {:.2f} px",
      ToString(r.front), ToString(r.back), r.front_moved ? "first" : "second", r.common_points, r.inliers,
      r.inlier_ratio, r.S_bf.scale(), r.refine_initial_rmse_px, r.refine_final_rmse_px, r.fused_points,
      r.welding.window_keyframes, r.welding.initial_rmse_px, r.welding.final_rmse_px);
  return r;
}

namespace {

SubmapKey KeyOf(const Submap& s) { return {s.source, s.id}; }

// Unchanged, or grown by less than `growth` of what it had (never shrunk).
bool Within(size_t then, size_t now, double growth) {
  if (now == then) return true;
  return growth > 0 && now > then && static_cast<double>(now - then) < growth * static_cast<double>(then);
}

}  // namespace

bool PlaceMergeMemo::Rejected(const Submap& a, const Submap& b, double retry_growth) const {
  const auto it = rejected_.find({KeyOf(a), KeyOf(b)});
  if (it == rejected_.end()) return false;
  const Sizes& t = it->second;
  if (retry_growth <= 0)  // the exact version only
    return t.keyframes_a == a.keyframes.size() && t.points_a == a.points.size() &&
           t.keyframes_b == b.keyframes.size() && t.points_b == b.points.size();
  return Within(t.keyframes_a, a.keyframes.size(), retry_growth) &&
         Within(t.keyframes_b, b.keyframes.size(), retry_growth);
}

void PlaceMergeMemo::AddRejected(const Submap& a, const Submap& b) {
  rejected_[{KeyOf(a), KeyOf(b)}] = {a.keyframes.size(), a.points.size(), b.keyframes.size(), b.points.size()};
}

std::vector<MergeReport> PlaceMergeAll(GlobalMap* map, const ManagerOptions& options, PlaceMergeMemo* memo,
                                       MergeMemo* merge_memo, const std::atomic<bool>* cancel) {
  std::vector<MergeReport> reports;
  if (!options.place_merge) return reports;
  if (merge_memo) merge_memo->BeginPlaceRun(*map);
  std::vector<std::pair<int, int>> tried;  // data unchanged: no retry
  // The front submap still being built is the newest; the others are
  // finished, and each is matched once more in its final form.
  int newest = -1;
  for (int j = 0; j < int(map->size()); ++j)
    if (map->submap(j).source == SubmapSource::kFront && (newest < 0 || map->submap(j).id > map->submap(newest).id))
      newest = j;
  for (bool progress = true; progress;) {
    progress = false;
    for (int j = 0; j < int(map->size()); ++j) {
      if (map->submap(j).source != SubmapSource::kFront) continue;
      std::vector<int> order;
      for (int i = 0; i < j; ++i) order.push_back(i);
      const SubmapKey* partner = memo ? memo->Partner(map->Key(j)) : nullptr;
      const int first = partner ? map->Find(*partner) : -1;
      if (first >= 0 && first < j) std::rotate(order.begin(), order.begin() + first, order.begin() + first + 1);
      for (int i : order) {
        if (map->submap(i).source != SubmapSource::kFront || map->Connected(i, j)) continue;
        if (std::find(tried.begin(), tried.end(), std::make_pair(i, j)) != tried.end()) continue;
        if (cancel && cancel->load()) break;
        tried.emplace_back(i, j);
        const double growth = i == newest || j == newest ? options.place_retry_growth : 0;
        if (memo && memo->Rejected(map->submap(i), map->submap(j), growth)) continue;
        reports.push_back(merge_memo ? merge_memo->Place(map, i, j, options) : PlaceMergePair(map, i, j, options));
        if (reports.back().merged) {
          progress = true;
          if (memo) memo->SetPartner(map->Key(i), map->Key(j));
        } else if (memo) {
          memo->AddRejected(map->submap(i), map->submap(j));
        }
      }
    }
  }
  if (merge_memo) merge_memo->EndPlaceRun();
  return reports;
}

}  // namespace rumi
