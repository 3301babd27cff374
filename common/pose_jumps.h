#pragma once
// COLMAP can register a frame of a texture-poor stretch with a pose far from
// the path (generated `corridor` seed 5, 2026-11-28: one frame of a 109-frame
// model 70 scene units off while its neighbours 1/30 s away were 0.1 apart).
// The model is otherwise right, so every merge check at the junction passes,
// and the map then holds that frame metres away (merged ATE 0.67 m against
// the front's 0.012 m). A camera does not teleport between two frames: a
// keyframe whose centre neither time neighbour can reach, while those two
// agree with each other, is left out of the back submap.
#include <cstddef>
#include <vector>

#include "common/submap.h"

namespace rumi {

// Indices (into s.keyframes, which are in time order) of isolated pose jumps.
// Reach from a to b: max_ratio x max(median speed x |t_a - t_b|, median step),
// the medians over consecutive keyframes, without the two steps that touch
// the keyframe tested. Keyframe i is a jump when it is
// out of reach of both neighbours and they are within reach of each other;
// the first (last) one when it is out of reach of the next two (previous
// two), which are within reach of each other. Needs 3 keyframes; max_ratio
// <= 0 finds none.
std::vector<size_t> PoseJumps(const Submap& s, double max_ratio);

// Removes the keyframes with these indices, their observations, and the
// points left without one. Returns the number removed.
int DropKeyframesAt(Submap* s, const std::vector<size_t>& indices);

}  // namespace rumi
