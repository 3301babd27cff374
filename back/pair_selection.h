#pragma once
// Which image pairs of a window COLMAP matches, instead of all of them
// (exhaustive matching is n(n-1)/2 pairs: 4,950 for 100 frames, 80-90 % of a
// window's time). A window is S1 (sparse, tracked before the loss), S2 (every
// frame of the lost stretch) and S3 (sparse, after recovery), in time order.
// The pairs keep what registration needs:
//   - temporal neighbours: frames at most `overlap` apart in the window;
//   - the lost stretch denser: S2 frames at most `lost_overlap` apart;
//   - bridges: the `bridge_frames` tracked frames on each side of the lost
//     stretch with every S2 frame (the merge pairs them with front keyframes);
//   - long range: frames 2^k apart (COLMAP's quadratic overlap), so a scene
//     seen again later in the window is still matched.
#include <utility>
#include <vector>

#include "common/option_spec.h"
#include "common/window.h"

namespace rumi {

struct PairSelectionOptions {
  int overlap = 8;
  int lost_overlap = 16;
  int bridge_frames = 3;
  bool quadratic = true;

  static const OptionSpec<PairSelectionOptions>& Spec();  // `back: {pairs: ...}`
};

// Index pairs (i < j) into a window of frames with these sets (time order),
// sorted, each once.
std::vector<std::pair<int, int>> SelectImagePairs(const std::vector<SampleSet>& sets,
                                                  const PairSelectionOptions& options);

}  // namespace rumi
