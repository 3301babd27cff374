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

// Marks the keyframes to cull (culled()[submap][keyframe]), by the rules of
// CullRedundantKeyframes (post_culling.h), over the map as it is.
class RedundancyCuller {
 public:
  RedundancyCuller(const GlobalMap& map, const ManagerOptions& options, CullingReport* rep)
      : map_(map), o_(options), rep_(*rep), n_(int(map.size())), idx_(size_t(n_)), clusters_(BuildIndex(), map) {
    for (const FusedPoint& f : map_.fused())
      clusters_.Join(clusters_.Id(f.dup, f.dup_point), clusters_.Id(f.kept, f.kept_point));
    // Front points found in back keyframes: more observers of those points,
    // and more points of those keyframes.
    const auto search_start = std::chrono::steady_clock::now();
    cross_ = SearchFrontPoints(map_, o_);
    rep_.seconds_front_search = SecondsSince(search_start);
    rep_.front_points_found = int(cross_.size());
    cross_cluster_.resize(cross_.size());
    for (size_t i = 0; i < cross_.size(); ++i) cross_cluster_[i] = clusters_.Id(cross_[i].front, cross_[i].point_id);
    BuildObservers();
    for (int s = 0; s < n_; ++s) {
      rep_.keyframes_before += int(map_.submap(s).keyframes.size());
      rep_.points_before += int(map_.submap(s).points.size());
    }
    // A back keyframe's found front points: (cluster, octave) per keyframe.
    for (size_t i = 0; i < cross_.size(); ++i) {
      const int k = idx_[size_t(cross_[i].back)].Keyframe(cross_[i].keyframe_id);
      if (k >= 0) extra_[Key(cross_[i].back, size_t(k))].push_back({cross_cluster_[i], cross_[i].octave});
    }
    culled_.resize(size_t(n_));
    alive_.resize(size_t(n_));
    for (int s = 0; s < n_; ++s) {
      alive_[size_t(s)] = int(map_.submap(s).keyframes.size());
      culled_[size_t(s)].assign(map_.submap(s).keyframes.size(), 0);
    }
    // Passes in time order: "earlier" below is time, not the map's order.
    rank_ = TimeRanks(map_);
    by_time_.resize(size_t(n_));
    for (int s = 0; s < n_; ++s) by_time_[size_t(rank_[size_t(s)])] = s;
    listed_by_.assign(clusters_.size(), -1);
    if (o_.culling_loop_ratio > 0)
      for (const auto& [qkey, list] : map_.loops().searched) {
        const int s = map_.Find(qkey.first);
        if (s < 0) continue;
        const int k = idx_[size_t(s)].Keyframe(qkey.second);
        if (k >= 0)
          for (const LoopDetection& d : list) detections_[Key(s, size_t(k))].push_back(&d);
      }
  }

  // Revisits first, the newest submap first: a front keyframe whose place an
  // earlier pass mapped (culling_revisit_ratio of its points fused with
  // points that other front submaps' keyframes see) goes, and the older pass
  // stays. Back keyframes do not count here: a back window re-images the
  // front's keyframes by design, and CullRedundant culls the back first.
  void CullRevisits() {
    if (!(o_.culling_revisit_ratio > 0 || o_.culling_loop_ratio > 0)) return;
    for (int r = n_ - 1; r >= 0; --r) {
      const int s = by_time_[size_t(r)];
      const Submap& m = map_.submap(s);
      if (m.source == SubmapSource::kBack) continue;
      for (size_t k = 0; k < m.keyframes.size() && alive_[size_t(s)] > 1; ++k) {
        if (o_.culling_revisit_ratio > 0 && RedundantShare(s, k, /*other_fronts=*/true) >= o_.culling_revisit_ratio)
          Cull(s, k, &rep_.culled_revisit);
        else if (RevisitByDetection(s, k))
          Cull(s, k, &rep_.culled_revisit_detected);
      }
    }
  }

  // ORB-SLAM's rule, back submaps first: a keyframe goes when
  // culling_redundant_ratio of its points are seen by enough others.
  void CullRedundant() {
    std::vector<double> back_shares;
    for (const bool back_pass : {true, false}) {
      for (int s = 0; s < n_; ++s) {
        const Submap& m = map_.submap(s);
        if ((m.source == SubmapSource::kBack) != back_pass) continue;
        for (size_t k = 0; k < m.keyframes.size(); ++k) {
          if (alive_[size_t(s)] <= 1) break;  // a submap keeps at least one keyframe
          if (culled_[size_t(s)][k]) continue;
          const double share = RedundantShare(s, k, /*other_fronts=*/false);
          if (share < 0) continue;
          if (back_pass) back_shares.push_back(share);
          if (share >= o_.culling_redundant_ratio) Cull(s, k, back_pass ? &rep_.culled_back : &rep_.culled_front);
        }
      }
    }
    rep_.back_examined = int(back_shares.size());
    if (!back_shares.empty()) {
      std::nth_element(back_shares.begin(), back_shares.begin() + back_shares.size() / 2, back_shares.end());
      rep_.back_redundant_share_median = back_shares[back_shares.size() / 2];
    }
  }

