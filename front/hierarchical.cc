#include "front/hierarchical.h"

namespace rumi {

bool HierarchicalOptions::Check(std::string* why) const {
  auto fail = [&](const char* m) { if (why) *why = m; return false; };
  if (!(eta >= 0)) return fail("eta must be >= 0");
  if (lambda < 1) return fail("lambda must be >= 1");
  if (stall_threshold < 1 || stall_threshold > lambda) return fail("stall_threshold must be in [1, lambda]");
  if (sparse_frames < 1) return fail("sparse_frames must be >= 1");
  if (resume_frames < 1) return fail("resume_frames must be >= 1");
  return true;
}

void ReadOptions(ConfigSection& s, HierarchicalOptions* o) {
  s.ReadInRange("eta", &o->eta, 0.0, 1e4);
  s.ReadInRange("lambda", &o->lambda, 1, 100000);
  s.ReadInRange("stall_threshold", &o->stall_threshold, 1, 100000);
  s.ReadInRange("sparse_frames", &o->sparse_frames, 1, 100000);
  s.ReadInRange("resume_frames", &o->resume_frames, 1, 100000);
  CheckOptions(*o, s, "hierarchical");
}

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
