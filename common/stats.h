#pragma once
// Order statistics of a sample, for every layer (the merge core, the
// evaluation, the grid): one of each.
#include <optional>
#include <vector>

namespace rumi {

// Numpy-style median (mean of the two middle values) and nearest-rank p-th
// percentile (p in [0, 100]); nullopt for no values.
std::optional<double> Median(std::vector<double> values);
std::optional<double> PercentileNearestRank(std::vector<double> values, double p);

// The upper of the two middle values for an even count (the value at
// index n / 2 in order; 0 for no values): a value of the sample itself,
// found in linear time (nth_element), where the mean of two would do no
// better (a camera height, a step length, a reprojection error).
double UpperMedian(std::vector<double> values);

}  // namespace rumi
