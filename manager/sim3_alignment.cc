#include "manager/sim3_alignment.h"

#include <algorithm>
#include <random>

#include "common/logging.h"
#include "manager/submap_index.h"

namespace rumi {
namespace {

int CountInliers(const Sim3& S, const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                 double threshold, std::vector<char>* mask) {
  int n = 0;
  if (mask) mask->assign(src.size(), 0);
  const double t2 = threshold * threshold;
  for (size_t i = 0; i < src.size(); ++i) {
    if ((dst[i] - S * src[i]).squaredNorm() < t2) {
      ++n;
      if (mask) (*mask)[i] = 1;
    }
  }
  return n;
}

}  // namespace

double SceneRadius(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : points) c += p;
  c /= double(points.size());
  std::vector<double> d;
  d.reserve(points.size());
  for (const auto& p : points) d.push_back((p - c).norm());
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

RansacSim3Result RansacSim3(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                            double threshold, int iterations, uint32_t seed) {
  RansacSim3Result best;
  const int n = int(src.size());
  if (n < 3 || int(dst.size()) != n) return best;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<Eigen::Vector3d> s(3), d(3);
  for (int it = 0; it < iterations; ++it) {
    int i0 = pick(rng), i1 = pick(rng), i2 = pick(rng);
    if (i0 == i1 || i0 == i2 || i1 == i2) continue;
    s = {src[i0], src[i1], src[i2]};
    d = {dst[i0], dst[i1], dst[i2]};
    const UmeyamaResult u = UmeyamaAlign(s, d, true);
    if (!u.ok || !(u.transform.scale() > 0)) continue;
    const int k = CountInliers(u.transform, src, dst, threshold, nullptr);
    if (k > best.num_inliers) {
      best.num_inliers = k;
      best.transform = u.transform;
      best.ok = true;
    }
  }
  if (!best.ok) return best;
  CountInliers(best.transform, src, dst, threshold, &best.inliers);
  // Refit on the inliers; keep the refit only when it does not lose support.
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector3d> is, id;
    for (int i = 0; i < n; ++i) {
      if (best.inliers[i]) {
        is.push_back(src[i]);
        id.push_back(dst[i]);
      }
    }
    const UmeyamaResult u = UmeyamaAlign(is, id, true);
    if (!u.ok) break;
    std::vector<char> mask;
    const int k = CountInliers(u.transform, src, dst, threshold, &mask);
    if (k < best.num_inliers) break;
    best.transform = u.transform;
    best.num_inliers = k;
    best.inliers = std::move(mask);
  }
  return best;
}

AlignmentResult AlignSubmaps(const Submap& front, const Submap& back, const std::vector<KeyframePair>& pairs,
                             const CommonPoints& common, const ManagerOptions& options,
                             const std::vector<FramePair>& frame_pairs) {
  AlignmentResult r;
  r.num_keyframe_pairs = int(pairs.size() + frame_pairs.size());
  if (r.num_keyframe_pairs < options.min_keyframe_pairs) {
    r.reason = "too few keyframe pairs (" + std::to_string(r.num_keyframe_pairs) + " < " +
               std::to_string(options.min_keyframe_pairs) + ")";
    return r;
  }
  const SubmapIndex fi(front), bi(back);
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<int> match_of;  // correspondence -> index in common.matches
  for (size_t m = 0; m < common.matches.size(); ++m) {
    const int f = fi.Point(common.matches[m].front_point_id);
    const int b = bi.Point(common.matches[m].back_point_id);
    if (f < 0 || b < 0) continue;
    src.push_back(front.points[f].position);
    dst.push_back(back.points[b].position);
    match_of.push_back(int(m));
  }
  r.num_point_matches = int(src.size());
  if (r.num_point_matches < options.min_common_points) {
    r.reason = "too few common points (" + std::to_string(src.size()) + " < " +
               std::to_string(options.min_common_points) + ")";
    return r;
  }
  r.inlier_threshold = options.ransac_threshold_ratio * SceneRadius(dst);
  if (!(r.inlier_threshold > 0)) {
    r.reason = "degenerate back scene (all common points coincide)";
    return r;
  }
  const double n = double(src.size());

  // Candidate 1: keyframe centres (needs 3 non-collinear pairs).
  Sim3 best;
  bool have = false;
  if (pairs.size() + frame_pairs.size() >= 3) {
    std::vector<Eigen::Vector3d> cf, cb;
    for (const KeyframePair& p : pairs) {
      cf.push_back(front.keyframes[p.front_keyframe].T_wc().translation());
      cb.push_back(back.keyframes[p.back_keyframe].T_wc().translation());
    }
    for (const FramePair& p : frame_pairs) {
      cf.push_back(front.frames[p.front_frame].T_wc.translation());
      cb.push_back(back.keyframes[p.back_keyframe].T_wc().translation());
    }
    const UmeyamaResult u = UmeyamaAlign(cf, cb, true);
    if (u.ok && u.transform.scale() > 0) {
      r.umeyama_inlier_ratio = CountInliers(u.transform, src, dst, r.inlier_threshold, nullptr) / n;
      best = u.transform;
      have = true;
      r.method = "umeyama-keyframes";
      r.inlier_ratio = r.umeyama_inlier_ratio;
    }
  }
  // Candidate 2: RANSAC over the common points.
  const RansacSim3Result rs =
      RansacSim3(src, dst, r.inlier_threshold, options.ransac_iterations, options.ransac_seed);
  if (rs.ok) {
    r.ransac_inlier_ratio = rs.num_inliers / n;
    if (!have || r.ransac_inlier_ratio > r.inlier_ratio) {
      best = rs.transform;
      have = true;
      r.method = "ransac-points";
      r.inlier_ratio = r.ransac_inlier_ratio;
    }
  }
  if (!have) {
    r.reason = "no Sim(3) candidate (degenerate keyframe centres and point samples)";
    return r;
  }
  std::vector<char> mask;
  r.num_inliers = CountInliers(best, src, dst, r.inlier_threshold, &mask);
  r.inlier_ratio = r.num_inliers / n;
  r.S_bf = best;
  r.inliers.assign(common.matches.size(), 0);
  for (size_t i = 0; i < mask.size(); ++i) r.inliers[match_of[i]] = mask[i];
  if (r.inlier_ratio <= options.min_inlier_ratio) {
    r.reason = "inlier ratio " + std::to_string(r.inlier_ratio) + " <= " + std::to_string(options.min_inlier_ratio);
    return r;
  }
  if (r.num_inliers < options.min_common_points) {
    r.reason = "too few inliers (" + std::to_string(r.num_inliers) + " < " +
               std::to_string(options.min_common_points) + ")";
    return r;
  }
  r.ok = true;
  return r;
}

}  // namespace rumi
