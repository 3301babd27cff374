#pragma once
// Hierarchical fine/coarse mapping state (paper 000, Formulas 3-4).
// Fine: enough features (density n_t >= eta) to build keyframes; the submap
// grows. Coarse: features too sparse, or the submap stalled (the counter C_t
// of unchanged steps over the last lambda frames reaches a threshold): submap
// building is suspended, the finished submap is chained to the previous one
// by the external pose source, the robot halts until the merge is done, and
// building restarts once features are dense again.
#include <deque>
#include <string>

#include "common/option_spec.h"
#include "common/timestamp.h"

namespace rumi {

struct HierarchicalOptions {
  double eta = 3.0;         // min feature density: keypoints per 100x100 px
  int lambda = 30;          // window length (frames) of the stall counter C_t
  int stall_threshold = 25; // C_t >= this (submap unchanged) -> coarse
  int sparse_frames = 3;    // consecutive frames with n_t < eta -> coarse
  int resume_frames = 5;    // consecutive dense frames to go back to fine
  static const OptionSpec<HierarchicalOptions>& Spec();  // front.hierarchical_mode (front_options.cc)
  bool Check(std::string* why = nullptr) const;
};

enum class MappingGrain { kFine = 0, kCoarse = 1 };
const char* ToString(MappingGrain g);

class HierarchicalState {
 public:
  explicit HierarchicalState(const HierarchicalOptions& o = {});

  // One step per frame. density: detected features per 100x100 px;
  // submap_changed: the submap grew this frame (new keyframe / points);
  // building: a submap is being built (stall counting only then).
  // Returns the state after this frame.
  MappingGrain Update(double density, bool submap_changed, bool building);

  MappingGrain state() const { return state_; }
  // True on the frame where fine -> coarse happened (finish + chain the submap).
  bool entered_coarse() const { return entered_coarse_; }
  // True on the frame where coarse -> fine happened (restart building).
  bool left_coarse() const { return left_coarse_; }
  // The robot should halt while coarse (merge in progress, paper 000).
  bool halt() const { return state_ == MappingGrain::kCoarse; }
  int stall_count() const { return stall_count_; }  // C_t
  void Reset();

 private:
  HierarchicalOptions o_;
  MappingGrain state_ = MappingGrain::kFine;
  std::deque<bool> unchanged_;  // last lambda steps: submap unchanged?
  int stall_count_ = 0;
  int sparse_run_ = 0, dense_run_ = 0;
  bool entered_coarse_ = false, left_coarse_ = false;
};

}  // namespace rumi
