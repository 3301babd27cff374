#include "manager/revisit_fusion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <tuple>
#include <unordered_map>

#include <opencv2/calib3d.hpp>

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
  const int n = int(map->size());
  std::vector<Prepared> prep(static_cast<size_t>(n));
  const auto prepare_points = [&](int s) {
    Prepared& p = prep[size_t(s)];
    if (p.points_ready) return;
    const Submap& m = map->submap(s);
    p.desc.resize(m.points.size());
    p.max_distance.resize(m.points.size());
    p.stamp.assign(m.points.size(), -1);
    for (size_t i = 0; i < m.points.size(); ++i) {
      p.desc[i] = PointDescriptor(m, m.points[i], p.kf_index);
      p.max_distance[i] = PointMaxDistance(m, m.points[i], p.kf_index);
    }
    p.points_ready = true;
  };
  // Links present already (merges, earlier rebuilds' fusions), either way round.
  std::set<std::tuple<int, int64_t, int, int64_t>> present;
  for (const FusedPoint& f : map->fused()) {
    present.insert({f.dup, f.dup_point, f.kept, f.kept_point});
    present.insert({f.kept, f.kept_point, f.dup, f.dup_point});
  }
  const double cos_max = std::cos(o.revisit_max_angle_deg * M_PI / 180.0);
  int search_stamp = 0;
  const std::vector<int> rank = TimeRanks(*map);  // "earlier" is time, not the map's order
  for (int root : map->ComponentsBySize()) {
    std::vector<int> fronts;
    for (int m : map->Members(root))
      if (map->submap(m).source == SubmapSource::kFront) fronts.push_back(m);
    if (fronts.size() < 2) continue;
    std::sort(fronts.begin(), fronts.end(), [&](int a, int b) { return rank[size_t(a)] < rank[size_t(b)]; });
    std::vector<Place> places;
    for (int s : fronts) {
      const Submap& m = map->submap(s);
      Prepared& p = prep[size_t(s)];
      p.idx.Build(m);
      for (size_t k = 0; k < m.keyframes.size(); ++k) p.kf_index[m.keyframes[k].id] = int(k);
      const Sim3& S = map->ToGlobal(s);
      for (size_t k = 0; k < m.keyframes.size(); ++k) {
        const Keyframe& kf = m.keyframes[k];
        const double depth = MedianDepth(m, p.idx, kf);
        if (depth <= 0) continue;
        const Se3 T_wc = kf.T_wc();
        places.push_back({s, int(k), S * T_wc.translation(), S.R() * (T_wc.rotation() * Eigen::Vector3d::UnitZ()),
                          depth * S.scale()});
      }
    }
    if (places.empty()) continue;
    std::vector<double> depths;
    for (const Place& pl : places) depths.push_back(pl.depth);
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    const double radius = o.revisit_radius * depths[depths.size() / 2];
    if (!(radius > 0) || !std::isfinite(radius)) continue;
    std::unordered_map<int64_t, std::vector<int>> cells;
    for (size_t i = 0; i < places.size(); ++i) cells[CellKey(places[i].centre, radius)].push_back(int(i));

    // (later submap, its point, earlier submap) -> earlier point -> votes
    std::map<std::tuple<int, int64_t, int>, std::map<int64_t, int>> votes;
    // The nearest earlier-submap places of a keyframe seen from centre/axis.
    const auto find_near = [&](const Place& b, const Eigen::Vector3d& centre, const Eigen::Vector3d& axis) {
      std::vector<std::pair<double, int>> near;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = cells.find(CellKey(centre + radius * Eigen::Vector3d(dx, dy, dz), radius));
            if (it == cells.end()) continue;
            for (int j : it->second) {
              const Place& a = places[size_t(j)];
              if (rank[size_t(a.submap)] >= rank[size_t(b.submap)]) continue;  // earlier passes only: each pair once
              const double d = (a.centre - centre).norm();
              if (d < radius && a.axis.dot(axis) > cos_max) near.push_back({d, j});
            }
          }
      // A cell may be listed twice when the grid wraps: keep each place once.
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      if (int(near.size()) > o.revisit_neighbours) near.resize(size_t(o.revisit_neighbours));
      return near;
    };
    struct Candidate {
      Eigen::Vector3d X;  // in the later submap's frame, by the merged Sim(3)
      const uint8_t* desc;
      double max_distance;
      int submap;
      int64_t point_id;
    };
    // The earlier passes' points seen by the near places, each once.
    const auto candidates = [&](const Place& b, const std::vector<std::pair<double, int>>& near) {
      std::vector<Candidate> cands;
      ++search_stamp;
      for (const auto& [dist, j] : near) {
        const Place& a = places[size_t(j)];
        prepare_points(a.submap);
        Prepared& pa = prep[size_t(a.submap)];
        const Submap& A = map->submap(a.submap);
        const Sim3 S_ba = map->ToGlobal(b.submap).Inverse() * map->ToGlobal(a.submap);
        for (int64_t pid : A.keyframes[size_t(a.keyframe)].point_ids) {
          const int p = pid >= 0 ? pa.idx.Point(pid) : -1;
          if (p < 0 || pa.stamp[size_t(p)] == search_stamp || !pa.desc[size_t(p)]) continue;
          pa.stamp[size_t(p)] = search_stamp;
          cands.push_back({S_ba * A.points[size_t(p)].position, pa.desc[size_t(p)],
                           S_ba.scale() * pa.max_distance[size_t(p)], a.submap, A.points[size_t(p)].id});
        }
      }
      return cands;
    };
    // keypoint -> (hamming, candidate) of the best claim. T_cw is the pose
    // the candidates are projected with; the candidates, moved by the same
    // correction (T_cw = kb.T_cw * D), are where the keyframe's own points
    // should be.
    using Claims = std::unordered_map<int, std::pair<int, int>>;
    const auto search_all = [&](const Place& b, const KeyframeSearch& search, const std::vector<Candidate>& cands,
                                double radius_px, const Se3& T_cw, bool check_depth) {
      const Submap& B = map->submap(b.submap);
      const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
      const SubmapIndex& idx_b = prep[size_t(b.submap)].idx;
      const Se3 D = kb.T_wc() * T_cw;
      Claims claims;
      for (size_t c = 0; c < cands.size(); ++c) {
        const Candidate& cd = cands[c];
        int hamming = 0;
        const int kp = search.Match(cd.X, cd.desc, cd.max_distance, radius_px, o.front_search_max_hamming,
                                    &hamming, &T_cw);
        if (kp < 0) continue;
        if (check_depth) {
          // The corner's own point must lie where the projected one does
          // (a descriptor match along the same ray at another depth is
          // not the same point).
          const int q = idx_b.Point(kb.point_ids[size_t(kp)]);
          if (q < 0) continue;
          const Eigen::Vector3d X = D * cd.X;
          const double depth = (kb.T_cw * X).norm();
          if ((B.points[size_t(q)].position - X).norm() > o.revisit_max_offset * depth) continue;
        }
        const auto it = claims.find(kp);
        if (it == claims.end() || hamming < it->second.first) claims[kp] = {hamming, int(c)};
      }
      return claims;
    };
    // The two passes are separate front submaps joined at one place; away
    // from it they drift apart by more than the search radius. As ORB-SLAM
    // corrects a loop before it fuses, the keyframe is first placed against
    // the earlier pass: a wide search from the guess, then PnP RANSAC.
    const auto place = [&](const Place& b, const KeyframeSearch& search, const std::vector<Candidate>& cands,
                           const Se3& guess, double radius_px, Se3* placed) {
      const Claims wide = search_all(b, search, cands, radius_px, guess, /*check_depth=*/false);
      if (int(wide.size()) < o.revisit_min_pnp_inliers) return false;
      const Keyframe& kb = map->submap(b.submap).keyframes[size_t(b.keyframe)];
      std::vector<cv::Point3f> obj;
      std::vector<cv::Point2f> img;
      for (const auto& [kp, claim] : wide) {
        const Eigen::Vector3d& X = cands[size_t(claim.second)].X;
        obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
        img.emplace_back(kb.keypoints[size_t(kp)].x(), kb.keypoints[size_t(kp)].y());
      }
      const CameraIntrinsics& K = map->submap(b.submap).camera;
      const cv::Mat Kcv = (cv::Mat_<double>(3, 3) << K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
      const Eigen::Matrix3d R0 = guess.rotation().toRotationMatrix();
      cv::Mat R0cv(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) R0cv.at<double>(r, c) = R0(r, c);
        tvec.at<double>(r) = guess.translation()(r);
      }
      cv::Rodrigues(R0cv, rvec);
      std::vector<int> inliers;
      // Keypoints are undistorted already: the pinhole K, no distortion.
      if (!cv::solvePnPRansac(obj, img, Kcv, cv::noArray(), rvec, tvec, /*useExtrinsicGuess=*/true, 100,
                              float(o.front_search_px), 0.99, inliers, cv::SOLVEPNP_ITERATIVE) ||
          int(inliers.size()) < o.revisit_min_pnp_inliers)
        return false;
      cv::Mat Rcv;
      cv::Rodrigues(rvec, Rcv);
      Eigen::Matrix3d R;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = Rcv.at<double>(r, c);
      const Se3 T_cw(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
      // A consensus on a wrong pose (repeated texture) moves the camera
      // far: a right correction stays within the depth check's tolerance
      // of the guess and turns the axis less than neighbours may differ.
      const Se3 g_wc = guess.Inverse(), p_wc = T_cw.Inverse();
      const double depth = b.depth / map->ToGlobal(b.submap).scale();
      if ((g_wc.translation() - p_wc.translation()).norm() > o.revisit_max_offset * depth ||
          (g_wc.rotation() * Eigen::Vector3d::UnitZ()).dot(p_wc.rotation() * Eigen::Vector3d::UnitZ()) < cos_max)
        return false;
      *placed = T_cw;
      return true;
    };

    // Per searched submap, its keyframes in order: a placed keyframe's
    // correction (D, with T_cw = kb.T_cw * D) is the next one's guess, so the
    // placement follows the drift along the pass instead of failing once it
    // exceeds the wide search (a looped walk: 210 of a pass's 332 keyframes
    // found < 10 wide matches from the merged pose). Forward, then backward
    // over what the forward sweep did not place.
    std::vector<uint64_t> pose_hash;  // of this component's fronts, once a memo needs them
    for (size_t first = 0; first < places.size();) {
      size_t last = first;
      while (last < places.size() && places[last].submap == places[first].submap) ++last;
      const int sb = places[first].submap;
      if (searched && !(*searched)[size_t(sb)]) {
        first = last;
        continue;
      }
      if (memo) {
        if (pose_hash.empty()) {
          pose_hash.assign(map->size(), 0);
          for (int m : fronts) pose_hash[size_t(m)] = KeyframePoseFingerprint(map->submap(m));
        }
        std::vector<int64_t> sig = Signature(*map, fronts, pose_hash, sb);
        RevisitMemo::Entry& e = memo->entries()[map->Key(sb)];
        if (e.signature == sig) {
          ++rep.submaps_replayed;
          for (const RevisitMemo::Link& l : e.links) {
            const int a = map->Find(l.kept);
            if (a < 0 || prep[size_t(sb)].idx.Point(l.point) < 0 || prep[size_t(a)].idx.Point(l.kept_point) < 0) continue;
            if (!present.insert({sb, l.point, a, l.kept_point}).second) continue;
            present.insert({a, l.kept_point, sb, l.point});
            map->fused().push_back({sb, l.point, a, l.kept_point});
            ++rep.fused;
          }
          first = last;
          continue;
        }
        e.signature = std::move(sig);
        e.links.clear();
      }
      const Submap& B = map->submap(sb);
      const Sim3& S_b = map->ToGlobal(sb);
      // Per keyframe, the earlier submaps its neighbours belong to, each
      // with its own placement: the earlier passes over one place are
      // themselves separate submaps, each drifted its own way, so a pose
      // placed against one of them projects another's points off (a looped
      // walk: a pass placed against the session's first submap for 208
      // keyframes found nothing where the 7th and 26th submaps' places came
      // next).
      struct Group {
        int a = -1;                               // earlier submap
        std::vector<std::pair<double, int>> near;  // its neighbour places
        Se3 pose;                                 // placed against a, else the merged pose
        bool placed = false;
      };
      std::vector<std::vector<Group>> groups(last - first);
      const auto near_of = [&](const Place& b, const Se3& T_cw) {
        const Se3 T_wc = T_cw.Inverse();
        return find_near(b, S_b * T_wc.translation(), S_b.R() * (T_wc.rotation() * Eigen::Vector3d::UnitZ()));
      };
      const auto sweep = [&](bool forward) {
        // The correction last found against each earlier submap (T_cw =
        // kb.T_cw * D), and the last one found: it is the next keyframe's
        // guess, so the placement follows the drift along the pass.
        std::map<int, Se3> d_of;
        int last_a = -1;
        for (size_t step = 0; step < last - first; ++step) {
          const size_t i = forward ? step : last - first - 1 - step;
          const Place& b = places[first + i];
          const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
          if (forward) {
            // Neighbours around the last correction's guess, else the merged pose.
            auto near = last_a >= 0 ? near_of(b, kb.T_cw * d_of.at(last_a)) : near_of(b, kb.T_cw);
            if (near.empty() && last_a >= 0) near = near_of(b, kb.T_cw);
            for (const auto& nj : near) {
              const int a = places[size_t(nj.second)].submap;
              auto it = std::find_if(groups[i].begin(), groups[i].end(), [&](const Group& g) { return g.a == a; });
              if (it == groups[i].end()) it = groups[i].insert(groups[i].end(), Group{a, {}, kb.T_cw, false});
              it->near.push_back(nj);
            }
          }
          for (Group& g : groups[i]) {
            if (g.placed) {
              d_of[g.a] = kb.T_wc() * g.pose;
              last_a = g.a;
              continue;
            }
            if (o.revisit_wide_px <= 0) continue;
            // Its own correction, else the last one found; then (forward
            // only) the merged pose: a front that relocalises in its own map
            // jumps to another part of its pass, where the last correction
            // is wrong.
            std::vector<Se3> guesses;
            const auto own = d_of.find(g.a);
            if (own != d_of.end())
              guesses.push_back(kb.T_cw * own->second);
            else if (last_a >= 0)
              guesses.push_back(kb.T_cw * d_of.at(last_a));
            if (forward) guesses.push_back(kb.T_cw);
            const KeyframeSearch search(kb, B.camera, /*mapped=*/true);
            const std::vector<Candidate> cands = candidates(b, g.near);
            // Last, a 3x wider search from the first guess: a pass never
            // placed against this one yet may be off by more.
            std::vector<std::pair<Se3, double>> tries;
            for (const Se3& guess : guesses) tries.push_back({guess, o.revisit_wide_px});
            if (!guesses.empty()) tries.push_back({guesses.front(), 3 * o.revisit_wide_px});
            for (const auto& [guess, radius_px] : tries) {
              Se3 T_cw;
              if (!place(b, search, cands, guess, radius_px, &T_cw)) continue;
              g.pose = T_cw;
              g.placed = true;
              d_of[g.a] = kb.T_wc() * T_cw;
              last_a = g.a;
              break;
            }
          }
        }
      };
      sweep(true);
      sweep(false);
      for (size_t i = 0; i < last - first; ++i) {
        if (groups[i].empty()) continue;
        ++rep.keyframes_searched;
        const Place& b = places[first + i];
        const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
        const KeyframeSearch search(kb, B.camera, /*mapped=*/true);
        bool any_placed = false;
        for (const Group& g : groups[i]) {
          any_placed |= g.placed;
          const std::vector<Candidate> cands = candidates(b, g.near);
          for (const auto& [kp, claim] : search_all(b, search, cands, o.front_search_px, g.pose, /*check_depth=*/true)) {
            const Candidate& cd = cands[size_t(claim.second)];
            ++votes[{b.submap, kb.point_ids[size_t(kp)], cd.submap}][cd.point_id];
          }
        }
        rep.keyframes_corrected += any_placed;
      }
      first = last;
    }
    for (const auto& [key, by_point] : votes) {
      const auto best = std::max_element(by_point.begin(), by_point.end(),
                                         [](const auto& x, const auto& y) { return x.second < y.second; });
      const auto [b, b_point, a] = key;
      if (memo) memo->entries()[map->Key(b)].links.push_back({b_point, map->Key(a), best->first});
      if (!present.insert({b, b_point, a, best->first}).second) continue;
      present.insert({a, best->first, b, b_point});
      map->fused().push_back({b, b_point, a, best->first});
      ++rep.fused;
    }
  }
  rep.seconds = SecondsSince(start);
  return rep;
}

}  // namespace rumi
