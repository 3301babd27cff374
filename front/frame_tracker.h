#pragma once
// Per-frame tracking steps of the front (the caller holds the map mutex):
// the constant-velocity motion model, the reference-keyframe fallback, and
// the local map (covisible keyframes' points projected and refined).
#include "common/camera.h"
#include "front/front_options.h"
#include "front/map.h"

namespace rumi {

// cur.T_cw predicted from last with the per-frame velocity (measured over
// velocity_dt_s), matches by projection, pose refined. False when too few.
bool TrackWithMotionModel(TrackFrame* cur, const TrackFrame& last, const Se3& velocity, double velocity_dt_s,
                          double search_radius, const PinholeCamera& cam, const ScalePyramid& pyr);

// From last's pose: the reference keyframe's points and last's, in wide
// windows with a ratio test (no vocabulary). False when too few.
bool TrackReferenceKeyFrame(TrackFrame* cur, const TrackFrame& last, const KeyFrame& ref, const PinholeCamera& cam,
                            const ScalePyramid& pyr);

// The local map: the newest keyframes, those voting for cur's matches, the
// short- and mid-term subsets (paper 004, Formula 5) and their covisibles;
// their points matched by projection, the pose refined. *ref becomes the
// keyframe sharing most points. wide: just (re)initialised or relocalised
// (3x search windows). Returns the inliers.
int TrackLocalMap(TrackFrame* cur, Map* map, KeyFrame** ref, bool wide, const FrontOptions& o,
                  const PinholeCamera& cam, const ScalePyramid& pyr);

}  // namespace rumi
