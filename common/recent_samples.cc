#include "common/recent_samples.h"

#include <algorithm>
#include <cmath>

namespace rumi {

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  p = std::clamp(p, 0.0, 1.0);
  const size_t rank = static_cast<size_t>(std::ceil(p * static_cast<double>(v.size())));
  const size_t k = std::min(v.size() - 1, rank > 0 ? rank - 1 : 0);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

void RecentSamples::Add(double v) {
  // Halving at 2 x window keeps Add O(1) amortised.
  if (values_.size() >= 2 * window_)
    values_.erase(values_.begin(), values_.end() - static_cast<std::ptrdiff_t>(window_));
  values_.push_back(v);
  max_ = count_ == 0 ? v : std::max(max_, v);
  ++count_;
}

}  // namespace rumi
