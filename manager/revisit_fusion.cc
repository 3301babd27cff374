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

}  // namespace

RevisitFusionReport FuseRevisitPoints(GlobalMap* map, const ManagerOptions& o, const std::vector<bool>* searched) {
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
  for (int root : map->ComponentsBySize()) {
    std::vector<int> fronts;
    for (int m : map->Members(root))
      if (map->submap(m).source == SubmapSource::kFront) fronts.push_back(m);
    if (fronts.size() < 2) continue;
    std::sort(fronts.begin(), fronts.end());
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
    std::vector<std::pair<double, int>> near;
    for (const Place& b : places) {
      if (searched && !(*searched)[size_t(b.submap)]) continue;
      near.clear();
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = cells.find(CellKey(b.centre + radius * Eigen::Vector3d(dx, dy, dz), radius));
            if (it == cells.end()) continue;
            for (int j : it->second) {
              const Place& a = places[size_t(j)];
              if (a.submap >= b.submap) continue;  // earlier submaps only: each pair once
              const double d = (a.centre - b.centre).norm();
              if (d < radius && a.axis.dot(b.axis) > cos_max) near.push_back({d, j});
            }
          }
      if (near.empty()) continue;
      // A cell may be listed twice when the grid wraps: keep each place once.
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      if (int(near.size()) > o.revisit_neighbours) near.resize(size_t(o.revisit_neighbours));
      ++rep.keyframes_searched;
      const Submap& B = map->submap(b.submap);
      const Keyframe& kb = B.keyframes[size_t(b.keyframe)];
      const KeyframeSearch search(kb, B.camera, /*mapped=*/true);
      const Prepared& pb = prep[size_t(b.submap)];
      ++search_stamp;
      // The earlier passes' points near this keyframe, in B's frame.
      struct Candidate {
        Eigen::Vector3d X;
        const uint8_t* desc;
        double max_distance;
        int submap;
        int64_t point_id;
      };
      std::vector<Candidate> cands;
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
      // keypoint -> (hamming, candidate) of the best claim
      using Claims = std::unordered_map<int, std::pair<int, int>>;
      const auto search_all = [&](double radius_px, const Se3& T_cw, bool check_depth) {
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
            const int q = pb.idx.Point(kb.point_ids[size_t(kp)]);
            if (q < 0) continue;
            const double depth = (kb.T_cw * cd.X).norm();
            if ((B.points[size_t(q)].position - cd.X).norm() > o.revisit_max_offset * depth) continue;
          }
          const auto it = claims.find(kp);
          if (it == claims.end() || hamming < it->second.first) claims[kp] = {hamming, int(c)};
        }
        return claims;
      };
      // The two passes are separate front submaps joined at one place; away
      // from it they drift apart by more than the search radius. As ORB-SLAM
      // corrects a loop before it fuses, the keyframe is first placed against
      // the earlier pass: a wide search, then PnP RANSAC from the merged pose.
      Se3 T_cw = kb.T_cw;
      if (o.revisit_wide_px > 0) {
        const Claims wide = search_all(o.revisit_wide_px, kb.T_cw, /*check_depth=*/false);
        if (int(wide.size()) >= o.revisit_min_pnp_inliers) {
          std::vector<cv::Point3f> obj;
          std::vector<cv::Point2f> img;
          for (const auto& [kp, claim] : wide) {
            const Eigen::Vector3d& X = cands[size_t(claim.second)].X;
            obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
            img.emplace_back(kb.keypoints[size_t(kp)].x(), kb.keypoints[size_t(kp)].y());
          }
          const CameraIntrinsics& K = B.camera;
          const cv::Mat Kcv = (cv::Mat_<double>(3, 3) << K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
          const Eigen::Matrix3d R0 = kb.T_cw.rotation().toRotationMatrix();
          cv::Mat R0cv(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
          for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) R0cv.at<double>(r, c) = R0(r, c);
            tvec.at<double>(r) = kb.T_cw.translation()(r);
          }
          cv::Rodrigues(R0cv, rvec);
          std::vector<int> inliers;
          // Keypoints are undistorted already: the pinhole K, no distortion.
          if (cv::solvePnPRansac(obj, img, Kcv, cv::noArray(), rvec, tvec, /*useExtrinsicGuess=*/true, 100,
                                 float(o.front_search_px), 0.99, inliers, cv::SOLVEPNP_ITERATIVE) &&
              int(inliers.size()) >= o.revisit_min_pnp_inliers) {
            cv::Mat Rcv;
            cv::Rodrigues(rvec, Rcv);
            Eigen::Matrix3d R;
            for (int r = 0; r < 3; ++r)
              for (int c = 0; c < 3; ++c) R(r, c) = Rcv.at<double>(r, c);
            T_cw = Se3(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
            ++rep.keyframes_corrected;
          }
        }
      }
      Claims final_claims = search_all(o.front_search_px, T_cw, /*check_depth=*/true);
      std::unordered_map<int, std::tuple<int, int, int64_t>> claims;
      for (const auto& [kp, claim] : final_claims) {
        const Candidate& cd = cands[size_t(claim.second)];
        claims[kp] = {claim.first, cd.submap, cd.point_id};
      }
      for (const auto& [kp, claim] : claims)
        ++votes[{b.submap, kb.point_ids[size_t(kp)], std::get<1>(claim)}][std::get<2>(claim)];
    }
    for (const auto& [key, by_point] : votes) {
      const auto best = std::max_element(by_point.begin(), by_point.end(),
                                         [](const auto& x, const auto& y) { return x.second < y.second; });
      const auto [b, b_point, a] = key;
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
