#include "imukit/hwmodel/chi_square.hpp"

#include <cassert>
#include <cmath>
#include <limits>

namespace imukit::hwmodel {
namespace {

// log of x^a e^-x / Gamma(a), the common prefactor of both expansions.
double log_prefactor(double a, double x) { return a * std::log(x) - x - std::lgamma(a); }

// Power series: gamma(a,x) = x^a e^-x sum_k x^k / (a (a+1) ... (a+k)).
double lower_series(double a, double x) {
  double term = 1.0 / a;
  double sum = term;
  for (int k = 1; k < 100000; ++k) {
    term *= x / (a + k);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-16) break;
  }
  return sum * std::exp(log_prefactor(a, x));
}

// Upper tail by the continued fraction Q(a,x) = e^-x x^a / Gamma(a) * 1/(x+1-a- 1(1-a)/(x+3-a-
// ...)), evaluated with the modified Lentz method.
double upper_fraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(log_prefactor(a, x)) * h;
}

}  // namespace

double regularized_lower_gamma(double a, double x) {
  assert(a > 0.0 && x >= 0.0);
  if (x == 0.0) return 0.0;
  if (x < a + 1.0) return lower_series(a, x);
  return 1.0 - upper_fraction(a, x);
}

double chi_square_cdf(double x, double nu) {
  assert(nu > 0.0);
  if (x <= 0.0) return 0.0;
  return regularized_lower_gamma(0.5 * nu, 0.5 * x);
}

double normal_quantile(double p) {
  assert(p > 0.0 && p < 1.0);
  // Bisection on Phi(z) = erfc(-z/sqrt 2)/2 over [-40, 40]: slow-ish but exact to the last bits
  // that erfc gives, and only called a few times per confidence interval.
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

double chi_square_quantile(double p, double nu) {
  assert(p > 0.0 && p < 1.0 && nu > 0.0);
  // Wilson & Hilferty (1931): (X/nu)^(1/3) is close to normal with mean 1 - 2/(9 nu) and
  // variance 2/(9 nu).
  const double z = normal_quantile(p);
  const double v = 2.0 / (9.0 * nu);
  double x = nu * std::pow(std::max(1.0 - v + z * std::sqrt(v), 1e-3), 3.0);
  // Bracket the root, then Newton steps on F(x) - p (F' is the chi-square density), falling
  // back to bisection whenever a step leaves the bracket.
  double lo = 0.0, hi = std::max(2.0 * x, nu + 10.0 * std::sqrt(2.0 * nu) + 50.0);
  while (chi_square_cdf(hi, nu) < p) hi *= 2.0;
  const double half = 0.5 * nu;
  for (int i = 0; i < 200; ++i) {
    const double f = chi_square_cdf(x, nu) - p;
    if (f < 0.0) {
      lo = x;
    } else {
      hi = x;
    }
    const double log_pdf =
        (half - 1.0) * std::log(x) - 0.5 * x - half * std::log(2.0) - std::lgamma(half);
    const double pdf = std::exp(log_pdf);
    double next = pdf > 0.0 ? x - f / pdf : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-14 * x || hi - lo <= 1e-14 * hi) {
      x = next;
      break;
    }
    x = next;
  }
  return x;
}

}  // namespace imukit::hwmodel
