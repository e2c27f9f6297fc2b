#include "eval/error_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace cofusion::eval {

double median_of(std::span<const double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> sorted(values.begin(), values.end());
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  return n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

ErrorStats summarize_errors(std::span<const double> values) {
  ErrorStats s;
  s.count = values.size();
  if (values.empty()) return s;
  double sum = 0, sum_sq = 0;
  s.min = values[0];
  s.max = values[0];
  for (const double v : values) {
    sum += v;
    sum_sq += v * v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
  }
  const double n = static_cast<double>(values.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  // Two-pass variance: the one-pass form loses precision for errors far from zero.
  double var = 0;
  for (const double v : values) var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  s.median = median_of(values);
  return s;
}

}  // namespace cofusion::eval
