#include "manager/revisit_fusion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <tuple>
#include <unordered_map>

#include <opencv2/core.hpp>

#include "common/pnp.h"
#include "common/timestamp.h"
#include "manager/front_point_search.h"
#include "manager/merge_memo.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

// A front keyframe in the global frame.
struct Place {
  int submap = -1, keyframe = -1;
  Eigen::Vector3d centre, axis;  // optical axis
  double depth = 0;              // median depth of its points (global units)
};

// Median depth of a keyframe's mapped points in its camera (submap units),
// from at most 64 of them; 0 when it has none.
double MedianDepth(const Submap& s, const SubmapIndex& idx, const Keyframe& kf) {
  std::vector<double> z;
  const size_t step = std::max<size_t>(1, kf.point_ids.size() / 256);
  for (size_t i = 0; i < kf.point_ids.size() && z.size() < 64; i += step) {
    const int p = kf.point_ids[i] >= 0 ? idx.Point(kf.point_ids[i]) : -1;
    if (p < 0) continue;
    const double d = (kf.T_cw * s.points[size_t(p)].position).z();
    if (d > 0) z.push_back(d);
  }
  if (z.empty()) return 0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

// Per submap, once: id lookups and what a projection search needs per point.
struct Prepared {
  SubmapIndex idx;
  std::unordered_map<int64_t, int> kf_index;
  std::vector<const uint8_t*> desc;
  std::vector<double> max_distance;  // submap units
  std::vector<int> stamp;            // last keyframe search that listed the point
  bool points_ready = false;
};

int64_t CellKey(const Eigen::Vector3d& c, double cell) {
  const auto q = [&](double v) { return int64_t(std::floor(v / cell)) & 0x1fffff; };
  return (q(c.x()) << 42) | (q(c.y()) << 21) | q(c.z());
}

// What a submap's search depends on: its own shape and keyframe poses (a
// merge's welding moves them) and those of the earlier front submaps of its
// component (fronts in time order, TimeRanks; pose_hash[m]: KeyframePoseFingerprint).
std::vector<int64_t> Signature(const GlobalMap& map, const std::vector<int>& fronts,
                               const std::vector<uint64_t>& pose_hash, int s) {
  std::vector<int64_t> sig;
  for (int m : fronts) {  // in time order: s and the passes before it
    const Submap& sm = map.submap(m);
    sig.insert(sig.end(), {int64_t(map.Key(m).source), map.Key(m).id, int64_t(sm.keyframes.size()),
                           int64_t(sm.points.size()), int64_t(sm.frames.size()), int64_t(pose_hash[size_t(m)])});
    if (m == s) break;
  }
  return sig;
}

// An earlier pass's point seen by a neighbour place, in the searched
// keyframe's submap frame (by the merged Sim(3)s).
struct Candidate {
  Eigen::Vector3d X;
  const uint8_t* desc;
  double max_distance;
  int submap;
  int64_t point_id;
};

// keypoint -> (hamming, candidate) of its best claim.
using Claims = std::unordered_map<int, std::pair<int, int>>;

// Per searched keyframe, the earlier submaps its neighbours belong to, each
// with its own placement: the earlier passes over one place are themselves
// separate submaps, each drifted its own way, so a pose placed against one of
// them projects another's points off (a looped walk: a pass placed against
// the session's first submap for 208 keyframes found nothing where the 7th
// and 26th submaps' places came next).
struct Group {
  int a = -1;                                // earlier submap
  std::vector<std::pair<double, int>> near;  // its neighbour places
  Se3 pose;                                  // placed against a, else the merged pose
  bool placed = false;
};

// One FuseRevisitPoints call: the map's components one by one, each front
// submap's keyframes searched against the earlier passes of its component.
class RevisitFuser {
 public:
  RevisitFuser(GlobalMap* map, const ManagerOptions& o, const std::vector<bool>* searched, RevisitMemo* memo,
               RevisitFusionReport* rep)
      : map_(*map), o_(o), searched_(searched), memo_(memo), rep_(*rep), prep_(map->size()),
        cos_max_(std::cos(o.revisit_max_angle_deg * M_PI / 180.0)), rank_(TimeRanks(*map)) {
    // Links present already (merges, earlier rebuilds' fusions), either way round.
    for (const FusedPoint& f : map_.fused()) {
      present_.insert({f.dup, f.dup_point, f.kept, f.kept_point});
      present_.insert({f.kept, f.kept_point, f.dup, f.dup_point});
    }
  }

  void FuseComponent(int root) {
    if (!BuildPlaces(root)) return;
    votes_.clear();
    pose_hash_.clear();
    for (size_t first = 0; first < places_.size();) {
      size_t last = first;
      while (last < places_.size() && places_[last].submap == places_[first].submap) ++last;
      const int sb = places_[first].submap;
      if ((!searched_ || (*searched_)[size_t(sb)]) && !ReplayMemo(sb)) SearchPass(first, last);
      first = last;
    }
    AddVotedLinks();
  }

 private:
  // The component's front submaps in time order ("earlier" is time, not the
  // map's order) and their keyframes as places, bucketed by the search radius.
  bool BuildPlaces(int root) {
    fronts_.clear();
    for (int m : map_.Members(root))
      if (map_.submap(m).source == SubmapSource::kFront) fronts_.push_back(m);
    if (fronts_.size() < 2) return false;
    std::sort(fronts_.begin(), fronts_.end(), [&](int a, int b) { return rank_[size_t(a)] < rank_[size_t(b)]; });
    places_.clear();
    for (int s : fronts_) {
      const Submap& m = map_.submap(s);
      Prepared& p = prep_[size_t(s)];
      p.idx.Build(m);
      for (size_t k = 0; k < m.keyframes.size(); ++k) p.kf_index[m.keyframes[k].id] = int(k);
      const Sim3& S = map_.ToGlobal(s);
      for (size_t k = 0; k < m.keyframes.size(); ++k) {
        const Keyframe& kf = m.keyframes[k];
        const double depth = MedianDepth(m, p.idx, kf);
        if (depth <= 0) continue;
        const Se3 T_wc = kf.T_wc();
        places_.push_back({s, int(k), S * T_wc.translation(),
                           S.R() * (T_wc.rotation() * Eigen::Vector3d::UnitZ()), depth * S.scale()});
      }
    }
    if (places_.empty()) return false;
    std::vector<double> depths;
    for (const Place& pl : places_) depths.push_back(pl.depth);
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    radius_ = o_.revisit_radius * depths[depths.size() / 2];
    if (!(radius_ > 0) || !std::isfinite(radius_)) return false;
    cells_.clear();
    for (size_t i = 0; i < places_.size(); ++i) cells_[CellKey(places_[i].centre, radius_)].push_back(int(i));
    return true;
  }

  // Descriptors and viewing distances of a submap's points, once per call.
  void PreparePoints(int s) {
    Prepared& p = prep_[size_t(s)];
    if (p.points_ready) return;
    const Submap& m = map_.submap(s);
    p.desc.resize(m.points.size());
    p.max_distance.resize(m.points.size());
    p.stamp.assign(m.points.size(), -1);
    for (size_t i = 0; i < m.points.size(); ++i) {
      p.desc[i] = PointDescriptor(m, m.points[i], p.kf_index);
      p.max_distance[i] = PointMaxDistance(m, m.points[i], p.kf_index);
    }
    p.points_ready = true;
  }

  // With a memo: a submap whose signature is unchanged gets its links from
  // it (true); otherwise its entry is reset for this search (false).
  bool ReplayMemo(int sb) {
    if (!memo_) return false;
    if (pose_hash_.empty()) {
      pose_hash_.assign(map_.size(), 0);
      for (int m : fronts_) pose_hash_[size_t(m)] = KeyframePoseFingerprint(map_.submap(m));
    }
    std::vector<int64_t> sig = Signature(map_, fronts_, pose_hash_, sb);
    RevisitMemo::Entry& e = memo_->entries()[map_.Key(sb)];
    if (e.signature != sig) {
      e.signature = std::move(sig);
      e.links.clear();
      return false;
    }
    ++rep_.submaps_replayed;
    for (const RevisitMemo::Link& l : e.links) {
      const int a = map_.Find(l.kept);
      if (a < 0 || prep_[size_t(sb)].idx.Point(l.point) < 0 || prep_[size_t(a)].idx.Point(l.kept_point) < 0) continue;
      AddLink(sb, l.point, a, l.kept_point);
    }
    return true;
  }

  void AddLink(int b, int64_t b_point, int a, int64_t a_point) {
    if (!present_.insert({b, b_point, a, a_point}).second) return;
    present_.insert({a, a_point, b, b_point});
    map_.fused().push_back({b, b_point, a, a_point});
    ++rep_.fused;
  }

  // The nearest earlier-submap places of keyframe b seen from centre/axis.
  std::vector<std::pair<double, int>> FindNear(const Place& b, const Eigen::Vector3d& centre,
                                               const Eigen::Vector3d& axis) const {
    std::vector<std::pair<double, int>> near;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(CellKey(centre + radius_ * Eigen::Vector3d(dx, dy, dz), radius_));
          if (it == cells_.end()) continue;
          for (int j : it->second) {
            const Place& a = places_[size_t(j)];
            if (rank_[size_t(a.submap)] >= rank_[size_t(b.submap)]) continue;  // earlier passes only: each pair once
            const double d = (a.centre - centre).norm();
            if (d < radius_ && a.axis.dot(axis) > cos_max_) near.push_back({d, j});
          }
        }
    // A cell may be listed twice when the grid wraps: keep each place once.
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    if (int(near.size()) > o_.revisit_neighbours) near.resize(size_t(o_.revisit_neighbours));
    return near;
  }

  std::vector<std::pair<double, int>> NearOf(const Place& b, const Se3& T_cw) const {
    const Sim3& S_b = map_.ToGlobal(b.submap);
    const Se3 T_wc = T_cw.Inverse();
    return FindNear(b, S_b * T_wc.translation(), S_b.R() * (T_wc.rotation() * Eigen::Vector3d::UnitZ()));
  }

  // The earlier passes' points seen by the near places, each once.
  std::vector<Candidate> Candidates(const Place& b, const std::vector<std::pair<double, int>>& near) {
    std::vector<Candidate> cands;
    ++search_stamp_;
    for (const auto& [dist, j] : near) {
      const Place& a = places_[size_t(j)];
      PreparePoints(a.submap);
      Prepared& pa = prep_[size_t(a.submap)];
      const Submap& A = map_.submap(a.submap);
      const Sim3 S_ba = map_.ToGlobal(b.submap).Inverse() * map_.ToGlobal(a.submap);
      for (int64_t pid : A.keyframes[size_t(a.keyframe)].point_ids) {
        const int p = pid >= 0 ? pa.idx.Point(pid) : -1;
        if (p < 0 || pa.stamp[size_t(p)] == search_stamp_ || !pa.desc[size_t(p)]) continue;
        pa.stamp[size_t(p)] = search_stamp_;
        cands.push_back({S_ba * A.points[size_t(p)].position, pa.desc[size_t(p)],
                         S_ba.scale() * pa.max_distance[size_t(p)], a.submap, A.points[size_t(p)].id});
      }
    }
    return cands;
  }

  // The candidates projected with T_cw into keyframe b. The candidates, moved
  // by the same correction (T_cw = kb.T_cw * D), are where the keyframe's own
  // points should be: with check_depth a claim must also agree in depth.
  Claims SearchAll(const Place& b, const KeyframeSearch& search, const std::vector<Candidate>& cands,
                   double radius_px, const Se3& T_cw, bool check_depth) const {
    const Submap& B = map_.submap(b.submap);
    const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
    const SubmapIndex& idx_b = prep_[size_t(b.submap)].idx;
    const Se3 D = kb.T_wc() * T_cw;
    Claims claims;
    for (size_t c = 0; c < cands.size(); ++c) {
      const Candidate& cd = cands[c];
      int hamming = 0;
      const int kp =
          search.Match(cd.X, cd.desc, cd.max_distance, radius_px, o_.front_search_max_hamming, &hamming, &T_cw);
      if (kp < 0) continue;
      if (check_depth) {
        // The corner's own point must lie where the projected one does (a
        // descriptor match along the same ray at another depth is not the
        // same point).
        const int q = idx_b.Point(kb.point_ids[size_t(kp)]);
        if (q < 0) continue;
        const Eigen::Vector3d X = D * cd.X;
        const double depth = (kb.T_cw * X).norm();
        if ((B.points[size_t(q)].position - X).norm() > o_.revisit_max_offset * depth) continue;
      }
      const auto it = claims.find(kp);
      if (it == claims.end() || hamming < it->second.first) claims[kp] = {hamming, int(c)};
    }
    return claims;
  }

  // The two passes are separate front submaps joined at one place; away from
  // it they drift apart by more than the search radius. As ORB-SLAM corrects
  // a loop before it fuses, the keyframe is first placed against the earlier
  // pass: a wide search from the guess, then PnP RANSAC.
  bool PlaceKeyframe(const Place& b, const KeyframeSearch& search, const std::vector<Candidate>& cands,
                     const Se3& guess, double radius_px, Se3* placed) const {
    const Claims wide = SearchAll(b, search, cands, radius_px, guess, /*check_depth=*/false);
    if (int(wide.size()) < o_.revisit_min_pnp_inliers) return false;
    const Keyframe& kb = map_.submap(b.submap).keyframes[size_t(b.keyframe)];
    std::vector<cv::Point3f> obj;
    std::vector<cv::Point2f> img;
    for (const auto& [kp, claim] : wide) {
      const Eigen::Vector3d& X = cands[size_t(claim.second)].X;
      obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
      img.emplace_back(kb.keypoints[size_t(kp)].x(), kb.keypoints[size_t(kp)].y());
    }
    std::vector<int> inliers;
    Se3 T_cw;
    if (!PnpRansacFromGuess(obj, img, map_.submap(b.submap).camera, guess.rotation().toRotationMatrix(),
                            guess.translation(), o_.front_search_px, &T_cw, &inliers) ||
        int(inliers.size()) < o_.revisit_min_pnp_inliers)
      return false;
    // A consensus on a wrong pose (repeated texture) moves the camera far: a
    // right correction stays within the depth check's tolerance of the guess
    // and turns the axis less than neighbours may differ.
    const Se3 g_wc = guess.Inverse(), p_wc = T_cw.Inverse();
    const double depth = b.depth / map_.ToGlobal(b.submap).scale();
    if ((g_wc.translation() - p_wc.translation()).norm() > o_.revisit_max_offset * depth ||
        (g_wc.rotation() * Eigen::Vector3d::UnitZ()).dot(p_wc.rotation() * Eigen::Vector3d::UnitZ()) < cos_max_)
      return false;
    *placed = T_cw;
    return true;
  }

  // One searched submap's keyframes, places_[first, last), in order: a placed
  // keyframe's correction (D, with T_cw = kb.T_cw * D) is the next one's
  // guess, so the placement follows the drift along the pass instead of
  // failing once it exceeds the wide search (a looped walk: 210 of a pass's
  // 332 keyframes found < 10 wide matches from the merged pose). Forward,
  // then backward over what the forward sweep did not place; then the votes.
  void SearchPass(size_t first, size_t last) {
    std::vector<std::vector<Group>> groups(last - first);
    Sweep(first, last, /*forward=*/true, &groups);
    Sweep(first, last, /*forward=*/false, &groups);
    Vote(first, last, groups);
  }

  void Sweep(size_t first, size_t last, bool forward, std::vector<std::vector<Group>>* groups) {
    const Submap& B = map_.submap(places_[first].submap);
    // The correction last found against each earlier submap (T_cw = kb.T_cw *
    // D), and the last one found: it is the next keyframe's guess.
    std::map<int, Se3> d_of;
    int last_a = -1;
    for (size_t step = 0; step < last - first; ++step) {
      const size_t i = forward ? step : last - first - 1 - step;
      const Place& b = places_[first + i];
      const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
      if (forward) AddGroups(b, last_a >= 0 ? &d_of.at(last_a) : nullptr, &(*groups)[i]);
      for (Group& g : (*groups)[i]) {
        if (!g.placed && o_.revisit_wide_px > 0) PlaceGroup(b, d_of, last_a, forward, &g);
        if (g.placed) {
          d_of[g.a] = kb.T_wc() * g.pose;
          last_a = g.a;
        }
      }
    }
  }

  // Keyframe b's neighbours around the last correction's guess (d), else
  // around its merged pose, grouped by earlier submap.
  void AddGroups(const Place& b, const Se3* d, std::vector<Group>* groups) const {
    const Keyframe& kb = map_.submap(b.submap).keyframes[size_t(b.keyframe)];
    auto near = d ? NearOf(b, kb.T_cw * *d) : NearOf(b, kb.T_cw);
    if (near.empty() && d) near = NearOf(b, kb.T_cw);
    for (const auto& nj : near) {
      const int a = places_[size_t(nj.second)].submap;
      auto it = std::find_if(groups->begin(), groups->end(), [&](const Group& g) { return g.a == a; });
      if (it == groups->end()) it = groups->insert(groups->end(), Group{a, {}, kb.T_cw, false});
      it->near.push_back(nj);
    }
  }

  // Guesses: the group's own correction, else the last one found; then
  // (forward only) the merged pose: a front that relocalises in its own map
  // jumps to another part of its pass, where the last correction is wrong.
  // Last, a 3x wider search from the first guess: a pass never placed
  // against this one yet may be off by more.
  void PlaceGroup(const Place& b, const std::map<int, Se3>& d_of, int last_a, bool forward, Group* g) {
    const Submap& B = map_.submap(b.submap);
    const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
    std::vector<Se3> guesses;
    const auto own = d_of.find(g->a);
    if (own != d_of.end())
      guesses.push_back(kb.T_cw * own->second);
    else if (last_a >= 0)
      guesses.push_back(kb.T_cw * d_of.at(last_a));
    if (forward) guesses.push_back(kb.T_cw);
    const KeyframeSearch search(kb, B.camera, /*mapped=*/true);
    const std::vector<Candidate> cands = Candidates(b, g->near);
    std::vector<std::pair<Se3, double>> tries;
    for (const Se3& guess : guesses) tries.push_back({guess, o_.revisit_wide_px});
    if (!guesses.empty()) tries.push_back({guesses.front(), 3 * o_.revisit_wide_px});
    for (const auto& [guess, radius_px] : tries) {
      Se3 T_cw;
      if (!PlaceKeyframe(b, search, cands, guess, radius_px, &T_cw)) continue;
      g->pose = T_cw;
      g->placed = true;
      return;
    }
  }

  // Each keyframe's claims at its groups' poses vote for point pairs.
  void Vote(size_t first, size_t last, const std::vector<std::vector<Group>>& groups) {
    const Submap& B = map_.submap(places_[first].submap);
    for (size_t i = 0; i < last - first; ++i) {
      if (groups[i].empty()) continue;
      ++rep_.keyframes_searched;
      const Place& b = places_[first + i];
      const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
      const KeyframeSearch search(kb, B.camera, /*mapped=*/true);
      bool any_placed = false;
      for (const Group& g : groups[i]) {
        any_placed |= g.placed;
        const std::vector<Candidate> cands = Candidates(b, g.near);
        for (const auto& [kp, claim] : SearchAll(b, search, cands, o_.front_search_px, g.pose, /*check_depth=*/true)) {
          const Candidate& cd = cands[size_t(claim.second)];
          ++votes_[{b.submap, kb.point_ids[size_t(kp)], cd.submap}][cd.point_id];
        }
      }
      rep_.keyframes_corrected += any_placed;
    }
  }

  // Each later point links to the earlier point most of its claims named.
  void AddVotedLinks() {
    for (const auto& [key, by_point] : votes_) {
      const auto best = std::max_element(by_point.begin(), by_point.end(),
                                         [](const auto& x, const auto& y) { return x.second < y.second; });
      const auto [b, b_point, a] = key;
      if (memo_) memo_->entries()[map_.Key(b)].links.push_back({b_point, map_.Key(a), best->first});
      AddLink(b, b_point, a, best->first);
    }
  }

  GlobalMap& map_;
  const ManagerOptions& o_;
  const std::vector<bool>* searched_;
  RevisitMemo* memo_;
  RevisitFusionReport& rep_;
  std::vector<Prepared> prep_;
  std::set<std::tuple<int, int64_t, int, int64_t>> present_;
  const double cos_max_;
  const std::vector<int> rank_;
  int search_stamp_ = 0;
  // The component being fused.
  std::vector<int> fronts_;
  std::vector<Place> places_;
  double radius_ = 0;
  std::unordered_map<int64_t, std::vector<int>> cells_;
  // (later submap, its point, earlier submap) -> earlier point -> votes
  std::map<std::tuple<int, int64_t, int>, std::map<int64_t, int>> votes_;
  std::vector<uint64_t> pose_hash_;  // of the component's fronts, once a memo needs them
};


}  // namespace

void RevisitMemo::Retain(const GlobalMap& map, const std::vector<bool>& searched) {
  for (auto it = entries_.begin(); it != entries_.end();) {
    const int i = map.Find(it->first);
    it = i < 0 || size_t(i) >= searched.size() || !searched[size_t(i)] ? entries_.erase(it) : std::next(it);
  }
}

RevisitFusionReport FuseRevisitPoints(GlobalMap* map, const ManagerOptions& o, const std::vector<bool>* searched,
                                      RevisitMemo* memo) {
  RevisitFusionReport rep;
  if (!o.revisit_fusion || o.front_search_px <= 0) return rep;
  const auto start = std::chrono::steady_clock::now();
  RevisitFuser fuser(map, o, searched, memo, &rep);
  for (int root : map->ComponentsBySize()) fuser.FuseComponent(root);
  rep.seconds = SecondsSince(start);
  return rep;
}

}  // namespace rumi
