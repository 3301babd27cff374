#include "manager/post_culling.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "common/logging.h"
#include "common/timestamp.h"
#include "manager/front_point_search.h"
#include "manager/revisit_fusion.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

struct Observer {
  int submap;
  int keyframe;  // index in the submap
  uint8_t octave;
};

// Map points of every submap as dense cluster ids (offset of the submap +
// point index), with union-find to merge fused duplicates. Flat arrays, not
// maps keyed by (submap, point id): culling runs over the whole map at every
// rebuild, and a long session holds ~10^6 points.
class PointClusters {
 public:
  explicit PointClusters(const std::vector<SubmapIndex>& idx, const GlobalMap& map) : idx_(idx) {
    for (size_t s = 0; s < map.size(); ++s) {
      offset_.push_back(int(parent_.size()));
      parent_.resize(parent_.size() + map.submap(int(s)).points.size());
    }
    for (size_t i = 0; i < parent_.size(); ++i) parent_[i] = int(i);
  }
  // A point id the submap does not hold gets an id of its own (it joins
  // nothing and nobody else observes it).
  int Id(int submap, int64_t pid) {
    const int p = idx_[size_t(submap)].Point(pid);
    if (p >= 0) return offset_[size_t(submap)] + p;
    const auto [it, inserted] = absent_.try_emplace({submap, pid}, int(parent_.size()));
    if (inserted) parent_.push_back(it->second);
    return it->second;
  }
  int IdOfIndex(int submap, int point_index) const { return offset_[size_t(submap)] + point_index; }
  void Join(int a, int b) { parent_[size_t(Root(a))] = Root(b); }
  int Root(int i) {
    while (parent_[size_t(i)] != i) i = parent_[size_t(i)] = parent_[size_t(parent_[size_t(i)])];
    return i;
  }
  size_t size() const { return parent_.size(); }

 private:
  const std::vector<SubmapIndex>& idx_;
  std::vector<int> offset_, parent_;
  std::map<std::pair<int, int64_t>, int> absent_;
};

}  // namespace

