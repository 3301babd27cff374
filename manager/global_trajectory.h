#pragma once
// Every input frame's pose in the global frame of one component: front-
// tracked frames through their submap's Sim(3) (keyframe pose when the frame
// is a keyframe, else its FrameRecord pose in the submap frame), frames the
// front lost through the back submap's keyframe (or culled keyframe record)
// with the same timestamp. Output: TUM text, camera -> world.
#include <string>
#include <vector>

#include "common/trajectory.h"
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

// The poses as a Trajectory, for the one TUM writer (common/trajectory.h).
Trajectory ToTrajectory(const std::vector<GlobalPose>& poses);

}  // namespace rumi
