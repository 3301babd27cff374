#include "front/hierarchical.h"

namespace rumi {

const char* ToString(MappingGrain g) { return g == MappingGrain::kFine ? "fine" : "coarse"; }

HierarchicalState::HierarchicalState(const HierarchicalOptions& o) : o_(o) {}

void HierarchicalState::Reset() {
  state_ = MappingGrain::kFine;
  unchanged_.clear();
  stall_count_ = sparse_run_ = dense_run_ = 0;
  entered_coarse_ = left_coarse_ = false;
}

MappingGrain HierarchicalState::Update(double density, bool submap_changed, bool building) {
  entered_coarse_ = left_coarse_ = false;
  const bool dense = density >= o_.eta;
  sparse_run_ = dense ? 0 : sparse_run_ + 1;
  dense_run_ = dense ? dense_run_ + 1 : 0;
  if (state_ == MappingGrain::kFine) {
    // C_t (Formula 4): unchanged steps in the last lambda frames, only while
    // a submap is being built (initialisation is not a stall).
    if (building) {
      unchanged_.push_back(!submap_changed);
      stall_count_ += submap_changed ? 0 : 1;
      if (static_cast<int>(unchanged_.size()) > o_.lambda) {
        stall_count_ -= unchanged_.front() ? 1 : 0;
        unchanged_.pop_front();
      }
    }
    const bool stalled = static_cast<int>(unchanged_.size()) >= o_.lambda &&
                         stall_count_ >= o_.stall_threshold;
    if (sparse_run_ >= o_.sparse_frames || stalled) {
      state_ = MappingGrain::kCoarse;
      entered_coarse_ = true;
      unchanged_.clear();
      stall_count_ = 0;
    }
  } else if (dense_run_ >= o_.resume_frames) {
    state_ = MappingGrain::kFine;
    left_coarse_ = true;
  }
  return state_;
}

}  // namespace rumi
