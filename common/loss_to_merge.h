#pragma once
// The back's headline figure: for every tracking loss, the wall time from the
// moment the front lost track to the moment the lost frames are part of the
// map (a back submap holding one of them is in one component with a front
// submap). Computed by `rumi eval run` from front_frames.txt (wall_s column),
// back/back_stats.json (which keyframes each back submap holds) and
// manager_stats.json (when each back submap joined). Keys: docs/eval.md.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/run_metrics.h"
#include "common/timestamp.h"

namespace rumi {

// (LossToMerge, one loss, is in common/run_metrics.h: metrics.json holds them.)

// One back submap: the timestamps of its keyframes and when it first joined a
// component with a front submap (system clock; null: never).
struct BackSubmapTimes {
  int64_t id = -1;
  std::vector<Timestamp> keyframes;  // increasing
  std::optional<Timestamp> joined_wall;
};

// A loss begins at a frame the front did not track (not a frame the replay
// skipped) after one it tracked (tracking or coarse), and runs until it
// tracks again or the sequence ends; the start-up before the first tracked
// frame is not a loss. Empty when a frame of a loss has no wall time.
std::vector<LossToMerge> ComputeLossToMerge(const std::vector<FrontFrameLine>& frames,
                                            const std::vector<BackSubmapTimes>& back);

// back_stats.json per_window (submaps, submap_timestamps) joined with
// manager_stats.json back_submap_times (joined_wall_s). Throws naming the file
// and key when one is malformed; a manager without back_submap_times (an
// older one) gives no join times.
std::vector<BackSubmapTimes> ReadBackSubmapTimes(const std::string& back_stats_path,
                                                 const std::string& manager_stats_path);

LossToMergeSummary SummarizeLossToMerge(const std::vector<LossToMerge>& losses);

}  // namespace rumi
