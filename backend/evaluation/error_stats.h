// Summary statistics of a list of errors, as TUM's evaluate_ate.py / evaluate_rpe.py print
// them: numpy's median (mean of the two middle values for an even count) and population std
// (ddof = 0). The trajectory evaluation and the filter-versus-smoother comparison both
// report their errors this way.
#pragma once

#include <cstddef>
#include <vector>

namespace ieslam {

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;
};

// The statistics of every value. CHECK-fails on an empty list.
ErrorStats ComputeErrorStats(const std::vector<double>& errors);
// The statistics of the finite values (NaN and inf skipped); all zeros when there are none.
ErrorStats ComputeFiniteErrorStats(const std::vector<double>& values);
// `stats` with every statistic but the count multiplied by `factor` (a change of unit).
ErrorStats ScaleErrorStats(ErrorStats stats, double factor);

// numpy's median: the middle value, or the mean of the two middle ones for an even count.
// CHECK-fails on an empty list.
double Median(std::vector<double> values);

}  // namespace ieslam
