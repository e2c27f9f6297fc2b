#pragma once
// Summary statistics of a list of non-negative errors, computed as numpy does in the TUM benchmark
// scripts: population standard deviation, median as the mean of the two middle values for even
// counts.
#include <cstddef>
#include <span>

namespace cofusion::eval {

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0;
  double mean = 0;
  double median = 0;
  double std = 0;  // population standard deviation (numpy.std, ddof = 0)
  double min = 0;
  double max = 0;
};

// All zeros when `values` is empty.
ErrorStats summarize_errors(std::span<const double> values);

// numpy.median: the middle value, or the mean of the two middle values. NaN when empty.
double median_of(std::span<const double> values);

}  // namespace cofusion::eval
