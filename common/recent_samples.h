#pragma once
// Percentiles of a figure measured per frame or per message (timings,
// latencies). RecentSamples keeps only the newest `window` values, plus the
// count and the maximum of all of them, so a run that lasts days reports the
// same figures without growing.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rumi {

// Nearest-rank percentile, p in [0, 1] (0: the smallest, 1: the largest); 0
// for no values.
double Percentile(std::vector<double> v, double p);

class RecentSamples {
 public:
  explicit RecentSamples(size_t window = size_t{1} << 16) : window_(window > 0 ? window : 1) {}
  void Add(double v);
  // Over the newest `window` values (at most 2 x window are held).
  double Percentile(double p) const { return rumi::Percentile(values_, p); }
  double max() const { return count_ > 0 ? max_ : 0; }  // of all values
  uint64_t count() const { return count_; }             // all values added
  size_t held() const { return values_.size(); }

 private:
  size_t window_;
  std::vector<double> values_;
  double max_ = 0;
  uint64_t count_ = 0;
};

}  // namespace rumi
