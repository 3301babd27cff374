#pragma once
// A camera that sees nothing (a covered lens, a blackout) sees no motion:
// meanwhile the robot may have been carried anywhere (generated `kidnap`).
// COLMAP still joins the frames before and after such a stretch when their
// images look alike, by appearance alone, and a repeated pattern joined two
// places: `kidnap` seed 3's window (a checkerboard poster on two walls) came
// back as one model holding both sides, each front merged with its own
// side, and the merged ATE was 0.46 m against the front's 0.006 m. So the
// back does not vouch for a link across a blank stretch: a model is cut
// there, and the two sides meet again only through the manager's place
// merge, which checks the place with its stricter thresholds.
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "common/submap.h"
#include "common/timestamp.h"

namespace rumi {

// An image that shows nothing but noise: the grey-level standard deviation
// of its 4 x 4 pixel block means is at most max_stddev. A covered generated
// camera: 0.16; the darkest frames of generated `dark` seeds: 1.95 and up.
bool IsBlankImage(const cv::Mat& image, double max_stddev);

// Runs of at least min_frames consecutive blank frames (frames in time
// order), as (first, last) timestamps.
std::vector<std::pair<Timestamp, Timestamp>> BlankStretches(const std::vector<Timestamp>& timestamps,
                                                            const std::vector<bool>& blank, int min_frames);

// Cuts `s` at every stretch that has keyframes on both sides: one piece per
// side, in time order, each keeping its keyframes and the observations they
// make; points left with fewer than min_point_observations observations are
// dropped, and pieces with fewer than min_keyframes keyframes. A submap no
// stretch cuts comes back whole.
std::vector<Submap> CutAtStretches(const Submap& s, const std::vector<std::pair<Timestamp, Timestamp>>& stretches,
                                   int min_keyframes, int min_point_observations);

}  // namespace rumi
