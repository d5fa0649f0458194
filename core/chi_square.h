// Quantiles of the normal and chi-square distributions, for consistency bands and gates.
#pragma once

namespace ieslam {

// Inverse of the standard normal CDF (Acklam's rational approximation, |error| < 1.2e-9).
double NormalQuantile(double p);

// Quantile of the chi-square distribution with `dof` degrees of freedom (Wilson-Hilferty
// cube-root normal approximation: in the 2.5-97.5% range its relative error is about 2.5%
// at dof = 6 and below 0.1% for dof >= 100, the sizes Monte-Carlo bands use).
double ChiSquareQuantile(double probability, double dof);

}  // namespace ieslam
