#include "backend/evaluation/error_stats.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

namespace ieslam {

ErrorStats ComputeErrorStats(const std::vector<double>& errors) {
  CHECK(!errors.empty()) << "statistics of an empty error list";
  const double n = static_cast<double>(errors.size());
  ErrorStats stats;
  stats.count = errors.size();
  double sum = 0.0;
  double sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  stats.rmse = std::sqrt(sum_sq / n);
  stats.mean = sum / n;
  stats.median = Median(errors);
  // Two passes, as numpy.std: sum of squares minus n mean^2 cancels for tight errors.
  double var = 0.0;
  for (double e : errors) var += (e - stats.mean) * (e - stats.mean);
  stats.std = std::sqrt(var / n);
  const auto [lo, hi] = std::minmax_element(errors.begin(), errors.end());
  stats.min = *lo;
  stats.max = *hi;
  return stats;
}

ErrorStats ComputeFiniteErrorStats(const std::vector<double>& values) {
  std::vector<double> finite;
  finite.reserve(values.size());
  for (double v : values) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  return finite.empty() ? ErrorStats() : ComputeErrorStats(finite);
}

ErrorStats ScaleErrorStats(ErrorStats stats, double factor) {
  stats.rmse *= factor;
  stats.mean *= factor;
  stats.median *= factor;
  stats.std *= factor;
  stats.min *= factor;
  stats.max *= factor;
  return stats;
}

double Median(std::vector<double> values) {
  CHECK(!values.empty());
  const std::size_t n = values.size();
  std::sort(values.begin(), values.end());
  return n % 2 == 1 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2.0;
}

}  // namespace ieslam
