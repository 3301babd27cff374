#pragma once
// The decisions of the back's attempt policy on what COLMAP gave
// (colmap_runner.h): whether an attempt leaves part of the window short of
// frames, which frames it left out and why, and the cut of the models at
// blank stretches, each side kept from its best attempt. BackSubmapBuilder
// runs the attempts (first, fill, retry) in the order these decide.
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "back/colmap_runner.h"
#include "back/window_layout.h"
#include "common/window.h"

namespace rumi {

// Whether a part of the window (layout.part_bounds) misses too many frames:
// the model holding most of that part's frames (blank ones aside) holds
// fewer than `below` x them. A window that is one part: its largest model.
bool ShortOfFrames(const ImageWindow& window, const WindowLayout& layout, const ColmapAttempt& attempt, double below);

// The COLMAP names of the frames (not blank) that `attempt` left out, and of
// those at most `margin` frames from one of them. Left out: not in the
// model that holds most of the frame's part (ShortOfFrames' parts), so a
// smaller model the part also split into counts as left out (generated
// weak seed 3: 88 + 22 frames in two models and 8 in none; the retry of
// the 8 alone gave 88 + 22 again, a full one 110 in one model).
std::vector<std::string> LeftOutFrames(const ImageWindow& window, const WindowLayout& layout,
                                       const ColmapAttempt& attempt, int margin);

// Why frames were left out: `poor` have fewer than min_features SIFT
// keypoints (or no row), `unlinked` (the others) no verified pair with a
// frame that was not left out.
struct LeftOutCauses {
  int poor = 0;
  int unlinked = 0;
};
LeftOutCauses ClassifyLeftOut(const std::vector<std::string>& missing,
                              const std::unordered_map<std::string, int>& features,
                              const std::vector<std::pair<std::string, std::string>>& verified, int min_features);

// Whether the retry at the lower SIFT threshold goes before the fill: when
// at least a quarter of the `missing` frames are poor or unlinked. No pair
// makes up for missing features, and the textured frames beyond a plain
// wall stay unlinked too; features that do not match seldom match with
// more pairs (a generated corridor window: 16 of the 33 frames in no model
// had under 100 features; the fill added 1, the retry all 73. A
// weak-texture window: 5 of 12 with no verified pair to the model; fill
// then retry 247-352 CPU s, the retry alone 134-142. Blur and drop windows:
// every frame left out had 23-222 inliers to the model, and the fill
// registered them).
bool RetryGoesFirst(const LeftOutCauses& causes, size_t missing);

// Every model cut at the blank stretches (CutAtStretches), its statistics
// recounted per piece; `warnings` (may be null) gets a line per model cut.
std::vector<BuiltModel> CutModels(std::vector<BuiltModel> built,
                                  const std::vector<std::pair<Timestamp, Timestamp>>& stretches, int min_keyframes,
                                  int min_point_observations, std::vector<std::string>* warnings);

// With blank stretches: every attempt's models cut (the adopted one's cuts
// said in `warnings`), and each side of a stretch takes its models from the
// attempt that registered most of it, the earliest on a tie (the adopted
// one when none did; a warning says when another). A fill or a retry
// that joined the two places (through a poster on two walls) bent the side
// it shared with the first attempt: generated `kidnap` seed 5, the same 38
// frames at 0.0026 m in the first attempt, 0.0118 m after the fill's model
// was cut. `tried`: every attempt that built, in order, the adopted one
// among them (by name). Replaces adopted->built by the models kept, largest
// first.
void KeepBestSides(std::vector<ColmapAttempt> tried, const std::vector<std::pair<Timestamp, Timestamp>>& stretches,
                   int min_keyframes, int min_point_observations, ColmapAttempt* adopted,
                   std::vector<std::string>* warnings);

}  // namespace rumi
