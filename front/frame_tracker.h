#pragma once
// Per-frame tracking steps of the front (the caller holds the map mutex):
// the motion model (constant velocity, the gyro's rotation when there is one), the reference-keyframe fallback, and
// the local map (covisible keyframes' points projected and refined).
#include "common/camera.h"
#include "front/front_options.h"
#include "front/map.h"

namespace rumi {

// The constant-velocity prediction of the pose at cur_t from last's, the
// per-frame velocity measured over velocity_dt_s.
Se3 PredictWithVelocity(const Se3& last_T_cw, Timestamp last_t, Timestamp cur_t, const Se3& velocity,
                        double velocity_dt_s);
// A predicted pose with its rotation replaced by a measured one (the gyro's),
// the camera centre kept.
Se3 WithRotation(const Se3& predicted_T_cw, const Eigen::Quaterniond& R_cw);

// From the predicted cur.T_cw: last's points matched by projection, the pose
// refined. False when too few.
bool TrackWithMotionModel(TrackFrame* cur, const TrackFrame& last, const Se3& predicted_T_cw,
                          double search_radius, const PinholeCamera& cam, const ScalePyramid& pyr);

// From start_T_cw (last's pose, turned by the gyro when there is one): the
// reference keyframe's points and last's, in wide windows with a ratio test
// (no vocabulary). False when too few.
bool TrackReferenceKeyFrame(TrackFrame* cur, const TrackFrame& last, const KeyFrame& ref, const Se3& start_T_cw,
                            const PinholeCamera& cam, const ScalePyramid& pyr);

// The local map: the newest keyframes, those voting for cur's matches, the
// short- and mid-term subsets (paper 004, Formula 5) and their covisibles;
// their points matched by projection, the pose refined. *ref becomes the
// keyframe sharing most points. wide: just (re)initialised or relocalised
// (3x search windows). Returns the inliers.
int TrackLocalMap(TrackFrame* cur, Map* map, KeyFrame** ref, bool wide, const FrontOptions& o,
                  const PinholeCamera& cam, const ScalePyramid& pyr);

}  // namespace rumi
