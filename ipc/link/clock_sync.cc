#include "ipc/link/clock_sync.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

namespace rumi {

bool ClockSync::Add(int64_t t1, int64_t t2, int64_t t3, int64_t t4) {
  if (t4 < t1 || t3 < t2) return false;
  const double delay = static_cast<double>((t4 - t1) - (t3 - t2));
  if (delay < 0 || delay > 10e6) return false;
  // Differences first: the clocks' absolute values can be ~1e15 us apart.
  s_.push_back({0.5 * static_cast<double>(t1) + 0.5 * static_cast<double>(t4), static_cast<double>(t2 - t1),
                static_cast<double>(t3 - t4), delay});
  while (static_cast<int>(s_.size()) > o_.window) s_.pop_front();
  Fit();
  return true;
}

double ClockSync::Middle(size_t b, size_t e, double slope, double ref) const {
  double up = std::numeric_limits<double>::infinity(), lo = -up;
  for (size_t i = b; i < e; ++i) {
    const double trend = slope * (s_[i].ground_mid - ref);
    up = std::min(up, s_[i].upper - trend);
    lo = std::max(lo, s_[i].lower - trend);
  }
  return 0.5 * (up + lo);
}

void ClockSync::Fit() {
  const size_t n = s_.size();
  slope_ = 0;
  best_delay_ = s_[0].delay;
  for (const Sample& x : s_) best_delay_ = std::min(best_delay_, x.delay);
  const double span = s_.back().ground_mid - s_.front().ground_mid;
  bool drift = span * 1e-6 >= o_.min_drift_span_s;
  if (drift) {
    // A line through the middles of bins of bin_s (least squares), twice: the
    // second time the first drift is removed inside each bin (a drift widens
    // a bin's bounds). Used only once its standard error is small: a wrong
    // drift extrapolated over the offset span is worse than none.
    double stderr_ppm = 1e9;
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<std::pair<double, double>> pts;  // (seconds, offset us)
      for (size_t b = 0; b < n;) {
        size_t e = b;
        while (e < n && s_[e].ground_mid - s_[b].ground_mid < o_.bin_s * 1e6) ++e;
        const double t = 0.5 * (s_[b].ground_mid + s_[e - 1].ground_mid);
        pts.push_back({(t - s_.front().ground_mid) * 1e-6, Middle(b, e, slope_, t)});
        b = e;
      }
      if (pts.size() < 4) break;
      double mx = 0, my = 0;
      for (auto& p : pts) mx += p.first / pts.size(), my += p.second / pts.size();
      double sxx = 0, sxy = 0;
      for (auto& p : pts) sxx += (p.first - mx) * (p.first - mx), sxy += (p.first - mx) * (p.second - my);
      if (sxx <= 0) break;
      const double b1 = sxy / sxx;  // us per s = ppm
      double rss = 0;
      for (auto& p : pts) rss += std::pow(p.second - my - b1 * (p.first - mx), 2);
      stderr_ppm = std::sqrt(rss / (pts.size() - 2) / sxx);
      slope_ = b1 * 1e-6;
    }
    drift = stderr_ppm <= o_.max_drift_stderr_ppm;
    drift_stderr_ppm_ = stderr_ppm;
    if (!drift) slope_ = 0;
  }
  // The offset from the recent bounds: without a drift estimate only the last
  // short span (an unknown drift of 50 ppm moves the offset 1.5 ms in 30 s).
  const double keep = drift ? o_.offset_span_s : o_.bin_s * 3;
  size_t b = 0;
  while (b + 8 < n && s_.back().ground_mid - s_[b].ground_mid > keep * 1e6) ++b;
  ref_ = 0.5 * (s_[b].ground_mid + s_.back().ground_mid);
  intercept_ = Middle(b, n, slope_, ref_);
  fitted_ = true;
}

double ClockSync::OffsetAt(int64_t ground_us) const {
  if (!fitted_) return 0;
  return intercept_ + slope_ * (static_cast<double>(ground_us) - ref_);
}

int64_t ClockSync::ToGround(int64_t robot_us) const {
  if (!fitted_) return robot_us;
  // robot = ground + intercept + slope * (ground - ref): solve for ground.
  const double g = (static_cast<double>(robot_us) - intercept_ + slope_ * ref_) / (1.0 + slope_);
  return static_cast<int64_t>(std::llround(g));
}

std::string ClockSync::Describe() const {
  if (!fitted_) return "not synced";
  char b[160];
  std::snprintf(b, sizeof(b), "offset %.3f ms, drift %.1f ppm, best round trip %.1f ms, %d round trips",
                intercept_ * 1e-3, drift_ppm(), best_delay_ * 1e-3, samples());
  return b;
}

}  // namespace rumi
