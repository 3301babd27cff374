#pragma once
// Frame-rate control of the robot link: when the link cannot carry the
// robot's frames (a bandwidth cap, a weak Wi-Fi cell) frames queue on the
// robot, arrive late and miss their deadline, and nearly all are lost (at a
// 2.5 Mbit/s cap a 30 fps QVGA stream delivered 85 of 270 frames with
// latencies up to 2 s, docs/results/2026-11-27-robot-link-spread.md). Fewer
// frames that all arrive serve the front better, so the ground station asks
// the robot for a lower frame rate (control `frame rate`), multiplicatively,
// when a window of frames has too many drops or too late ones, and for a
// higher one, additively, after a clean stretch, never above the highest
// rate seen.
#include <cstdint>
#include <string>
#include <vector>

#include "common/option_spec.h"

namespace rumi {

struct RateControlOptions {
  bool enabled = true;
  double window_s = 1.0;          // frames judged together
  // Mild overload (a few % of frames dropped) is left alone: the front
  // copes with a few frames missing better than with a lower rate.
  double max_dropped = 0.15;      // dropped share of a window's frames above which the rate is cut
  double max_late = 1.0;          // ... or a p90 latency above this share of the frame deadline
  double cut = 0.7;               // new rate = cut x the window's arrival rate
  double hold_s = 2.0;            // no second cut this soon: the frames queued before the cut drain first
  double min_fps = 2;
  double raise_after_s = 5;       // clean this long (after a cut or a raise): raise
  double raise_fps = 1;           // by this much
  static const OptionSpec<RateControlOptions>& Spec();
  bool Check(std::string* why = nullptr) const { return Spec().Check(*this, why); }
};

class RateControl {
 public:
  RateControl(const RateControlOptions& o, double frame_deadline_ms) : o_(o), deadline_ms_(frame_deadline_ms) {}
  // One frame's fate at ground time now_us: completed with its latency, or dropped.
  void OnFrame(int64_t now_us, bool complete, double latency_ms);
  // The frame rate to ask the robot for now (fps), or 0 for no change.
  double Poll(int64_t now_us);
  double asked_fps() const { return asked_fps_; }  // 0: never asked (the robot's own rate)
  double max_seen_fps() const { return max_seen_fps_; }
  int cuts() const { return cuts_; }
  int raises() const { return raises_; }

 private:
  RateControlOptions o_;
  double deadline_ms_;
  int64_t window_start_us_ = 0, clean_since_us_ = 0, last_cut_us_ = 0;
  int frames_ = 0, dropped_ = 0;
  std::vector<double> latencies_ms_;
  double asked_fps_ = 0, max_seen_fps_ = 0;
  int cuts_ = 0, raises_ = 0;
};

}  // namespace rumi
