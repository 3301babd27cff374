#pragma once
// The core of rumi-back, independent of any transport: one ImageWindow in,
// zero or more back submaps (source kBack) or a failure report out. Runs the
// COLMAP CLI (feature_extractor, matcher, mapper) in a per-window workspace
// with fixed PINHOLE intrinsics and reads the binary models back.
#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "back/back_options.h"
#include "back/back_result.h"
#include "common/window.h"

namespace rumi {

class BackSubmapBuilder {
 public:
  // Submap ids are handed out from first_submap_id upwards.
  explicit BackSubmapBuilder(const BackOptions& options, int64_t first_submap_id = 0);

  // Never throws on bad input or COLMAP trouble: everything ends in the result.
  // cancel (optional) is polled while COLMAP runs.
  BackResult Build(const ImageWindow& window, const std::atomic<bool>* cancel = nullptr);

  const BackOptions& options() const { return options_; }
  // The next submap gets this id (then +1 per submap).
  void set_next_submap_id(int64_t id) { next_submap_id_ = id; }
  int64_t next_submap_id() const { return next_submap_id_; }
  // Called with the COLMAP step about to run ("feature_extractor", ...).
  void set_stage_callback(std::function<void(const std::string&)> f) { on_stage_ = std::move(f); }

 private:
  BackOptions options_;
  std::function<void(const std::string&)> on_stage_;
  int64_t next_submap_id_;
  int64_t workspace_counter_ = 0;
};

}  // namespace rumi
