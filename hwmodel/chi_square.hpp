// Chi-square distribution functions for confidence intervals of variance estimates with
// non-integer equivalent degrees of freedom (IEEE Std 1139, NIST SP 1065 section 5.3):
// a variance estimate with edf nu has nu * s^2 / sigma^2 ~ chi^2(nu), so the interval at
// confidence c is [nu s^2 / q(1-(1-c)/2), nu s^2 / q((1-c)/2)].
//
// Implemented here (no Boost): the regularised lower incomplete gamma function by its power
// series (x < a + 1) or Lentz's continued fraction for the upper one (otherwise), and the
// quantile by the Wilson-Hilferty cube-root approximation refined with safeguarded Newton steps.
#pragma once

namespace imukit::hwmodel {

// P(a, x) = gamma(a, x) / Gamma(a), a > 0, x >= 0 (asserted). Relative error ~1e-14.
double regularized_lower_gamma(double a, double x);

// Cumulative distribution of chi^2 with nu > 0 degrees of freedom at x >= 0.
double chi_square_cdf(double x, double nu);

// The x with chi_square_cdf(x, nu) = p, for 0 < p < 1 and nu > 0 (asserted): the cdf at the
// result is p to 1e-12 for nu <= 1e4 (1e-10 above, where lnGamma's rounding dominates).
double chi_square_quantile(double p, double nu);

// Standard normal quantile (inverse of Phi), 0 < p < 1; absolute accuracy 1e-14.
double normal_quantile(double p);

}  // namespace imukit::hwmodel
