#include "front/frame_tracker.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "front/matcher.h"
#include "front/optimizer.h"

namespace rumi {

Se3 PredictWithVelocity(const Se3& last_T_cw, Timestamp last_t, Timestamp cur_t, const Se3& velocity,
                        double velocity_dt_s) {
  // Constant velocity in time: a short drop (up to 3 intervals) scales the
  // predicted motion; over longer gaps extrapolation is worse than one
  // interval's motion (seen on the synthetic `drop` sequence).
  Se3 v = velocity;
  const double dt = NsToSeconds(cur_t - last_t);
  if (velocity_dt_s > 0 && dt > 0 && std::abs(dt / velocity_dt_s - 1.0) > 0.2 && dt / velocity_dt_s <= 3.0)
    v = Se3::Exp(velocity.Log() * (dt / velocity_dt_s));
  return v * last_T_cw;
}

Se3 WithRotation(const Se3& predicted_T_cw, const Eigen::Quaterniond& R_cw) {
  const Eigen::Vector3d centre = -(predicted_T_cw.rotation().conjugate() * predicted_T_cw.translation());
  return Se3(R_cw, -(R_cw.normalized() * centre));
}

bool TrackWithMotionModel(TrackFrame* cur, const TrackFrame& last, const Se3& predicted_T_cw, double search_radius,
                          const PinholeCamera& cam, const ScalePyramid& pyr) {
  cur->T_cw = predicted_T_cw;
  cur->Reset(cur->f->size());
  int n = SearchByProjection(cur, last, cam, pyr, search_radius, true);
  if (n < 20) {
    cur->Reset(cur->f->size());
    n = SearchByProjection(cur, last, cam, pyr, 2 * search_radius, true);
  }
  if (n < 20) return false;
  return OptimizePose(cur, cam, pyr) >= 10;
}

bool TrackReferenceKeyFrame(TrackFrame* cur, const TrackFrame& last, const KeyFrame& ref, const Se3& start_T_cw,
                            const PinholeCamera& cam, const ScalePyramid& pyr) {
  cur->T_cw = start_T_cw;
  cur->Reset(cur->f->size());
  // Without a vocabulary: wide projection windows with a ratio test, from the
  // last position (the camera has not moved far when the motion model failed).
  int n = SearchKeyFramePoints(cur, ref, cam, pyr, 40.0, kDescHigh, 0.8);
  n += SearchByProjection(cur, last, cam, pyr, 40.0, true);
  if (n < 15) return false;
  return OptimizePose(cur, cam, pyr) >= 10;
}

int TrackLocalMap(TrackFrame* cur, Map* map, KeyFrame** ref, bool wide, const FrontOptions& o,
                  const PinholeCamera& cam, const ScalePyramid& pyr) {
  const int64_t tag = cur->id;
  // Keyframes sharing points with the frame, by votes.
  std::map<KeyFrame*, int, ById> votes;
  for (size_t i = 0; i < cur->points.size(); ++i) {
    Landmark* p = cur->points[i];
    if (!p || p->bad || cur->outlier[i]) continue;
    for (auto& [k, idx] : p->obs) if (!k->bad) ++votes[k];
  }
  std::vector<std::pair<int, KeyFrame*>> ranked;
  for (auto& [k, v] : votes) ranked.push_back({v, k});
  std::sort(ranked.begin(), ranked.end(), [](auto& a, auto& b) { return a.first > b.first || (a.first == b.first && a.second->id > b.second->id); });
  std::vector<KeyFrame*> local;
  auto add = [&](KeyFrame* k) {
    if (k->bad || k->local_for_frame == tag) return;
    if (static_cast<int>(local.size()) >= o.max_local_keyframes) return;
    k->local_for_frame = tag;
    local.push_back(k);
  };
  // The newest keyframes first: their young points are what keeps tracking
  // alive while the view changes (they have few votes yet).
  int newest = 0;
  for (auto it = map->keyframes.rbegin(); it != map->keyframes.rend() && newest < 8; ++it) {
    KeyFrame* k = it->second.get();
    if (k->bad || std::abs(NsToSeconds(cur->timestamp - k->timestamp)) >= o.short_term_s) continue;
    add(k);
    ++newest;
  }
  for (auto& [v, k] : ranked) add(k);
  // Short-term (|dt| < Th_t) and mid-term (|dp| < Th_p) subsets (paper 004, Formula 5).
  const Eigen::Vector3d centre = -(cur->T_cw.R().transpose() * cur->T_cw.translation());
  for (auto it = map->keyframes.rbegin(); it != map->keyframes.rend(); ++it) {
    KeyFrame* k = it->second.get();
    if (k->bad) continue;
    if (std::abs(NsToSeconds(cur->timestamp - k->timestamp)) < o.short_term_s ||
        (k->Centre() - centre).norm() < o.mid_term_dist)
      add(k);
  }
  const size_t first_level = local.size();
  for (size_t i = 0; i < first_level; ++i)
    for (KeyFrame* n : local[i]->BestCovisibles(10)) add(n);
  if (!ranked.empty()) *ref = ranked.front().second;

  // Local points not already matched.
  for (size_t i = 0; i < cur->points.size(); ++i) {
    Landmark* p = cur->points[i];
    if (!p) continue;
    if (p->bad) { cur->points[i] = nullptr; continue; }
    p->visible++;
    p->last_frame_seen = tag;
  }
  std::vector<Landmark*> pts;
  for (KeyFrame* k : local)
    for (Landmark* p : k->points)
      if (p && !p->bad && p->track_ref_frame != tag && p->last_frame_seen != tag) {
        p->track_ref_frame = tag;
        pts.push_back(p);
      }
  SearchLocalPoints(cur, pts, cam, pyr, o.local_search_radius * (wide ? 3.0 : 1.0));
  const int inliers = OptimizePose(cur, cam, pyr);
  for (size_t i = 0; i < cur->points.size(); ++i) {
    Landmark* p = cur->points[i];
    if (p && !cur->outlier[i]) p->found++;
  }
  return inliers;
}

}  // namespace rumi
