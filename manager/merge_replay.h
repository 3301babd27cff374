#pragma once
// rumi-merge-replay (apps/merge_replay_main.cc): the manager's merge re-run
// offline on a saved map (e.g. <out>/map.rumi.raw, every submap as
// received), for diagnosing the merges of a real run without the three
// processes. Prints one line per merge attempt and loop, the merge audit
// against a ground truth, the post-culling, and writes the largest
// component's trajectory (TUM) like merged.txt. The live session replayed
// instead: manager/session_replay.h.
#include <string>

#include "manager/global_map.h"
#include "manager/manager_options.h"

namespace rumi {

// The raw submaps of `path` (LoadRawSubmaps), less the back keyframes
// registered off the camera path when jump_ratio > 0 (PoseJumps: what
// back.pose_jump_ratio does), each said on stdout when print. False with
// *why "cannot load PATH: ...".
bool LoadReplayMap(const std::string& path, double jump_ratio, bool print, GlobalMap* map, std::string* why);

struct MergeReplayOptions {
  ManagerOptions manager;
  std::string map_path;              // the map replayed, reloaded raw for the audit
  double back_pose_jump_ratio = 0;   // what LoadReplayMap dropped (the audit drops it too)
  double complete_back_px = 0;       // first complete the back submaps' tracks at this radius (0: off)
  int min_back_observations = 0;     // first drop back points seen by fewer keyframes (0: off)
  int loop_rounds = 1000;            // loop closure rounds at most, each as one rebuild would close them
  std::string groundtruth_path;      // TUM: print the merge and loop audits (merge_audit.h, loop_audit.h); "": none
  bool post_culling = true;          // redundant-keyframe culling
  std::string trajectory_path;       // the largest component's trajectory (TUM); "": not written
};

// Replays the merge on *map, printing as it goes. False with *why when the
// ground truth, the map (reloaded) or the trajectory cannot be read or written.
bool ReplayMerges(GlobalMap* map, const MergeReplayOptions& o, std::string* why);

}  // namespace rumi
