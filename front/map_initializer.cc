#include "front/map_initializer.h"

#include <spdlog/spdlog.h>

#include "front/matcher.h"
#include "front/optimizer.h"

namespace rumi {

void MapInitializer::SetReference(const TrackFrame& cur) {
  ref_.reset();
  if (static_cast<int>(cur.f->size()) < o_.init_min_matches) return;
  ref_ = cur.f;
  ref_t_ = cur.timestamp;
  ref_frame_ = cur.id;
  prev_matched_ = cur.f->un;
}

bool MapInitializer::Match(const TrackFrame& cur, bool reinit, const PinholeCamera& cam) {
  const Features& f = *cur.f;
  if (!ref_ || cur.id - ref_frame_ > o_.init_max_frames) {
    SetReference(cur);
    return false;
  }
  std::vector<int> m12;
  const int n = SearchForInitialization(*ref_, f, &prev_matched_, o_.init_search_radius_frac * f.width, &m12);
  if (n < o_.init_min_matches) {
    SetReference(cur);
    return false;
  }
  std::vector<Eigen::Vector2d> p1, p2;
  matches_.clear();
  for (size_t i = 0; i < m12.size(); ++i) {
    if (m12[i] < 0) continue;
    p1.push_back(ref_->un[i]);
    p2.push_back(f.un[m12[i]]);
    matches_.push_back({static_cast<int>(i), m12[i]});
  }
  TwoViewOptions tvo;
  tvo.min_triangulated = MinPoints(reinit);
  tvo.min_parallax_deg = reinit ? o_.reinit_min_parallax_deg : o_.init_min_parallax_deg;
  // The pinhole K: keypoints are undistorted already.
  two_view_ = TwoViewResult();  // nothing of an earlier attempt survives
  const bool ok = ReconstructTwoView(p1, p2, PinholeMatrix(cam), tvo, &two_view_);
  if (!ok)
    spdlog::debug("front: two-view frames {}-{} rejected: {} ({} matches, {} {} good, parallax {:.2f} deg, RH {:.2f})",
                  ref_frame_, cur.id, two_view_.rejected, n, two_view_.model, two_view_.num_triangulated,
                  two_view_.parallax_deg, two_view_.score_ratio);
  return ok;
}

bool MapInitializer::Build(const TrackFrame& cur, bool reinit, Map* map, const PinholeCamera& cam,
                           const ScalePyramid& pyr, InitialMap* out) {
  KeyFrame* kf0 = map->NewKeyFrame(ref_t_, ref_frame_, ref_, Se3());
  kf0->fixed = true;  // the gauge
  KeyFrame* kf1 = map->NewKeyFrame(cur.timestamp, cur.id, cur.f, two_view_.T_21);
  for (size_t m = 0; m < matches_.size(); ++m) {
    if (!two_view_.triangulated[m]) continue;
    Landmark* p = map->NewPoint(two_view_.points[m], kf0);
    Map::AddObservation(p, kf0, matches_[m].first);
    Map::AddObservation(p, kf1, matches_[m].second);
    Map::ComputeDescriptor(p);
    Map::UpdateNormalAndDepth(p, pyr);
  }
  Map::UpdateConnections(kf0);
  Map::UpdateConnections(kf1);
  GlobalBa(map, cam, pyr, 20);
  const double median = kf0->MedianDepth();
  const int tracked = kf1->TrackedPoints(1);
  if (!(median > 0) || tracked < MinPoints(reinit)) {
    spdlog::debug("front: initial map rejected (median depth {}, {} points)", median, tracked);
    for (auto& [id, p] : map->points) Map::SetBad(p.get());
    map->keyframes.clear();
    map->points.clear();
    ref_.reset();
    return false;
  }
  // Scale: median scene depth of the first keyframe = 1.
  const double s = 1.0 / median;
  kf1->T_cw.translation() *= s;
  for (auto& [id, p] : map->points) {
    p->pos *= s;
    Map::UpdateNormalAndDepth(p.get(), pyr);
  }
  out->kf0 = kf0;
  out->kf1 = kf1;
  out->tracked = tracked;
  out->gap = std::max<int64_t>(1, cur.id - ref_frame_);
  out->two_view = two_view_;
  return true;
}

}  // namespace rumi