  const std::vector<std::vector<char>>& culled() const { return culled_; }

 private:
  static int64_t Key(int s, size_t k) { return (int64_t(s) << 32) | int64_t(k); }

  const std::vector<SubmapIndex>& BuildIndex() {
    for (int s = 0; s < n_; ++s) idx_[size_t(s)].Build(map_.submap(s));
    return idx_;
  }

  // Calls visit(cluster, observer) for every observation of a point: the
  // submaps' own and the front points found in back keyframes.
  template <class Visit>
  void ForEachObservation(const Visit& visit) {
    for (int s = 0; s < n_; ++s) {
      const Submap& m = map_.submap(s);
      for (size_t p = 0; p < m.points.size(); ++p)
        for (const auto& ob : m.points[p].observations) {
          const int k = idx_[size_t(s)].Keyframe(ob.keyframe_id);
          if (k < 0) continue;
          const Keyframe& kf = m.keyframes[size_t(k)];
          const uint8_t oct = ob.keypoint_index >= 0 && ob.keypoint_index < int(kf.octaves.size())
                                  ? kf.octaves[size_t(ob.keypoint_index)]
                                  : 0;
          visit(clusters_.IdOfIndex(s, int(p)), Observer{s, k, oct});
        }
    }
    for (size_t i = 0; i < cross_.size(); ++i) {
      const int k = idx_[size_t(cross_[i].back)].Keyframe(cross_[i].keyframe_id);
      if (k >= 0) visit(cross_cluster_[i], Observer{cross_[i].back, k, cross_[i].octave});
    }
  }

  // Observers per cluster root, flat (counted, then filled).
  void BuildObservers() {
    begin_.assign(clusters_.size() + 1, 0);
    ForEachObservation([&](int c, const Observer&) { ++begin_[size_t(clusters_.Root(c)) + 1]; });
    for (size_t c = 0; c < clusters_.size(); ++c) begin_[c + 1] += begin_[c];
    observers_.resize(size_t(begin_.back()));
    std::vector<int> fill(begin_.begin(), begin_.end() - 1);
    ForEachObservation([&](int c, const Observer& o) { observers_[size_t(fill[size_t(clusters_.Root(c))]++)] = o; });
  }

  bool Earlier(int a, int b) const { return rank_[size_t(a)] < rank_[size_t(b)]; }

  // Keyframe k of submap s's points as (cluster root, octave), each cluster once.
  std::vector<std::pair<int, uint8_t>> KeyframeClusters(int s, size_t k) {
    const Keyframe& kf = map_.submap(s).keyframes[k];
    ++keyframe_stamp_;
    std::vector<std::pair<int, uint8_t>> points;
    const auto list = [&](int root, uint8_t oct) {
      if (listed_by_[size_t(root)] == keyframe_stamp_) return;
      listed_by_[size_t(root)] = keyframe_stamp_;
      points.push_back({root, oct});
    };
    for (size_t i = 0; i < kf.point_ids.size(); ++i) {
      if (kf.point_ids[i] < 0) continue;
      const int p = idx_[size_t(s)].Point(kf.point_ids[i]);
      if (p < 0) continue;
      list(clusters_.Root(clusters_.IdOfIndex(s, p)), i < kf.octaves.size() ? kf.octaves[i] : 0);
    }
    const auto ex = extra_.find(Key(s, k));
    if (ex != extra_.end())
      for (const auto& [c, oct] : ex->second) list(clusters_.Root(c), oct);
    return points;
  }

  // Share of keyframe k of submap s whose points are seen by
  // culling_min_observers living keyframes other than itself; with
  // other_fronts, by one living keyframe of an earlier front submap (the
  // point is known to an earlier pass, which culling may have thinned to
  // fewer observers than the ORB rule asks; never a later one, or the earlier
  // pass would go for the keyframe the later one must keep). -1 when it has
  // no point.
  double RedundantShare(int s, size_t k, bool other_fronts) {
    const int needed = other_fronts ? 1 : o_.culling_min_observers;
    const std::vector<std::pair<int, uint8_t>> points = KeyframeClusters(s, k);
    if (points.empty()) return -1.0;
    int redundant = 0;
    for (const auto& [root, oct] : points) {
      seen_.clear();
      for (int o = begin_[size_t(root)]; o < begin_[size_t(root) + 1] && int(seen_.size()) < needed; ++o) {
        const Observer& ob = observers_[size_t(o)];
        if ((ob.submap == s && ob.keyframe == int(k)) ||
            (other_fronts && (!Earlier(ob.submap, s) || map_.submap(ob.submap).source != SubmapSource::kFront)) ||
            ob.octave > oct + o_.culling_octave_tolerance || culled_[size_t(ob.submap)][size_t(ob.keyframe)])
          continue;
        const std::pair<int, int> key{ob.submap, ob.keyframe};
        if (std::find(seen_.begin(), seen_.end(), key) == seen_.end()) seen_.push_back(key);
      }
      if (int(seen_.size()) >= needed) ++redundant;
    }
    return double(redundant) / double(points.size());
  }

