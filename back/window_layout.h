#pragma once
// Where a window's frames stand before COLMAP runs: the blank ones (a
// covered lens, back/blank_cut.h), which COLMAP never gets; the blank
// stretches, where models are cut and no image pair crosses; and the parts
// whose coverage the attempt policy judges one by one (attempt_policy.h).
#include <utility>
#include <vector>

#include "back/back_options.h"
#include "common/timestamp.h"
#include "common/window.h"

namespace rumi {

struct WindowLayout {
  std::vector<bool> blank;  // per frame; none when back.blank_max_stddev is 0
  int num_blank = 0;
  std::vector<std::pair<Timestamp, Timestamp>> stretches;  // (first, last) blank frame, time order
  std::vector<int> side;  // per frame: how many stretches end before it
  // Part k holds the frames from part_bounds[k - 1] up to (not including)
  // part_bounds[k]: one part per window the queue joined into this one
  // (window.joined_at), as each loss gives COLMAP its own model, and one per
  // side of a blank stretch, where models are cut anyway. Sorted.
  std::vector<Timestamp> part_bounds;
};

WindowLayout LayOutWindow(const ImageWindow& window, const BackOptions& options);

}  // namespace rumi