CullingReport CullRedundantKeyframes(GlobalMap* map, const ManagerOptions& options,
                                     const std::vector<bool>* revisit_searched, RevisitMemo* revisit_memo) {
  CullingReport rep;
  {
    const RevisitFusionReport fusion = FuseRevisitPoints(map, options, revisit_searched, revisit_memo);
    rep.revisit_keyframes_searched = fusion.keyframes_searched;
    rep.revisit_keyframes_placed = fusion.keyframes_corrected;
    rep.revisit_fused = fusion.fused;
    rep.revisit_submaps_replayed = fusion.submaps_replayed;
    rep.seconds_revisit = fusion.seconds;
  }
  const int n = int(map->size());
  std::vector<SubmapIndex> idx(n);
  for (int s = 0; s < n; ++s) idx[s].Build(map->submap(s));
  PointClusters clusters(idx, *map);
  for (const FusedPoint& f : map->fused()) clusters.Join(clusters.Id(f.dup, f.dup_point), clusters.Id(f.kept, f.kept_point));
  // Front points found in back keyframes: more observers of those points, and
  // more points of those keyframes.
  const auto search_start = std::chrono::steady_clock::now();
  const std::vector<CrossObservation> cross = SearchFrontPoints(*map, options);
  rep.seconds_front_search = SecondsSince(search_start);
  rep.front_points_found = int(cross.size());
  std::vector<int> cross_cluster(cross.size());
  for (size_t i = 0; i < cross.size(); ++i) cross_cluster[i] = clusters.Id(cross[i].front, cross[i].point_id);

  // Observers per cluster root, flat (counted, then filled).
  const auto for_each_observation = [&](const auto& visit) {
    for (int s = 0; s < n; ++s) {
      const Submap& m = map->submap(s);
      for (size_t p = 0; p < m.points.size(); ++p)
        for (const auto& ob : m.points[p].observations) {
          const int k = idx[s].Keyframe(ob.keyframe_id);
          if (k < 0) continue;
          const Keyframe& kf = m.keyframes[size_t(k)];
          const uint8_t oct = ob.keypoint_index >= 0 && ob.keypoint_index < int(kf.octaves.size())
                                  ? kf.octaves[size_t(ob.keypoint_index)]
                                  : 0;
          visit(clusters.IdOfIndex(s, int(p)), Observer{s, k, oct});
        }
    }
    for (size_t i = 0; i < cross.size(); ++i) {
      const int k = idx[cross[i].back].Keyframe(cross[i].keyframe_id);
      if (k >= 0) visit(cross_cluster[i], Observer{cross[i].back, k, cross[i].octave});
    }
  };
  std::vector<int> begin(clusters.size() + 1, 0);
  for_each_observation([&](int c, const Observer&) { ++begin[size_t(clusters.Root(c)) + 1]; });
  for (size_t c = 0; c < clusters.size(); ++c) begin[c + 1] += begin[c];
  std::vector<Observer> observers(size_t(begin.back()));
  {
    std::vector<int> fill(begin.begin(), begin.end() - 1);
    for_each_observation([&](int c, const Observer& o) { observers[size_t(fill[size_t(clusters.Root(c))]++)] = o; });
  }
  for (int s = 0; s < n; ++s) {
    rep.keyframes_before += int(map->submap(s).keyframes.size());
    rep.points_before += int(map->submap(s).points.size());
  }
  // A back keyframe's found front points: (cluster, octave) per keyframe.
  std::unordered_map<int64_t, std::vector<std::pair<int, uint8_t>>> extra;
  for (size_t i = 0; i < cross.size(); ++i) {
    const int k = idx[cross[i].back].Keyframe(cross[i].keyframe_id);
    if (k >= 0) extra[(int64_t(cross[i].back) << 32) | k].push_back({cross_cluster[i], cross[i].octave});
  }
  std::vector<std::vector<char>> culled(n);
  std::vector<int> alive(n);
  for (int s = 0; s < n; ++s) {
    alive[s] = int(map->submap(s).keyframes.size());
    culled[s].assign(map->submap(s).keyframes.size(), 0);
  }

  // Passes in time order: "earlier" below is time, not the map's order.
  const std::vector<int> rank = TimeRanks(*map);
  std::vector<int> by_time(static_cast<size_t>(n));
  for (int s = 0; s < n; ++s) by_time[size_t(rank[size_t(s)])] = s;
  const auto earlier = [&](int a, int b) { return rank[size_t(a)] < rank[size_t(b)]; };

  std::vector<double> back_shares;
  std::vector<int> listed_by(clusters.size(), -1);  // the keyframe that last listed a cluster
  int keyframe_stamp = 0;
  const int min_observers = options.culling_min_observers;
  std::vector<std::pair<int, int>> seen;  // distinct other keyframes (submap, index)
  // Share of keyframe k of submap s whose points are seen by min_observers
  // living keyframes other than itself; with other_fronts, by one living
  // keyframe of an earlier front submap (the point is known to an earlier
  // pass, which culling may have thinned to fewer observers than the ORB
  // rule asks; never a later one, or the earlier pass would go for the
  // keyframe the later one must keep). -1 when it has no point.
  const auto redundant_share = [&](int s, size_t k, bool other_fronts) {
    const int needed = other_fronts ? 1 : min_observers;
    const Keyframe& kf = map->submap(s).keyframes[k];
    ++keyframe_stamp;
    // The keyframe's points as (cluster root, octave), each cluster once.
    std::vector<std::pair<int, uint8_t>> points;
    const auto list = [&](int root, uint8_t oct) {
      if (listed_by[size_t(root)] == keyframe_stamp) return;
      listed_by[size_t(root)] = keyframe_stamp;
      points.push_back({root, oct});
    };
    for (size_t i = 0; i < kf.point_ids.size(); ++i) {
      if (kf.point_ids[i] < 0) continue;
      const int p = idx[s].Point(kf.point_ids[i]);
      if (p < 0) continue;
      list(clusters.Root(clusters.IdOfIndex(s, p)), i < kf.octaves.size() ? kf.octaves[i] : 0);
    }
    const auto ex = extra.find((int64_t(s) << 32) | int64_t(k));
    if (ex != extra.end())
      for (const auto& [c, oct] : ex->second) list(clusters.Root(c), oct);
    if (points.empty()) return -1.0;
    int redundant = 0;
    for (const auto& [root, oct] : points) {
      seen.clear();
      for (int o = begin[size_t(root)]; o < begin[size_t(root) + 1] && int(seen.size()) < needed; ++o) {
        const Observer& ob = observers[size_t(o)];
        if ((ob.submap == s && ob.keyframe == int(k)) ||
            (other_fronts && (!earlier(ob.submap, s) || map->submap(ob.submap).source != SubmapSource::kFront)) ||
            ob.octave > oct + options.culling_octave_tolerance || culled[size_t(ob.submap)][size_t(ob.keyframe)])
          continue;
        const std::pair<int, int> key{ob.submap, ob.keyframe};
        if (std::find(seen.begin(), seen.end(), key) == seen.end()) seen.push_back(key);
      }
      if (int(seen.size()) >= needed) ++redundant;
    }
    return double(redundant) / double(points.size());
  };
  const auto cull = [&](int s, size_t k, int* counter) {
    culled[size_t(s)][k] = 1;
    --alive[size_t(s)];
    ++*counter;
  };
  // Revisits first, the newest submap first: a front keyframe whose place an
  // earlier pass mapped (culling_revisit_ratio of its points fused with
  // points that other front submaps' keyframes see) goes, and the older pass
  // stays. Back keyframes do not count here: a back window re-images the
  // front's keyframes by design, and the rules below cull the back first.
  // A verified loop detection (loop_closure.h: descriptor matches, a RANSAC
  // Sim(3) and PnP against an earlier pass's keyframe and its neighbours)
  // says the same without placing the keyframe first: the share of its
  // mapped points that were inliers there. Revisit fusion places a keyframe
  // in the global frame before it can fuse, and on a looped walk it placed
  // only a third of them (20 minutes live: 1,389 of 4,113); the loop search
  // verified a detection for most.
  std::unordered_map<int64_t, std::vector<const LoopDetection*>> detections;  // (submap << 32 | keyframe)
  if (options.culling_loop_ratio > 0)
    for (const auto& [qkey, list] : map->loops().searched) {
      const int s = map->Find(qkey.first);
      if (s < 0) continue;
      const int k = idx[size_t(s)].Keyframe(qkey.second);
      if (k >= 0)
        for (const LoopDetection& d : list) detections[(int64_t(s) << 32) | k].push_back(&d);
    }
  const auto mapped_points = [&](int s, size_t k) {
    int count = 0;
    for (int64_t pid : map->submap(s).keyframes[k].point_ids) count += pid >= 0 && idx[size_t(s)].Point(pid) >= 0;
    return count;
  };
  // A living keyframe of submap m within loop_group_s of what the detection
  // matched (loop closure's scale of one place): the place is still mapped
  // there. (Earlier submaps are culled after later ones here, so this holds
  // for keyframes culled at earlier rebuilds, which have left the map; a
  // keyframe the rules below cull now has others that see its points.)
  const int64_t near_ns = int64_t(options.loop_group_s * 1e9);
  const auto alive_near = [&](int m, Timestamp t) {
    const auto& kfs = map->submap(m).keyframes;
    auto it = std::lower_bound(kfs.begin(), kfs.end(), t - near_ns,
                               [](const Keyframe& kf, Timestamp x) { return kf.timestamp < x; });
    for (; it != kfs.end() && it->timestamp <= t + near_ns; ++it)
      if (!culled[size_t(m)][size_t(it - kfs.begin())]) return true;
    return false;
  };
  const auto revisit_by_detection = [&](int s, size_t k) {
    const auto it = detections.find((int64_t(s) << 32) | int64_t(k));
    if (it == detections.end()) return false;
    const int own = mapped_points(s, k);
    if (own == 0) return false;
    for (const LoopDetection* d : it->second) {
      if (double(d->inliers) < options.culling_loop_ratio * own) continue;
      const int m = map->Find(d->match_submap);
      if (m < 0 || !earlier(m, s) || map->submap(m).source != SubmapSource::kFront || !map->Connected(m, s))
        continue;
      if (alive_near(m, d->match_time)) return true;
    }
    return false;
  };
  if (options.culling_revisit_ratio > 0 || options.culling_loop_ratio > 0) {
    for (int r = n - 1; r >= 0; --r) {
      const int s = by_time[size_t(r)];
      const Submap& m = map->submap(s);
      if (m.source == SubmapSource::kBack) continue;
      for (size_t k = 0; k < m.keyframes.size() && alive[size_t(s)] > 1; ++k) {
        if (options.culling_revisit_ratio > 0 &&
            redundant_share(s, k, /*other_fronts=*/true) >= options.culling_revisit_ratio)
          cull(s, k, &rep.culled_revisit);
        else if (revisit_by_detection(s, k))
          cull(s, k, &rep.culled_revisit_detected);
      }
    }
  }
  for (const bool back_pass : {true, false}) {
    for (int s = 0; s < n; ++s) {
      const Submap& m = map->submap(s);
      if ((m.source == SubmapSource::kBack) != back_pass) continue;
      for (size_t k = 0; k < m.keyframes.size(); ++k) {
        if (alive[size_t(s)] <= 1) break;  // a submap keeps at least one keyframe
        if (culled[size_t(s)][k]) continue;
        const double share = redundant_share(s, k, /*other_fronts=*/false);
        if (share < 0) continue;
        if (back_pass) back_shares.push_back(share);
        if (share >= options.culling_redundant_ratio) cull(s, k, back_pass ? &rep.culled_back : &rep.culled_front);
      }
    }
  }

  rep.back_examined = int(back_shares.size());
  if (!back_shares.empty()) {
    std::nth_element(back_shares.begin(), back_shares.begin() + back_shares.size() / 2, back_shares.end());
    rep.back_redundant_share_median = back_shares[back_shares.size() / 2];
  }
  // Apply: keep culled poses as frame records, drop their observations and
  // the points that only they supported.
  for (int s = 0; s < n; ++s) {
    Submap& m = map->submap(s);
    if (std::count(culled[s].begin(), culled[s].end(), 1) > 0) {
      std::unordered_map<Timestamp, size_t> recorded;
      for (size_t i = 0; i < m.frames.size(); ++i) recorded[m.frames[i].timestamp] = i;
      std::vector<Keyframe> kept;
      std::unordered_set<int64_t> culled_ids;
      for (size_t k = 0; k < m.keyframes.size(); ++k)
        if (culled[s][k]) culled_ids.insert(m.keyframes[k].id);
      for (Keyframe& kf : m.keyframes) {
        if (!culled_ids.count(kf.id)) {
          kept.push_back(std::move(kf));
          continue;
        }
        // The keyframe pose (BA-refined) replaces the tracking-time record.
        const auto it = recorded.find(kf.timestamp);
        if (it != recorded.end()) {
          m.frames[it->second].T_wc = kf.T_wc();
          m.frames[it->second].state = TrackingState::kTracking;
        } else {
          FrameRecord r;
          r.timestamp = kf.timestamp;
          r.state = TrackingState::kTracking;
          r.submap_id = m.id;
          r.T_wc = kf.T_wc();
          m.frames.push_back(r);
        }
      }
      m.keyframes = std::move(kept);
      std::sort(m.frames.begin(), m.frames.end(),
                [](const FrameRecord& a, const FrameRecord& b) { return a.timestamp < b.timestamp; });
      std::vector<MapPoint> points;
      for (MapPoint& p : m.points) {
        p.observations.erase(std::remove_if(p.observations.begin(), p.observations.end(),
                                            [&](const MapPoint::Observation& o) { return culled_ids.count(o.keyframe_id) > 0; }),
                             p.observations.end());
        if (!p.observations.empty()) points.push_back(std::move(p));
      }
      m.points = std::move(points);
    }
    rep.keyframes_after += int(m.keyframes.size());
    rep.points_after += int(m.points.size());
  }
  // Fused links to removed points go.
  std::vector<SubmapIndex> after(n);
  for (int s = 0; s < n; ++s) after[s].Build(map->submap(s));
  auto& fused = map->fused();
  fused.erase(std::remove_if(fused.begin(), fused.end(),
                             [&](const FusedPoint& f) {
                               return after[f.dup].Point(f.dup_point) < 0 || after[f.kept].Point(f.kept_point) < 0;
                             }),
              fused.end());
  spdlog::info("post-culling: saved keyframes {} -> {} ({} back, {} front, {} + {} revisit culled: fused, detected), "
               "points {} -> {}, {} front points found in back keyframes, {} revisit points fused ({} keyframes "
               "searched, {} submaps replayed, {:.2f} s)",
               rep.keyframes_before, rep.keyframes_after, rep.culled_back, rep.culled_front, rep.culled_revisit,
               rep.culled_revisit_detected, rep.points_before,
               rep.points_after, rep.front_points_found, rep.revisit_fused, rep.revisit_keyframes_searched,
               rep.revisit_submaps_replayed, rep.seconds_revisit);
  return rep;
}

}  // namespace rumi
