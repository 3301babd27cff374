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

// What a frame shows once sensor noise is averaged down: the grey levels of
// its 8 x 8 pixel block means, in floating point (8-bit block means round a
// near-black scene's 1-2 levels of content, and a plain wall's shading, away
// to nothing).
struct BlankMeasure {
  double stddev = 0;     // standard deviation of the block means
  double structure = 0;  // their correlation with the next block (across and down):
                         // ~0 for noise, towards 1 for anything imaged
};
BlankMeasure MeasureBlank(const cv::Mat& image);

// An image that shows nothing but noise: its block means are flat (stddev
// at most max_stddev) and uncorrelated (structure at most max_structure).
// A covered generated camera: stddev 0.08, structure within +-0.03, also
// with 3-8x the read noise and through JPEG at quality 20-95; the demo's
// near-black `dark` frames (2 % exposure): stddev 0.6-0.8, structure
// 0.80-0.89 (0.66-0.79 through JPEG at 50-95, 0.41-0.60 with 3x the noise):
// the camera still sees them, and COLMAP registers them. What this cannot
// tell from noise: a flat frame whose only content is finer than the blocks
// (a fine random texture at 1 % exposure, a checkerboard of 4-pixel squares
// that fills every block alike), or one that JPEG at 20 or 8x the noise left
// at 0.14-0.21. docs/results/2026-11-29-blank-structure.md.
bool IsBlankImage(const cv::Mat& image, double max_stddev, double max_structure);

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
