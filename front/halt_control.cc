#include "front/halt_control.h"

#include <spdlog/spdlog.h>

#include <algorithm>

namespace rumi {

bool HaltControl::Update(int64_t finished_id, Timestamp finished_end, int64_t map_upto, Timestamp map_end,
                         double now_s) {
  const auto in_map = [&](int64_t id, Timestamp end) {
    return map_upto > id || (map_upto == id && map_end >= end);
  };
  if (finished_id >= 0 && !in_map(finished_id, finished_end)) {
    if (waiting_for_ < 0) {
      since_s_ = now_s;
      ++stats_.halts;
      spdlog::info("front: halting the robot until submap {} is merged", finished_id);
    }
    if (finished_id > waiting_for_) waiting_for_ = finished_id, waiting_end_ = finished_end;
  }
  if (waiting_for_ >= 0) {
    if (in_map(waiting_for_, waiting_end_)) {
      Resume(now_s, true);
    } else if (now_s - since_s_ >= max_halt_s_) {
      Resume(now_s, false);
    }
  }
  return halted();
}

void HaltControl::Resume(double now_s, bool merged) {
  stats_.last_halt_s = now_s - since_s_;
  stats_.longest_halt_s = std::max(stats_.longest_halt_s, stats_.last_halt_s);
  if (merged) {
    ++stats_.resumed_on_merge;
    spdlog::info("front: submap {} is in the map after {:.1f} s: resuming the robot", waiting_for_,
                 stats_.last_halt_s);
  } else {
    ++stats_.resumed_on_timeout;
    spdlog::warn("front: submap {} not in the map after {:.1f} s: resuming the robot anyway", waiting_for_,
                 stats_.last_halt_s);
  }
  waiting_for_ = -1;
}

std::string HaltControl::Describe() const {
  return std::to_string(stats_.halts) + " halts (" + std::to_string(stats_.resumed_on_merge) + " resumed on merge, " +
         std::to_string(stats_.resumed_on_timeout) + " on timeout)";
}

}  // namespace rumi
