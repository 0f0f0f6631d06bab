#include "imukit/hwmodel/chi_square.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace imukit::hwmodel {
namespace {

TEST(ChiSquare, LowerGammaOfShapeOneIsExponentialCdf) {
  for (double x : {0.01, 0.5, 1.0, 3.0, 10.0, 40.0}) {
    EXPECT_NEAR(regularized_lower_gamma(1.0, x), 1.0 - std::exp(-x), 1e-14) << x;
  }
}

TEST(ChiSquare, LowerGammaOfShapeHalfIsErf) {
  // P(1/2, x) = erf(sqrt x): exercises the series and the continued fraction.
  for (double x : {0.001, 0.2, 1.4, 1.6, 5.0, 20.0}) {
    EXPECT_NEAR(regularized_lower_gamma(0.5, x), std::erf(std::sqrt(x)), 2e-14) << x;
  }
}

TEST(ChiSquare, QuantilesMatchPublishedTables) {
  // Values from standard chi-square tables (5 significant digits).
  EXPECT_NEAR(chi_square_quantile(0.975, 10.0), 20.483, 5e-3);
  EXPECT_NEAR(chi_square_quantile(0.025, 10.0), 3.2470, 5e-4);
  EXPECT_NEAR(chi_square_quantile(0.5, 1.0), 0.45494, 5e-5);
  EXPECT_NEAR(chi_square_quantile(0.95, 100.0), 124.342, 5e-3);
  EXPECT_NEAR(chi_square_quantile(0.05, 1.0), 0.0039321, 5e-7);
}

TEST(ChiSquare, TwoDegreesOfFreedomHasClosedFormQuantile) {
  for (double p : {1e-6, 0.01, 0.3, 0.5, 0.9, 0.999999}) {
    const double expected = -2.0 * std::log1p(-p);
    EXPECT_NEAR(chi_square_quantile(p, 2.0), expected, 1e-11 * std::max(1.0, expected)) << p;
  }
}

TEST(ChiSquare, QuantileInvertsCdfForFractionalDegrees) {
  for (double nu : {0.7, 1.3, 2.5, 17.25, 333.3, 1e5}) {
    for (double p : {0.0005, 0.025, 0.16, 0.5, 0.84, 0.975, 0.9995}) {
      const double x = chi_square_quantile(p, nu);
      // For huge nu the cdf's prefactor exp(a ln x - x - lnGamma(a)) cancels terms of ~nu/2,
      // which limits what either function can resolve.
      const double tol = nu > 1e4 ? 1e-10 : 1e-12;
      EXPECT_NEAR(chi_square_cdf(x, nu), p, tol) << "nu " << nu << " p " << p;
    }
  }
}

TEST(ChiSquare, NormalQuantileMatchesKnownValues) {
  EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 1e-13);
  EXPECT_NEAR(normal_quantile(0.5), 0.0, 1e-14);
  EXPECT_NEAR(normal_quantile(0.158655253931457), -1.0, 1e-12);
}

}  // namespace
}  // namespace imukit::hwmodel
