#pragma once
// The robot's clock seen from the ground station: offset and drift from
// NTP-style round trips (t1 ground send, t2 robot receive, t3 robot send,
// t4 ground receive), robot = ground + offset. One round trip bounds the
// offset: t3 - t4 <= offset <= t2 - t1 (each leg takes >= 0). Averaging
// single round trips ((t2-t1)+(t3-t4))/2 keeps an error of half the legs'
// difference (tens of ms over Wi-Fi); intersecting the bounds of many round
// trips instead converges to the legs' minimum delays, which are nearly the
// same both ways: the estimate is the middle of the tightest bounds. Drift
// (ppm) is a line through the middles of short bins of the window; the
// offset is the middle of the bounds of the last offset_span_s, drift removed.
#include <cstdint>
#include <deque>
#include <string>

namespace rumi {

struct ClockSyncOptions {
  int window = 1200;               // round trips kept (5 min at 4 Hz)
  double min_drift_span_s = 120.0; // estimate a drift only over at least this long
  double bin_s = 10.0;
  double max_drift_stderr_ppm = 3.0;  // use the drift only once it is this certain             // the drift is a line through the bounds of bins this long
  double offset_span_s = 120.0;    // the offset from the round trips of the last this long
                                   // (3 bins while there is no drift estimate)
};

class ClockSync {
 public:
  explicit ClockSync(const ClockSyncOptions& o = {}) : o_(o) {}

  // Microseconds; t1, t4 ground clock, t2, t3 robot clock. A round trip that
  // is impossible (t4 < t1, t3 < t2, or a delay longer than 10 s) is ignored.
  bool Add(int64_t t1, int64_t t2, int64_t t3, int64_t t4);

  bool synced() const { return fitted_; }
  int samples() const { return static_cast<int>(s_.size()); }
  // Robot clock -> ground clock (microseconds). Before the first round trip:
  // the identity.
  int64_t ToGround(int64_t robot_us) const;
  // Robot minus ground at ground time t (microseconds).
  double OffsetAt(int64_t ground_us) const;
  double drift_ppm() const { return slope_ * 1e6; }  // 0 until it is certain
  double best_delay_us() const { return best_delay_; }
  std::string Describe() const;

 private:
  struct Sample {
    double ground_mid, upper, lower, delay;  // upper = t2 - t1, lower = t3 - t4
  };
  void Fit();
  // Middle of the tightest bounds over samples [b, e), after removing slope.
  double Middle(size_t b, size_t e, double slope, double ref) const;

  ClockSyncOptions o_;
  std::deque<Sample> s_;
  bool fitted_ = false;
  double ref_ = 0, intercept_ = 0, slope_ = 0, best_delay_ = 0, drift_stderr_ppm_ = 0;
};

}  // namespace rumi
