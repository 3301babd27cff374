#pragma once
// One COLMAP attempt on a window's workspace (colmap_workspace.h): feature
// extraction, matching and mapping with the COLMAP CLI at fixed PINHOLE
// intrinsics, each step a process of its own (timeout, cancel, low
// priority), then every model read back as a back submap: frames
// registered off the camera path left out (common/pose_jumps.h), tracks
// completed, weak points and small models dropped. Which attempts run
// (fill, retry) is the attempt policy's (attempt_policy.h).
#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "back/back_options.h"
#include "back/back_result.h"
#include "back/colmap_workspace.h"
#include "common/window.h"

namespace rumi {

// One COLMAP model as a back submap (its id not given yet).
struct BuiltModel {
  Submap submap;
  BackSubmapStats stats;
};

struct ColmapAttempt {
  BackStatus status = BackStatus::kOk;
  std::string message;              // why, when not ok
  std::vector<BuiltModel> built;    // the models kept, largest first
  std::vector<std::string> warnings;
  size_t models = 0;                // model folders the mapper wrote
  std::string name;                 // for the log: "first attempt", "fill", "retry", "fill of the retry"
  int largest() const { return built.empty() ? 0 : built.front().stats.registered_images; }
};

struct AttemptSpec {
  double peak_threshold = 0;  // SIFT; 0 = COLMAP's default
  std::string tag;            // its database and model folder: "" (first), "_retry"
  // A fill reuses the database of `tag`: no extraction, the pairs the
  // selection left out are matched (COLMAP skips pairs matched already) and
  // the mapper runs again into its own folder (sparse<tag>_all).
  bool fill = false;
};

struct ColmapStep {
  const char* name;               // in messages: "feature_extraction", "matching", "mapping"
  std::vector<std::string> args;  // after the executable; args[0] is COLMAP's command
  double BackStepTimes::*seconds;      // where its wall time adds up
  double BackStepTimes::*cpu_seconds;  // and its CPU time
};

// A double as COLMAP's options get it: %.17g, exact.
std::string ColmapNumber(double v);

// The COLMAP command lines of one attempt: feature_extractor (not for a
// fill), the matcher of back.matcher, mapper. blank_stretches: the workspace
// has the fill's pair list (WritePairLists); without it a fill matches
// every pair.
std::vector<ColmapStep> ColmapAttemptSteps(const BackOptions& options, const PinholeCameraOptions& camera,
                                           const ColmapWorkspace& ws, const AttemptSpec& attempt,
                                           bool blank_stretches);

class ColmapRunner {
 public:
  // Step times add up in *times (a retry adds to the first attempt's);
  // on_stage (may be empty) gets each COLMAP command about to run.
  ColmapRunner(const BackOptions& options, const ImageWindow& window, const ColmapWorkspace& ws,
               bool blank_stretches, const std::atomic<bool>* cancel,
               const std::function<void(const std::string&)>& on_stage, BackStepTimes* times);

  // Runs the attempt's steps and reads its models back. Never throws.
  ColmapAttempt Run(const AttemptSpec& attempt);

 private:
  bool RunStep(const ColmapStep& step, ColmapAttempt* at);

  const BackOptions& options_;
  const ImageWindow& window_;
  const ColmapWorkspace& ws_;
  const bool blank_stretches_;
  const std::atomic<bool>* cancel_;
  const std::function<void(const std::string&)>& on_stage_;
  BackStepTimes* times_;
};

}  // namespace rumi
