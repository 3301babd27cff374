#pragma once
// When the robot stands still (the rat-robot paper's hierarchical mode): on
// entering the coarse state the front finishes its submap; the robot halts
// until the manager's map holds that submap (a MapNotice from rumi-manager),
// then walks again; a merge that never comes (no manager, a submap refused)
// ends the halt after max_halt_s, logged. Pure logic: the caller sends halt
// and resume over the link.
#include <cstdint>
#include <string>

#include "common/timestamp.h"

namespace rumi {

struct HaltStats {
  int halts = 0;
  int resumed_on_merge = 0;
  int resumed_on_timeout = 0;
  double last_halt_s = 0, longest_halt_s = 0;
};

class HaltControl {
 public:
  explicit HaltControl(double max_halt_s) : max_halt_s_(max_halt_s) {}

  // Per frame. finished_id >= 0: the front just finished that submap, its
  // last frame at finished_end, on entering coarse. map_upto / map_end: the
  // newest front submap in the manager's map and its last frame (-1: none;
  // the manager also holds snapshots of submaps still being built: those end
  // before the finished version). Returns whether the robot should be halted.
  bool Update(int64_t finished_id, Timestamp finished_end, int64_t map_upto, Timestamp map_end, double now_s);
  bool halted() const { return waiting_for_ >= 0; }
  int64_t waiting_for() const { return waiting_for_; }
  const HaltStats& stats() const { return stats_; }
  std::string Describe() const;

 private:
  void Resume(double now_s, bool merged);

  double max_halt_s_;
  int64_t waiting_for_ = -1;
  Timestamp waiting_end_ = 0;
  double since_s_ = 0;
  HaltStats stats_;
};

}  // namespace rumi
