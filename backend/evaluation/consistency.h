// Filter consistency measures (Bar-Shalom, Li & Kirubarajan, "Estimation with Applications
// to Tracking and Navigation", 2001, §5.4): the normalised estimation error squared (NEES)
// of a pose and the two-sided chi-square acceptance band of its average over Monte-Carlo
// runs.
#pragma once

#include <utility>

#include "core/pose.h"

namespace ieslam {

// e^T P^-1 e with e = PoseDifference(estimate, truth) (angles wrapped).
double PoseNees(const Vector6d& estimate, const Vector6d& truth, const Matrix6d& covariance);

// Quantile of the chi-square distribution with `dof` degrees of freedom (Wilson-Hilferty
// cube-root normal approximation: in the 2.5-97.5% range its relative error is about 2.5%
// at dof = 6 and below 0.1% for dof >= 100, the sizes Monte-Carlo bands use).
double ChiSquareQuantile(double probability, double dof);

// The two-sided `confidence` band of the average NEES over `runs` runs of a `dim`-dimensional
// state: [chi2_{(1-c)/2}(dim*runs), chi2_{(1+c)/2}(dim*runs)] / runs.
std::pair<double, double> NeesBand(int dim, int runs, double confidence = 0.95);

}  // namespace ieslam
