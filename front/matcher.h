#pragma once
// Descriptor matching guided by geometry (projection windows, epipolar
// segments); no vocabulary is used.
#include <Eigen/Core>
#include <utility>
#include <vector>

#include "front/map.h"

namespace rumi {

constexpr int kDescHigh = 100;  // accept threshold for tracking matches
constexpr int kDescLow = 50;    // strict threshold (initialisation, new points)

// Projects the last frame's tracked points into cur (pose cur.T_cw) and
// matches within radius * scale(level). Returns the number of new matches.
int SearchByProjection(TrackFrame* cur, const TrackFrame& last, const PinholeCamera& cam, const ScalePyramid& pyr,
                       double radius, bool check_rotation);

// Projects candidate points (frustum, scale and viewing-angle checks) and
// matches them with a ratio test. Counts visibility for culling statistics.
int SearchLocalPoints(TrackFrame* cur, const std::vector<Landmark*>& points,
                      const PinholeCamera& cam, const ScalePyramid& pyr, double radius);

// Projects keyframe points with a descriptor ratio test (relocalisation /
// reference fallback); skips points already matched.
int SearchKeyFramePoints(TrackFrame* cur, const KeyFrame& kf, const PinholeCamera& cam, const ScalePyramid& pyr,
                         double radius, int max_desc, double ratio);

// Two-view initialisation matching: f1's features searched around
// prev_matched (updated in place) in f2. m12[i] = index in f2 or -1.
int SearchForInitialization(const Features& f1, const Features& f2,
                            std::vector<Eigen::Vector2d>* prev_matched, double radius,
                            std::vector<int>* m12);

// Matches unmapped features of two keyframes along epipolar segments.
std::vector<std::pair<int, int>> SearchForTriangulation(const KeyFrame& k1, const KeyFrame& k2,
                                                        const PinholeCamera& cam, const ScalePyramid& pyr);

// Projects points into kf and merges duplicates / adds observations.
// Returns the number of fused points.
int Fuse(KeyFrame* kf, const std::vector<Landmark*>& points, const PinholeCamera& cam, const ScalePyramid& pyr, double radius);

}  // namespace rumi
