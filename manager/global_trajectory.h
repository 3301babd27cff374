#pragma once
// Every input frame's pose in the global frame of one component: front-
// tracked frames through their submap's Sim(3) (keyframe pose when the frame
// is a keyframe, else its FrameRecord pose in the submap frame), frames the
// front lost through the back submap's keyframe (or culled keyframe record)
// with the same timestamp. Output: TUM text, camera -> world.
#include <string>
#include <vector>

#include "manager/global_map.h"

namespace rumi {

struct GlobalPose {
  Timestamp timestamp = 0;
  Se3 T_wc;  // camera -> global
  int submap = -1;  // map index it came from
  bool from_back = false;
};

// component: a GlobalMap::Component root, -1 = the largest component.
// Timestamps within max_dt_ns of each other are one frame.
std::vector<GlobalPose> ComputeGlobalTrajectory(const GlobalMap& map, int component = -1,
                                                int64_t max_dt_ns = 100000);

// TUM: "t tx ty tz qx qy qz qw" with t in seconds (9 decimals, exact).
bool WriteTumTrajectory(const std::string& path, const std::vector<GlobalPose>& poses, std::string* why);

}  // namespace rumi
