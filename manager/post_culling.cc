#include "manager/post_culling.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "common/logging.h"
#include "common/timestamp.h"
#include "manager/front_point_search.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

struct Observer {
  int submap;
  int64_t keyframe_id;
  uint8_t octave;
};

// Union-find over (submap, point id) to merge fused duplicates into clusters.
class PointClusters {
 public:
  int Id(int submap, int64_t pid) {
    const auto key = std::make_pair(submap, pid);
    const auto it = ids_.find(key);
    if (it != ids_.end()) return Root(it->second);
    parent_.push_back(int(parent_.size()));
    ids_[key] = parent_.back();
    return parent_.back();
  }
  void Join(int a, int b) { parent_[Root(a)] = Root(b); }
  int Root(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }

 private:
  std::map<std::pair<int, int64_t>, int> ids_;
  std::vector<int> parent_;
};

}  // namespace

CullingReport CullRedundantKeyframes(GlobalMap* map, const ManagerOptions& options) {
  CullingReport rep;
  const int n = int(map->size());
  PointClusters clusters;
  for (const FusedPoint& f : map->fused()) clusters.Join(clusters.Id(f.dup, f.dup_point), clusters.Id(f.kept, f.kept_point));
  std::vector<SubmapIndex> idx(n);
  std::unordered_map<int, std::vector<Observer>> observers;  // cluster -> observers
  for (int s = 0; s < n; ++s) {
    const Submap& m = map->submap(s);
    idx[s].Build(m);
    rep.keyframes_before += int(m.keyframes.size());
    rep.points_before += int(m.points.size());
    for (const MapPoint& p : m.points) {
      const int c = clusters.Id(s, p.id);
      for (const auto& ob : p.observations) {
        const int k = idx[s].Keyframe(ob.keyframe_id);
        if (k < 0) continue;
        const Keyframe& kf = m.keyframes[k];
        const uint8_t oct = ob.keypoint_index >= 0 && ob.keypoint_index < int(kf.octaves.size())
                                ? kf.octaves[ob.keypoint_index]
                                : 0;
        observers[c].push_back({s, ob.keyframe_id, oct});
      }
    }
  }
  // Front points found in back keyframes: more observers of those points, and
  // more points of those keyframes.
  std::map<std::pair<int, int64_t>, std::vector<std::pair<int, uint8_t>>> extra;  // keyframe -> (cluster, octave)
  const auto search_start = std::chrono::steady_clock::now();
  const std::vector<CrossObservation> cross = SearchFrontPoints(*map, options);
  rep.seconds_front_search = SecondsSince(search_start);
  rep.front_points_found = int(cross.size());
  for (const CrossObservation& x : cross) {
    const int c = clusters.Id(x.front, x.point_id);
    observers[c].push_back({x.back, x.keyframe_id, x.octave});
    extra[{x.back, x.keyframe_id}].push_back({c, x.octave});
  }
  // Clusters are final now; resolve observer lists under their roots.
  std::unordered_map<int, std::vector<Observer>> by_root;
  for (auto& [c, obs] : observers) {
    auto& dst = by_root[clusters.Root(c)];
    dst.insert(dst.end(), obs.begin(), obs.end());
  }
  std::vector<std::unordered_set<int64_t>> culled(n);
  std::vector<int> alive(n);
  for (int s = 0; s < n; ++s) alive[s] = int(map->submap(s).keyframes.size());
  auto is_culled = [&](int s, int64_t kf) { return culled[s].count(kf) > 0; };

  std::vector<double> back_shares;
  for (const bool back_pass : {true, false}) {
    for (int s = 0; s < n; ++s) {
      Submap& m = map->submap(s);
      if ((m.source == SubmapSource::kBack) != back_pass) continue;
      for (const Keyframe& kf : m.keyframes) {
        if (alive[s] <= 1) break;  // a submap keeps at least one keyframe
        // The keyframe's points as (cluster root, octave), each cluster once.
        std::vector<std::pair<int, uint8_t>> points;
        std::unordered_set<int> listed;
        for (size_t i = 0; i < kf.point_ids.size(); ++i) {
          if (kf.point_ids[i] < 0 || idx[s].Point(kf.point_ids[i]) < 0) continue;
          const int root = clusters.Root(clusters.Id(s, kf.point_ids[i]));
          if (listed.insert(root).second) points.push_back({root, i < kf.octaves.size() ? kf.octaves[i] : 0});
        }
        const auto ex = extra.find({s, kf.id});
        if (ex != extra.end())
          for (const auto& [c, oct] : ex->second)
            if (listed.insert(clusters.Root(c)).second) points.push_back({clusters.Root(c), oct});
        int with_point = 0, redundant = 0;
        for (const auto& [root, oct] : points) {
          ++with_point;
          const auto it = by_root.find(root);
          if (it == by_root.end()) continue;
          std::unordered_set<int64_t> seen;  // distinct other keyframes
          for (const Observer& o : it->second) {
            if ((o.submap == s && o.keyframe_id == kf.id) || o.octave > oct + options.culling_octave_tolerance ||
                is_culled(o.submap, o.keyframe_id))
              continue;
            seen.insert((int64_t(o.submap) << 40) ^ o.keyframe_id);
            if (int(seen.size()) >= options.culling_min_observers) break;
          }
          if (int(seen.size()) >= options.culling_min_observers) ++redundant;
        }
        if (back_pass && with_point > 0) back_shares.push_back(double(redundant) / with_point);
        if (with_point > 0 && redundant >= options.culling_redundant_ratio * with_point) {
          culled[s].insert(kf.id);
          --alive[s];
          (back_pass ? rep.culled_back : rep.culled_front) += 1;
        }
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
    if (!culled[s].empty()) {
      std::unordered_map<Timestamp, size_t> recorded;
      for (size_t i = 0; i < m.frames.size(); ++i) recorded[m.frames[i].timestamp] = i;
      std::vector<Keyframe> kept;
      for (Keyframe& kf : m.keyframes) {
        if (!culled[s].count(kf.id)) {
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
                                            [&](const MapPoint::Observation& o) { return culled[s].count(o.keyframe_id) > 0; }),
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
  spdlog::info("post-culling: saved keyframes {} -> {} ({} back, {} front culled), points {} -> {}, {} front "
               "points found in back keyframes",
               rep.keyframes_before, rep.keyframes_after, rep.culled_back, rep.culled_front, rep.points_before,
               rep.points_after, rep.front_points_found);
  return rep;
}

}  // namespace rumi