  int MappedPoints(int s, size_t k) const {
    int count = 0;
    for (int64_t pid : map_.submap(s).keyframes[k].point_ids) count += pid >= 0 && idx_[size_t(s)].Point(pid) >= 0;
    return count;
  }

  // A living keyframe of submap m within loop_group_s of time t (loop
  // closure's scale of one place): the place is still mapped there. (Earlier
  // submaps are culled after later ones here, so this holds for keyframes
  // culled at earlier rebuilds, which have left the map; a keyframe
  // CullRedundant culls now has others that see its points.)
  bool AliveNear(int m, Timestamp t) const {
    const int64_t near_ns = int64_t(o_.loop_group_s * 1e9);
    const auto& kfs = map_.submap(m).keyframes;
    auto it = std::lower_bound(kfs.begin(), kfs.end(), t - near_ns,
                               [](const Keyframe& kf, Timestamp x) { return kf.timestamp < x; });
    for (; it != kfs.end() && it->timestamp <= t + near_ns; ++it)
      if (!culled_[size_t(m)][size_t(it - kfs.begin())]) return true;
    return false;
  }

  // A verified loop detection (loop_closure.h: descriptor matches, a RANSAC
  // Sim(3) and PnP against an earlier pass's keyframe and its neighbours)
  // says what revisit fusion says without placing the keyframe first: the
  // share of its mapped points that were inliers there. Revisit fusion
  // places a keyframe in the global frame before it can fuse, and on a
  // looped walk it placed only a third of them (20 minutes live: 1,389 of
  // 4,113); the loop search verified a detection for most.
  bool RevisitByDetection(int s, size_t k) const {
    const auto it = detections_.find(Key(s, k));
    if (it == detections_.end()) return false;
    const int own = MappedPoints(s, k);
    if (own == 0) return false;
    for (const LoopDetection* d : it->second) {
      if (double(d->inliers) < o_.culling_loop_ratio * own) continue;
      const int m = map_.Find(d->match_submap);
      if (m < 0 || !Earlier(m, s) || map_.submap(m).source != SubmapSource::kFront || !map_.Connected(m, s)) continue;
      if (AliveNear(m, d->match_time)) return true;
    }
    return false;
  }

  void Cull(int s, size_t k, int* counter) {
    culled_[size_t(s)][k] = 1;
    --alive_[size_t(s)];
    ++*counter;
  }

  const GlobalMap& map_;
  const ManagerOptions& o_;
  CullingReport& rep_;
  const int n_;
  std::vector<SubmapIndex> idx_;  // before clusters_, which refers to it
  PointClusters clusters_;
  std::vector<CrossObservation> cross_;
  std::vector<int> cross_cluster_;
  std::vector<int> begin_;  // observers_[begin_[root], begin_[root + 1]) of a cluster root
  std::vector<Observer> observers_;
  std::unordered_map<int64_t, std::vector<std::pair<int, uint8_t>>> extra_;  // Key(s, k)
  std::unordered_map<int64_t, std::vector<const LoopDetection*>> detections_;  // Key(s, k)
  std::vector<std::vector<char>> culled_;
  std::vector<int> alive_;
  std::vector<int> rank_, by_time_;
  std::vector<int> listed_by_;  // the keyframe that last listed a cluster
  int keyframe_stamp_ = 0;
  std::vector<std::pair<int, int>> seen_;  // distinct other keyframes (submap, index)
};

// Removes the culled keyframes, keeping their poses as frame records, their
// observations and the points that only they supported.
void ApplyCulling(const std::vector<std::vector<char>>& culled, GlobalMap* map, CullingReport* rep) {
  for (size_t s = 0; s < map->size(); ++s) {
    Submap& m = map->submap(int(s));
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
    rep->keyframes_after += int(m.keyframes.size());
    rep->points_after += int(m.points.size());
  }
  // Fused links to removed points go.
  std::vector<SubmapIndex> after(map->size());
  for (size_t s = 0; s < map->size(); ++s) after[s].Build(map->submap(int(s)));
  auto& fused = map->fused();
  fused.erase(std::remove_if(fused.begin(), fused.end(),
                             [&](const FusedPoint& f) {
                               return after[f.dup].Point(f.dup_point) < 0 || after[f.kept].Point(f.kept_point) < 0;
                             }),
              fused.end());
}

}  // namespace

CullingReport CullRedundantKeyframes(GlobalMap* map, const ManagerOptions& options,
                                     const std::vector<bool>* revisit_searched, RevisitMemo* revisit_memo) {
  CullingReport rep;
  const RevisitFusionReport fusion = FuseRevisitPoints(map, options, revisit_searched, revisit_memo);
  rep.revisit_keyframes_searched = fusion.keyframes_searched;
  rep.revisit_keyframes_placed = fusion.keyframes_corrected;
  rep.revisit_fused = fusion.fused;
  rep.revisit_submaps_replayed = fusion.submaps_replayed;
  rep.seconds_revisit = fusion.seconds;
  {
    RedundancyCuller culler(*map, options, &rep);
    culler.CullRevisits();
    culler.CullRedundant();
    ApplyCulling(culler.culled(), map, &rep);
  }
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
