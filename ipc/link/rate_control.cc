#include "ipc/link/rate_control.h"

#include <algorithm>
#include <cmath>

namespace rumi {

const OptionSpec<RateControlOptions>& RateControlOptions::Spec() {
  using O = RateControlOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("rate_control");
    s->Flag("enabled", &O::enabled, "ask the robot for a lower frame rate when the link cannot carry its frames");
    s->Number("window_s", &O::window_s, Above(0.0), AtMost(60.0), "frames judged together, seconds");
    s->Number("max_dropped", &O::max_dropped, AtLeast(0.0), AtMost(1.0),
              "a window with more of its frames dropped cuts the rate");
    s->Number("max_late", &O::max_late, Above(0.0), AtMost(1.0),
              "... or with a p90 latency above this share of frame_deadline_ms");
    s->Number("cut", &O::cut, Above(0.0), Below(1.0), "new rate = cut x the window's arrival rate");
    s->Number("hold_s", &O::hold_s, AtLeast(0.0), AtMost(60.0),
              "no second cut this soon after one (the frames queued before it drain first)");
    s->Number("min_fps", &O::min_fps, Above(0.0), AtMost(1000.0), "never ask for fewer frames per second");
    s->Number("raise_after_s", &O::raise_after_s, Above(0.0), AtMost(3600.0), "clean this long: raise the rate");
    s->Number("raise_fps", &O::raise_fps, Above(0.0), AtMost(1000.0), "by this many frames per second");
    return s;
  }();
  return *spec;
}

void RateControl::OnFrame(int64_t now_us, bool complete, double latency_ms) {
  if (window_start_us_ == 0) window_start_us_ = clean_since_us_ = now_us;
  ++frames_;
  if (complete) {
    latencies_ms_.push_back(latency_ms);
  } else {
    ++dropped_;
  }
}

double RateControl::Poll(int64_t now_us) {
  if (!o_.enabled || window_start_us_ == 0) return 0;
  const double span_s = (now_us - window_start_us_) * 1e-6;
  if (span_s < o_.window_s) return 0;
  const double arrival_fps = frames_ / span_s;
  double p90 = 0;
  if (!latencies_ms_.empty()) {
    const size_t k = std::min(latencies_ms_.size() - 1, static_cast<size_t>(std::floor(0.9 * latencies_ms_.size())));
    std::nth_element(latencies_ms_.begin(), latencies_ms_.begin() + static_cast<long>(k), latencies_ms_.end());
    p90 = latencies_ms_[k];
  }
  const bool troubled =
      frames_ > 0 && (dropped_ > o_.max_dropped * frames_ || p90 > o_.max_late * deadline_ms_);
  // The robot's own rate: the most that ever arrived (dropped frames count:
  // the reassembler knows them by their ids), the ceiling of a raise.
  max_seen_fps_ = std::max(max_seen_fps_, arrival_fps);
  window_start_us_ = now_us;
  frames_ = dropped_ = 0;
  latencies_ms_.clear();
  if (troubled) {
    clean_since_us_ = now_us;
    if (cuts_ > 0 && (now_us - last_cut_us_) * 1e-6 < o_.hold_s) return 0;
    const double want = std::max(o_.min_fps, o_.cut * std::min(arrival_fps, asked_fps_ > 0 ? asked_fps_ : 1e9));
    if (asked_fps_ > 0 && want >= asked_fps_) return 0;  // already at the floor
    asked_fps_ = want;
    ++cuts_;
    last_cut_us_ = now_us;
    return asked_fps_;
  }
  if (asked_fps_ > 0 && (now_us - clean_since_us_) * 1e-6 >= o_.raise_after_s) {
    clean_since_us_ = now_us;
    const double ceiling = std::max(max_seen_fps_, asked_fps_);
    const double want = std::min(asked_fps_ + o_.raise_fps, ceiling);
    if (want <= asked_fps_) return 0;
    asked_fps_ = want;
    ++raises_;
    return asked_fps_;
  }
  return 0;
}

}  // namespace rumi
