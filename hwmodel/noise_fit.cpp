#include "imukit/hwmodel/noise_fit.hpp"

#include <fmt/core.h>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "imukit/core/error.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/hwmodel/chi_square.hpp"

namespace imukit::hwmodel {
namespace {

// Above any recording's sample count, so no real edf reaches it; an infinite or astronomically
// large one (a crafted input) would overflow the weighted columns and silently zero the fit.
constexpr double kMaxEdf = 1e15;

// Basis of the model in the squared coefficients (Q^2, N^2, B^2, K^2, R^2).
double basis(int term, double tau) {
  switch (term) {
    case kQuantization:
      return 3.0 / (tau * tau);
    case kWhite:
      return 1.0 / tau;
    case kBiasInstability:
      return 2.0 * std::numbers::ln2 / std::numbers::pi;
    case kRandomWalk:
      return tau / 3.0;
    default:
      return tau * tau / 2.0;
  }
}

// Lawson-Hanson active-set NNLS: min |A x - b| subject to x >= 0. Small dense problems only.
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const Eigen::Index n = A.cols();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(static_cast<size_t>(n), false);
  const double tol = 1e-12 * A.norm() * std::max(1.0, b.norm());
  for (int outer = 0; outer < 3 * static_cast<int>(n) + 10; ++outer) {
    const Eigen::VectorXd w = A.transpose() * (b - A * x);
    Eigen::Index t = -1;
    double best = tol;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!passive[static_cast<size_t>(j)] && w(j) > best) best = w(j), t = j;
    }
    if (t < 0) break;
    passive[static_cast<size_t>(t)] = true;
    for (int inner = 0; inner < 3 * static_cast<int>(n) + 10; ++inner) {
      std::vector<Eigen::Index> idx;
      for (Eigen::Index j = 0; j < n; ++j)
        if (passive[static_cast<size_t>(j)]) idx.push_back(j);
      Eigen::MatrixXd Ap(A.rows(), static_cast<Eigen::Index>(idx.size()));
      for (size_t k = 0; k < idx.size(); ++k) Ap.col(static_cast<Eigen::Index>(k)) = A.col(idx[k]);
      const Eigen::VectorXd sp = Ap.colPivHouseholderQr().solve(b);
      Eigen::VectorXd s = Eigen::VectorXd::Zero(n);
      for (size_t k = 0; k < idx.size(); ++k) s(idx[k]) = sp(static_cast<Eigen::Index>(k));
      bool feasible = true;
      for (Eigen::Index j : idx) feasible = feasible && s(j) > 0.0;
      if (feasible) {
        x = s;
        break;
      }
      // Step towards s until the first passive variable reaches zero; drop those at zero.
      double alpha = 1.0;
      for (Eigen::Index j : idx) {
        if (s(j) <= 0.0) alpha = std::min(alpha, x(j) / (x(j) - s(j)));
      }
      x += alpha * (s - x);
      for (Eigen::Index j : idx) {
        if (x(j) <= 1e-15 * std::max(1.0, x.cwiseAbs().maxCoeff())) {
          x(j) = 0.0;
          passive[static_cast<size_t>(j)] = false;
        }
      }
    }
  }
  return x;
}

// Phase generalised autocovariances (up to scale) of the noise behind each model term, in
// samples: quantisation = white PM (impulse), N = white FM (-|t|), B = flicker FM (t^2 ln|t|),
// K = random-walk FM (|t|^3).
double term_gacv(int term, double t) {
  const double at = std::abs(t);
  switch (term) {
    case kQuantization:
      return at < 0.5 ? 1.0 : 0.0;
    case kWhite:
      return -at;
    case kBiasInstability:
      return at == 0.0 ? 0.0 : t * t * std::log(at);
    default:
      return at * at * at;
  }
}

// Allan variance of m-sample averages that gacv R gives (up to the same scale), sample units.
double unit_avar(int term, double m) {
  return (6.0 * term_gacv(term, 0.0) - 8.0 * term_gacv(term, m) + 2.0 * term_gacv(term, 2.0 * m)) /
         (2.0 * m * m);
}

// Weights of the second difference, x_{j+2m} - 2 x_{j+m} + x_j.
constexpr double kSecondDifference[3] = {1.0, -2.0, 1.0};

// (phi(1) - 2 phi(1 - x) + phi(1 - 2x)) / x^2 for phi(u) = u^2 ln u and |x| <= 1/32, by its
// Taylor series 3 - 2x - sum_{k>=4} c_k x^(k-2), c_k = 2 (2^k - 2) / (k (k-1) (k-2)) (from
// phi^(k)(1) = 2 (-1)^(k-1) (k-3)! for k >= 3); the terms beyond k = 15 are below 1e-19.
double flicker_second_difference_series(double x) {
  constexpr int kLast = 15;  // an even number of coefficients, 4..15
  static constexpr auto kCoefficients = [] {
    std::array<double, kLast + 1> c{};
    for (int k = 4; k <= kLast; ++k)
      c[static_cast<size_t>(k)] =
          2.0 * static_cast<double>((int64_t{1} << k) - 2) / (double(k) * (k - 1) * (k - 2));
    return c;
  }();
  // Horner in x^2 over pairs of terms: half the dependent multiply-adds of plain Horner.
  const double x2 = x * x;
  double tail = kCoefficients[kLast - 1] + kCoefficients[kLast] * x;
  for (int k = kLast - 3; k >= 4; k -= 2)
    tail = tail * x2 +
           (kCoefficients[static_cast<size_t>(k)] + kCoefficients[static_cast<size_t>(k + 1)] * x);
  return 3.0 - 2.0 * x - tail * x2;
}

// Second difference with step m of a term's gacv, sum_p w_p R(t - p m). Away from (0, 2m) the
// three values are large and nearly cancel, and adding them in floating point leaves a residue
// where the exact difference is small or, after the second difference over the other factor,
// exactly 0: |t|^3 at t = 3e5 is 2.7e16, rounded to +-4, while C for m1 = 1, m2 = 37 peaks at
// a few hundred, and such residues at all 6e5 lags put the sum 1e-3 off. So there the
// difference is taken in closed form: 0 for -|t|, 6 m^2 (|t| - m) for |t|^3, and for t^2 ln|t|,
// with ln|t - p m| = ln|t| + log1p(-p m / t), 2 m^2 ln|t| plus the log1p terms (their series
// beyond |t| = 32 m, which is cheaper).
double second_difference(int term, double m, double t) {
  auto direct = [&] {
    return term_gacv(term, t) - 2.0 * term_gacv(term, t - m) + term_gacv(term, t - 2.0 * m);
  };
  switch (term) {
    case kQuantization:
      return direct();
    case kWhite:
      return t <= 0.0 || t >= 2.0 * m ? 0.0 : direct();
    case kBiasInstability:
      if (std::abs(t) <= 4.0 * m) return direct();
      if (std::abs(t) < 32.0 * m) {
        return 2.0 * m * m * std::log(std::abs(t)) - 2.0 * (t - m) * (t - m) * std::log1p(-m / t) +
               (t - 2.0 * m) * (t - 2.0 * m) * std::log1p(-2.0 * m / t);
      }
      return m * m * (2.0 * std::log(std::abs(t)) + flicker_second_difference_series(m / t));
    default:
      if (t >= 2.0 * m) return 6.0 * m * m * (t - m);
      if (t <= 0.0) return 6.0 * m * m * (m - t);
      return direct();
  }
}

// Gauss-Legendre rule with 2 * half nodes (x, -x) and weights w on [u, v].
template <class F>
double gauss_legendre(const F& f, double u, double v, const double* x, const double* w, int half) {
  const double c = 0.5 * (u + v), h = 0.5 * (v - u);
  double sum = 0.0;
  for (int i = 0; i < half; ++i) sum += w[i] * (f(c - h * x[i]) + f(c + h * x[i]));
  return h * sum;
}

// Integral of f over [A, B] inside the stretch (s, e) of sum_between. A polynomial of degree
// <= 7: 4-node Gauss-Legendre, exact. Otherwise f has a t^2 ln|t| singularity at each end that
// is a kink of C (`singular_s`, `singular_e`), 9 or more lags beyond A or B. Next to such an
// end the integral is taken in v = ln(l - s) (or ln(e - l)), where the singularity moves to
// v = -infinity and f e^v is smooth, with 16 Gauss-Legendre nodes per 7 units of v (or less);
// between two singular ends, the quarters next to them so and the middle half with 8 nodes.
// Every rule's other singularities lie outside its Bernstein ellipse of rho = 2.2 (error
// ~rho^-32); the sums agree with the lag-by-lag sum to 1e-9 for n from 3e5 to 7.2e6.
template <class F>
double integral_between(const F& f, double s, double e, double A, double B, bool polynomial,
                        bool singular_s, bool singular_e) {
  constexpr double kX4[2] = {0.33998104358485626, 0.8611363115940526};
  constexpr double kW4[2] = {0.6521451548625462, 0.3478548451374537};
  constexpr double kX8[4] = {0.18343464249564978, 0.525532409916329, 0.7966664774136267,
                             0.9602898564975362};
  constexpr double kW8[4] = {0.36268378337836177, 0.31370664587788705, 0.22238103445337434,
                             0.10122853629037669};
  constexpr double kX16[8] = {0.09501250983763745, 0.2816035507792589, 0.45801677765722737,
                              0.6178762444026438,  0.755404408355003,  0.8656312023878318,
                              0.9445750230732326,  0.9894009349916499};
  constexpr double kW16[8] = {0.18945061045506859,  0.1826034150449236,  0.16915651939500262,
                              0.14959598881657676,  0.12462897125553403, 0.09515851168249259,
                              0.062253523938647706, 0.027152459411754037};
  if (polynomial) return gauss_legendre(f, A, B, kX4, kW4, 2);
  // Integral of f over the lags at distance d0..d1 from the end `from` (direction +1 from s,
  // -1 from e), in v = ln d.
  auto from_end = [&](double from, double direction, double d0, double d1) {
    auto g = [&](double v) {
      const double d = std::exp(v);
      return f(from + direction * d) * d;
    };
    const double v0 = std::log(d0), v1 = std::log(d1);
    const int panels = std::max(1, static_cast<int>(std::ceil((v1 - v0) / 7.0)));
    double sum = 0.0;
    for (int i = 0; i < panels; ++i)
      sum += gauss_legendre(g, v0 + (v1 - v0) * i / panels, v0 + (v1 - v0) * (i + 1) / panels, kX16,
                            kW16, 8);
    return sum;
  };
  if (!singular_e) return from_end(s, 1.0, A - s, B - s);
  if (!singular_s) return from_end(e, -1.0, e - B, e - A);
  const double quarter = 0.25 * (e - s);
  if (s + quarter <= A) return gauss_legendre(f, A, B, kX8, kW8, 4);
  return from_end(s, 1.0, A - s, quarter) +
         gauss_legendre(f, s + quarter, e - quarter, kX8, kW8, 4) +
         from_end(e, -1.0, e - B, quarter);
}

// Sum of f(l) over the integers l strictly between the breakpoints s < e, where f is smooth:
// a polynomial of degree <= 7 when `polynomial`, otherwise analytic except at s and e. Unless
// f is a polynomial, the first and last kEndLags lags are summed directly; the rest, l = A..B,
// by Gregory's formula
//   sum_{l=A}^{B} f(l) = int_A^B f + (f(A) + f(B)) / 2
//                        + sum_{k=1}^{8} G_k (nabla^k f(B) + (-1)^k Delta^k f(A))
// (G_k the Gregory coefficients; exact for polynomials up to degree 9), with the integral by
// integral_between.
template <class F>
double sum_between(const F& f, double s, double e, bool polynomial, bool singular_s,
                   bool singular_e) {
  constexpr int kEndLags = 8, kOrder = 8;
  constexpr double kGregory[kOrder] = {1.0 / 12,          1.0 / 24,        19.0 / 720,
                                       3.0 / 160,         863.0 / 60480,   275.0 / 24192,
                                       33953.0 / 3628800, 8183.0 / 1036800};
  // A polynomial needs no lags summed directly: Gregory's formula is exact from the first lag.
  const double end_lags = polynomial ? 0.0 : kEndLags;
  double sum = 0.0;
  if (e - s - 1.0 <= 2.0 * (end_lags + kOrder + 1)) {
    for (double l = s + 1.0; l < e; l += 1.0) sum += f(l);
    return sum;
  }
  const double A = s + 1.0 + end_lags, B = e - 1.0 - end_lags;
  for (double l = s + 1.0; l < A; l += 1.0) sum += f(l);
  for (double l = B + 1.0; l < e; l += 1.0) sum += f(l);
  std::array<double, kOrder + 1> head{}, tail{};
  for (int i = 0; i <= kOrder; ++i) {
    head[static_cast<size_t>(i)] = f(A + i);
    tail[static_cast<size_t>(i)] = f(B - kOrder + i);
  }
  sum += 0.5 * (head[0] + tail[kOrder]);
  for (int k = 1; k <= kOrder; ++k) {
    // After this pass head[0] is Delta^k f(A) and tail[kOrder] is nabla^k f(B).
    for (int i = 0; i + k <= kOrder; ++i) {
      head[static_cast<size_t>(i)] =
          head[static_cast<size_t>(i + 1)] - head[static_cast<size_t>(i)];
      tail[static_cast<size_t>(kOrder - i)] =
          tail[static_cast<size_t>(kOrder - i)] - tail[static_cast<size_t>(kOrder - i - 1)];
    }
    sum += kGregory[k - 1] * (tail[static_cast<size_t>(kOrder)] + (k % 2 ? -1.0 : 1.0) * head[0]);
  }
  return sum + integral_between(f, s, e, A, B, polynomial, singular_s, singular_e);
}

// Sigma^-1/2 applied to x, with Sigma = D^1/2 C D^1/2 split into its diagonal D and correlation
// matrix C first: the variances span many decades, the correlations do not. Directions of C
// whose eigenvalue is below 1e-4 of the largest are dropped (a pseudo-inverse): on a dense tau
// grid neighbouring estimates are almost one number, and such directions carry no information
// of their own. They used to be kept with their eigenvalue floored, which shrank their residual
// while the degrees of freedom still counted every point: chi^2 / dof of white noise fell from
// 1.06 at 10 points a decade to 0.22 at 100, and a record with motion passed the goodness-of-fit
// gate with --points-per-decade 50 (found in review, 2026-11-27). `kept` is the number of
// whitened rows, the points the fit's degrees of freedom count.
struct Whitener {
  Eigen::VectorXd inv_sd;
  Eigen::MatrixXd transform;  // (kept x points): Lambda_kept^-1/2 V_kept^T
  Eigen::Index kept = 0;
  explicit Whitener(const Eigen::MatrixXd& sigma) {
    inv_sd = sigma.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd corr = inv_sd.asDiagonal() * sigma * inv_sd.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(corr);
    const double floor = es.eigenvalues().maxCoeff() * 1e-4;
    for (Eigen::Index k = 0; k < es.eigenvalues().size(); ++k) kept += es.eigenvalues()(k) >= floor;
    transform.resize(kept, corr.rows());
    // Eigen sorts the eigenvalues in increasing order: the kept ones are the last `kept`.
    const Eigen::Index first = es.eigenvalues().size() - kept;
    for (Eigen::Index k = 0; k < kept; ++k) {
      transform.row(k) =
          es.eigenvectors().col(first + k).transpose() / std::sqrt(es.eigenvalues()(first + k));
    }
  }
  Eigen::MatrixXd operator()(const Eigen::MatrixXd& x) const {
    return transform * (inv_sd.asDiagonal() * x);
  }
};

// Covariance of the fitted squares: the inverse normal matrix of the active (non-zero) terms of
// the weighted design Aw, scaled by `inflation`; inactive terms get zero rows and columns.
Eigen::MatrixXd active_covariance(const Eigen::MatrixXd& Aw, const std::vector<Eigen::Index>& act,
                                  double inflation) {
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(Aw.cols(), Aw.cols());
  if (act.empty()) return cov;
  // Columns scaled to unit norm, so the rank test sees how far apart the terms' shapes are and
  // not their magnitudes (Q and R differ by orders).
  Eigen::MatrixXd Aa(Aw.rows(), static_cast<Eigen::Index>(act.size()));
  Eigen::VectorXd norm(Aa.cols());
  for (size_t k = 0; k < act.size(); ++k) {
    const auto c = static_cast<Eigen::Index>(k);
    Aa.col(c) = Aw.col(act[k]);
    norm(c) = Aa.col(c).norm();
    if (norm(c) > 0.0) Aa.col(c) /= norm(c);
  }
  const Eigen::MatrixXd info = Aa.transpose() * Aa;  // unit diagonal
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(info);
  // More terms than points, or terms the curve cannot tell apart (found in review: a 60 s
  // record gave a singular system whose inverse claimed B at 5 sigma): their variances are
  // unbounded, so no interval excludes 0.
  if (norm.minCoeff() <= 0.0 || eig.eigenvalues().minCoeff() <= 1e-12) {
    for (const Eigen::Index a : act) cov(a, a) = std::numeric_limits<double>::infinity();
    return cov;
  }
  const Eigen::MatrixXd inv = eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
                              eig.eigenvectors().transpose();
  for (size_t i = 0; i < act.size(); ++i)
    for (size_t j = 0; j < act.size(); ++j) {
      const auto a = static_cast<Eigen::Index>(i), b = static_cast<Eigen::Index>(j);
      cov(act[i], act[j]) = inv(a, b) / (norm(a) * norm(b));
    }
  return cov * inflation;
}

// Each term's value, 1-sigma and interval from its fitted square x2 and the covariance. The
// interval is formed on the square (where the estimate is close to normal) and mapped back, so
// it never goes negative.
void set_terms(NoiseFit& fit, const std::vector<int>& terms, const Eigen::VectorXd& x2,
               const Eigen::MatrixXd& cov, double z) {
  for (Eigen::Index c = 0; c < x2.size(); ++c) {
    const auto t = static_cast<size_t>(terms[static_cast<size_t>(c)]);
    const double sq = std::max(0.0, x2(c));
    const double sd_sq = std::sqrt(std::max(0.0, cov(c, c)));
    fit.value[t] = std::sqrt(sq);
    fit.active[t] = sq > 0.0;
    fit.sigma[t] = sq > 0.0 ? sd_sq / (2.0 * std::sqrt(sq)) : 0.0;
    fit.lower[t] = std::isfinite(sd_sq) ? std::sqrt(std::max(0.0, sq - z * sd_sq)) : 0.0;
    fit.upper[t] = std::sqrt(sq + z * sd_sq);
  }
}

}  // namespace

double allan_variance_covariance(const std::array<double, kNoiseTerms>& c, double tau0, int64_t n,
                                 int64_t m1, int64_t m2) {
  const int64_t M1 = n + 1 - 2 * m1, M2 = n + 1 - 2 * m2;
  if (M1 < 1 || M2 < 1) return 0.0;
  // Scale of each term's gacv so that its Allan variance equals the model's term.
  double g[4] = {};
  for (int term = 0; term < 4; ++term) {
    const double model =
        c[static_cast<size_t>(term)] * c[static_cast<size_t>(term)] * basis(term, tau0);
    g[term] = model / unit_avar(term, 1.0);
  }
  const double a = static_cast<double>(m1), b = static_cast<double>(m2);
  // Cross-covariance of the (unnormalised) second differences z1_j, z2_{j+l}, in S units:
  // C(l) = sum_pq w_p w_q R(l + q b - p a), the second difference over the smaller factor taken
  // first (second_difference), so that far lags keep their digits.
  auto cross = [&](double l) {
    double total = 0.0;
    for (int term = 0; term < 4; ++term) {
      if (g[term] == 0.0) continue;
      double s = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double dk = static_cast<double>(k);
        s += kSecondDifference[k] * (m1 <= m2 ? second_difference(term, a, l + dk * b)
                                              : second_difference(term, b, dk * a - l));
      }
      total += g[term] * s;
    }
    return total;
  };
  auto overlap = [&](double l) {
    return std::max(
        0.0, std::min(static_cast<double>(M1), static_cast<double>(M2) - l) - std::max(0.0, -l));
  };
  auto f = [&](double l) {
    const double x = cross(l);
    return overlap(l) * x * x;
  };
  // Sum of f over the integer lags in [-(M1-1), M2-1]. C is a sum of narrow peaks, about
  // min(m1, m2) wide, at the kinks p m1 - q m2, and overlap is piecewise linear with its bends
  // at two of them (0 and M2 - M1 = 2 m1 - 2 m2), so f is smooth between the kinks and the two
  // ends: each of these breakpoints is summed directly, each stretch between two by
  // sum_between (exact for Q, N and K, whose C is piecewise polynomial; 1e-9 relative with B's
  // t^2 ln|t|). An end is singular when a kink lies on or beyond it.
  const double lo = -static_cast<double>(M1 - 1), hi = static_cast<double>(M2 - 1);
  std::array<double, 11> breaks{};
  bool kink_at_lo = false, kink_at_hi = false;
  for (int p = 0; p < 3; ++p) {
    for (int q = 0; q < 3; ++q) {
      const double kink = p * a - q * b;
      kink_at_lo = kink_at_lo || kink <= lo;
      kink_at_hi = kink_at_hi || kink >= hi;
      breaks[static_cast<size_t>(3 * p + q)] = std::clamp(kink, lo, hi);
    }
  }
  breaks[9] = lo;
  breaks[10] = hi;
  std::sort(breaks.begin(), breaks.end());
  const auto last = std::unique(breaks.begin(), breaks.end());
  const bool polynomial = g[kBiasInstability] == 0.0;
  double total = 0.0;
  for (auto it = breaks.begin(); it != last; ++it) {
    total += f(*it);
    if (it + 1 == last) continue;
    const double s = *it, e = *(it + 1);
    total += sum_between(f, s, e, polynomial, s != lo || kink_at_lo, e != hi || kink_at_hi);
  }
  // Var-cov of averages of squares of jointly Gaussian terms: Cov(z1^2, z2^2) = 2 C12^2.
  return 2.0 * total / (4.0 * a * a * b * b * static_cast<double>(M1) * static_cast<double>(M2));
}

const char* noise_term_name(int term) {
  static const char* names[] = {"Q", "N", "B", "K", "R"};
  return names[term];
}

double model_allan_variance(const std::array<double, kNoiseTerms>& c, double tau_s) {
  double v = 0.0;
  for (int i = 0; i < kNoiseTerms; ++i)
    v += c[static_cast<size_t>(i)] * c[static_cast<size_t>(i)] * basis(i, tau_s);
  return v;
}

namespace {

// The points of the Allan curve a fit uses: positive tau and finite positive deviation inside
// the options' tau window, and what `usable` (the caller's own condition) accepts. At least 2.
template <class Usable>
std::vector<size_t> usable_points(const std::vector<double>& tau_s, const std::vector<double>& adev,
                                  const NoiseFitOptions& options, Usable usable) {
  std::vector<size_t> use;
  for (size_t k = 0; k < tau_s.size(); ++k) {
    if (tau_s[k] > 0.0 && adev[k] > 0.0 && std::isfinite(adev[k]) && usable(k) &&
        tau_s[k] >= options.tau_min_s && tau_s[k] <= options.tau_max_s)
      use.push_back(k);
  }
  if (use.size() < 2) throw Error("noise fit: fewer than 2 usable points on the Allan curve");
  return use;
}

// The noise terms the options select (indices into Q, N, B, K, R). At least one. Also checks
// the options' confidence.
std::vector<int> selected_terms(const NoiseFitOptions& options) {
  if (!(options.confidence > 0.0 && options.confidence < 1.0)) {
    throw Error(
        fmt::format("noise fit: the confidence of the intervals must be between 0 and 1, got {:g}",
                    options.confidence));
  }
  std::vector<int> terms;
  for (int i = 0; i < kNoiseTerms; ++i)
    if (options.terms[static_cast<size_t>(i)]) terms.push_back(i);
  if (terms.empty()) throw Error("noise fit: no term selected");
  return terms;
}

}  // namespace

namespace {

// fit_noise_model on a curve of order 1 (see DeviationScale).
NoiseFit fit_independent(const std::vector<double>& tau_s, const std::vector<double>& adev,
                         const std::vector<double>& edf, const NoiseFitOptions& options) {
  if (tau_s.size() != adev.size() || tau_s.size() != edf.size()) {
    throw Error("noise fit: tau, deviation and edf lists differ in length");
  }
  const std::vector<size_t> use = usable_points(
      tau_s, adev, options, [&](size_t k) { return edf[k] >= 1.0 && edf[k] < kMaxEdf; });
  const std::vector<int> terms = selected_terms(options);

  const auto rows = static_cast<Eigen::Index>(use.size());
  const auto cols = static_cast<Eigen::Index>(terms.size());
  Eigen::MatrixXd basis_m(rows, cols);
  Eigen::VectorXd avar(rows), nu(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const size_t k = use[static_cast<size_t>(r)];
    for (Eigen::Index c = 0; c < cols; ++c)
      basis_m(r, c) = basis(terms[static_cast<size_t>(c)], tau_s[k]);
    avar(r) = adev[k] * adev[k];
    nu(r) = edf[k];
  }
  // Weighted rows: sqrt(w) = sqrt(nu / 2) / AVAR_model; columns scaled to unit norm so the
  // terms' very different magnitudes do not upset the solver.
  Eigen::VectorXd model = avar;
  Eigen::VectorXd x2(cols);
  Eigen::MatrixXd Aw(rows, cols);
  Eigen::VectorXd bw(rows), col_scale(cols);
  double chi2 = 0.0;
  for (int it = 0; it <= std::max(0, options.reweight_iterations); ++it) {
    for (Eigen::Index r = 0; r < rows; ++r) {
      const double sw = std::sqrt(0.5 * nu(r)) / std::max(model(r), 1e-300);
      Aw.row(r) = basis_m.row(r) * sw;
      bw(r) = avar(r) * sw;
    }
    for (Eigen::Index c = 0; c < cols; ++c) {
      col_scale(c) = Aw.col(c).norm();
      if (col_scale(c) > 0) Aw.col(c) /= col_scale(c);
    }
    const Eigen::VectorXd y = nnls(Aw, bw);
    x2 = y.cwiseQuotient(col_scale);
    chi2 = (Aw * y - bw).squaredNorm();
    for (Eigen::Index c = 0; c < cols; ++c) {
      if (col_scale(c) > 0) Aw.col(c) *= col_scale(c);
    }
    const Eigen::VectorXd next_model = basis_m * x2;
    if (next_model.minCoeff() <= 0.0) break;  // keep the last positive model as weights
    model = next_model;
  }

  NoiseFit fit;
  fit.points = static_cast<int>(rows);
  std::vector<Eigen::Index> act;
  for (Eigen::Index c = 0; c < cols; ++c)
    if (x2(c) > 0.0) act.push_back(c);
  const int dof = static_cast<int>(rows) - static_cast<int>(act.size());
  fit.chi2_per_dof = dof > 0 ? chi2 / dof : 0.0;
  // Grid density in points per decade over the fitted span, against one per octave.
  const double decades = std::log10(tau_s[use.back()] / tau_s[use.front()]);
  const double ppd = decades > 0 ? static_cast<double>(rows - 1) / decades : 1.0;
  const double octave_ppd = 1.0 / std::log10(2.0);
  const double corr = options.correct_for_correlation ? std::max(1.0, ppd / octave_ppd) : 1.0;
  fit.covariance_inflation = corr * std::max(1.0, fit.chi2_per_dof);

  const Eigen::MatrixXd cov = active_covariance(Aw, act, fit.covariance_inflation);
  const double z = normal_quantile(0.5 + 0.5 * options.confidence);
  set_terms(fit, terms, x2, cov, z);
  return fit;
}

// The fits square the deviations and the GLS covariance takes their fourth powers: a curve of
// 1e-170 (or 1e200) under- (over-) flowed to "fewer than 2 usable points" (found in review). So
// they fit adev / scale, scale the power of two at or below the largest finite deviation, and
// multiply the coefficients back; a power of two divides exactly, so a curve times 2^k gives
// the same fit times 2^k.
class DeviationScale {
 public:
  explicit DeviationScale(const std::vector<double>& adev) {
    double largest = 0.0;
    for (const double a : adev)
      if (std::isfinite(a)) largest = std::max(largest, std::abs(a));
    // 2^-1022 to 2^1022 (as allan.cpp): the scale and its inverse are finite normal numbers.
    const int e = largest > 0.0 ? std::clamp(std::ilogb(largest), -1022, 1022) : 0;
    scale_ = std::ldexp(1.0, e);
    inverse_ = std::ldexp(1.0, -e);
    scaled_.reserve(adev.size());
    for (const double a : adev) scaled_.push_back(a * inverse_);
  }
  const std::vector<double>& scaled() const { return scaled_; }
  NoiseFit restore(NoiseFit f) const {
    for (auto* v : {&f.value, &f.sigma, &f.lower, &f.upper})
      for (double& x : *v) x *= scale_;
    return f;
  }

 private:
  double scale_ = 1.0, inverse_ = 1.0;
  std::vector<double> scaled_;
};

}  // namespace

NoiseFit fit_noise_model(const std::vector<double>& tau_s, const std::vector<double>& adev,
                         const std::vector<double>& edf, const NoiseFitOptions& options) {
  const DeviationScale s(adev);
  return s.restore(fit_independent(tau_s, s.scaled(), edf, options));
}

SlopeReadings read_slopes(const std::vector<double>& tau, const std::vector<double>& adev,
                          const std::vector<double>& lower, const std::vector<double>& upper) {
  SlopeReadings out;
  const size_t n = tau.size();
  if (n < 3 || adev.size() != n || lower.size() != n || upper.size() != n) return out;
  // Only positive, finite deviations are read: a deviation of exactly zero (a signal that
  // toggles by one count reads 0 at every even factor) has no logarithm and no relative
  // interval, and would turn the readings into NaN and infinities.
  auto usable = [&](size_t k) { return adev[k] > 0.0 && std::isfinite(adev[k]); };
  // Local slope of log ADEV against log tau, central differences; NaN where it cannot be read.
  std::vector<double> slope(n, std::numeric_limits<double>::quiet_NaN());
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k == 0 ? 0 : k - 1, b = k + 1 < n ? k + 1 : n - 1;
    if (usable(a) && usable(b) && usable(k))
      slope[k] = std::log(adev[b] / adev[a]) / std::log(tau[b] / tau[a]);
  }
  auto rel_sigma = [&](size_t k) { return 0.5 * (upper[k] - lower[k]) / adev[k]; };
  auto read = [&](double target, auto value_at) {
    SlopeReading r;
    size_t best = 0;
    double err = 1e300;
    for (size_t k = 0; k < n; ++k) {  // a NaN slope compares false: never read
      if (std::abs(slope[k] - target) < err) err = std::abs(slope[k] - target), best = k;
    }
    if (err <= 0.15) {
      r.found = true;
      r.tau_s = tau[best];
      r.slope = slope[best];
      r.value = value_at(best);
      r.sigma = r.value * rel_sigma(best);
    }
    return r;
  };
  out.white = read(-0.5, [&](size_t k) { return adev[k] * std::sqrt(tau[k]); });
  out.random_walk = read(0.5, [&](size_t k) { return adev[k] * std::sqrt(3.0 / tau[k]); });
  out.quantization = read(-1.0, [&](size_t k) { return adev[k] * tau[k] / std::sqrt(3.0); });
  out.ramp = read(1.0, [&](size_t k) { return adev[k] * std::sqrt(2.0) / tau[k]; });
  std::optional<size_t> lowest;
  for (size_t k = 0; k < n; ++k)
    if (usable(k) && (!lowest || adev[k] < adev[*lowest])) lowest = k;
  if (!lowest) return out;
  const size_t k = *lowest;
  out.bias_instability.found = true;
  out.bias_instability.tau_s = tau[k];
  out.bias_instability.slope = slope[k];
  out.bias_instability.value = adev[k] / kFlickerFloorFactor;
  out.bias_instability.sigma = out.bias_instability.value * rel_sigma(k);
  return out;
}

}  // namespace imukit::hwmodel

namespace imukit::hwmodel {

namespace {
// The Allan variances as GLS sees them, normalised by Wilson and Hilferty's cube root. An
// estimate with nu equivalent degrees of freedom is about its mean m times chi^2(nu) / nu, and
// chi^2 is skewed (the longest taus have 4-7 degrees of freedom: at 4 a point 1.96 sigma above
// its mean is twice as likely as a normal point), while (chi^2 / nu)^(1/3) is close to normal, with
// mean c = 1 - 2 / (9 nu) and variance 2 / (9 nu) (Wilson & Hilferty 1931). So the fit is a
// Gauss-Newton step of the model's cube root against the estimates' cube roots, linearised at
// the covariance's model m: each AVAR is replaced by z = m (1 + 3 ((AVAR / m)^(1/3) / c - 1)),
// whose mean is the model's value and whose covariance is the AVAR's divided by c_i c_j (`sigma`
// is scaled so), with nu = 2 m^2 / Var(AVAR) from the same covariance. Where nu is large (the
// short taus) z is the AVAR itself to first order; at the longest taus the tail a few-dof
// estimate throws up is drawn in, as a normal variable's would be. It acts on detection through
// the score test of gls_eliminating, linearised at the model without the term: a model that
// passes through the points leaves z = AVAR there (alone it left R in 14 of 300 white-noise axes,
// where 7.5 are expected; with the test, 4).
Eigen::VectorXd wilson_hilferty(const Eigen::VectorXd& avar, const std::vector<double>& tau_s,
                                const std::vector<size_t>& use,
                                const std::array<double, kNoiseTerms>& model,
                                Eigen::MatrixXd& sigma) {
  const auto rows = avar.size();
  Eigen::VectorXd z(rows), c(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const double m = model_allan_variance(model, tau_s[use[static_cast<size_t>(r)]]);
    const double var = sigma(r, r);
    if (!(m > 0.0) || !(var > 0.0) || !std::isfinite(m) || !std::isfinite(var)) {
      z(r) = avar(r);
      c(r) = 1.0;
      continue;
    }
    // At least one degree of freedom, where c is 7/9.
    const double nu = std::max(1.0, 2.0 * m * m / var);
    c(r) = 1.0 - 2.0 / (9.0 * nu);
    z(r) = m * (1.0 + 3.0 * (std::cbrt(avar(r) / m) / c(r) - 1.0));
  }
  sigma = c.cwiseInverse().asDiagonal() * sigma * c.cwiseInverse().asDiagonal();
  return z;
}

// One GLS fit of the options' terms. The covariance of the estimates comes from the fit's own
// model (refined twice), or, given covariance_model, from that model alone: the elimination
// compares nested models under one covariance, where chi^2 differences are meaningful.
NoiseFit gls_once(const std::vector<double>& tau_s, const std::vector<double>& adev,
                  const std::vector<int64_t>& factors, int64_t n, const NoiseFitOptions& options,
                  const std::array<double, kNoiseTerms>* covariance_model = nullptr,
                  double* chi2_out = nullptr) {
  if (tau_s.size() != adev.size() || tau_s.size() != factors.size()) {
    throw Error("noise fit: tau, deviation and factor lists differ in length");
  }
  const std::vector<size_t> use = usable_points(tau_s, adev, options, [&](size_t k) {
    return factors[k] >= 1 && n + 1 - 2 * factors[k] >= 2;
  });
  const std::vector<int> terms = selected_terms(options);
  const double tau0 = tau_s[use.front()] / static_cast<double>(factors[use.front()]);
  // The rates an Allan deviation takes (RateLimits).
  check_period(tau0, "noise fit: the sample rate (factor / tau)");

  // Start from the independent-points fit (edf of white FM is enough for a first model).
  std::vector<double> t1, a1, e1;
  for (size_t k : use) {
    t1.push_back(tau_s[k]);
    a1.push_back(adev[k]);
    e1.push_back(std::max(
        1.0, static_cast<double>(n + 1 - 2 * factors[k]) / static_cast<double>(factors[k])));
  }
  NoiseFitOptions first = options;
  first.correct_for_correlation = false;
  NoiseFit fit = fit_independent(t1, a1, e1, first);

  const auto rows = static_cast<Eigen::Index>(use.size());
  const auto cols = static_cast<Eigen::Index>(terms.size());
  Eigen::MatrixXd basis_m(rows, cols);
  Eigen::VectorXd avar(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c)
      basis_m(r, c) = basis(terms[static_cast<size_t>(c)], tau_s[use[static_cast<size_t>(r)]]);
    avar(r) = adev[use[static_cast<size_t>(r)]] * adev[use[static_cast<size_t>(r)]];
  }
  Eigen::VectorXd x2(cols);
  Eigen::MatrixXd Aw;
  double chi2 = 0.0;
  Eigen::Index whitened_rows = rows;
  for (int it = 0; it < (covariance_model != nullptr ? 1 : 2); ++it) {
    // The covariance needs some noise in the model; a floor of white noise at 1e-6 of the
    // first point's level keeps it positive definite when the fit zeroed every noise term.
    std::array<double, kNoiseTerms> model =
        covariance_model != nullptr ? *covariance_model : fit.value;
    model[kWhite] =
        std::max(model[kWhite], 1e-6 * adev[use.front()] * std::sqrt(tau_s[use.front()]));
    Eigen::MatrixXd sigma(rows, rows);
    for (Eigen::Index i = 0; i < rows; ++i)
      for (Eigen::Index j = 0; j <= i; ++j)
        sigma(i, j) = sigma(j, i) =
            allan_variance_covariance(model, tau0, n, factors[use[static_cast<size_t>(i)]],
                                      factors[use[static_cast<size_t>(j)]]);
    const Eigen::VectorXd observed = wilson_hilferty(avar, tau_s, use, model, sigma);
    const Whitener whiten(sigma);
    Aw = whiten(basis_m);
    const Eigen::VectorXd bw = whiten(observed);
    whitened_rows = whiten.kept;
    Eigen::VectorXd scale(cols);
    for (Eigen::Index c = 0; c < cols; ++c) {
      scale(c) = Aw.col(c).norm();
      if (scale(c) > 0) Aw.col(c) /= scale(c);
    }
    const Eigen::VectorXd y = nnls(Aw, bw);
    chi2 = (Aw * y - bw).squaredNorm();
    x2 = y.cwiseQuotient(scale);
    for (Eigen::Index c = 0; c < cols; ++c) {
      if (scale(c) > 0) Aw.col(c) *= scale(c);
    }
    for (Eigen::Index c = 0; c < cols; ++c)
      fit.value[static_cast<size_t>(terms[static_cast<size_t>(c)])] =
          std::sqrt(std::max(0.0, x2(c)));
  }

  std::vector<Eigen::Index> act;
  for (Eigen::Index c = 0; c < cols; ++c)
    if (x2(c) > 0.0) act.push_back(c);
  const int dof = static_cast<int>(whitened_rows) - static_cast<int>(act.size());
  fit.points = static_cast<int>(rows);
  fit.chi2_per_dof = dof > 0 ? chi2 / dof : 0.0;
  fit.covariance_inflation = std::max(1.0, fit.chi2_per_dof);
  const Eigen::MatrixXd cov = active_covariance(Aw, act, fit.covariance_inflation);
  const double z = normal_quantile(0.5 + 0.5 * options.confidence);
  fit.value.fill(0.0);
  fit.sigma.fill(0.0);
  fit.lower.fill(0.0);
  fit.upper.fill(0.0);
  fit.active.fill(false);
  set_terms(fit, terms, x2, cov, z);
  if (chi2_out != nullptr) *chi2_out = chi2;
  return fit;
}
}  // namespace

namespace {
// On a curve too short to tell the terms apart, keeps in `options` only N and says why;
// otherwise changes nothing and returns "". A short record's curve starts at the shortest taus,
// where white noise rules every MEMS sensor. A span cut short by tau_min_s is an error: it lies
// wherever the caller looked, and neither the curve's slope (on a few points too noisy to pick
// N against Q or B: a third of 50-sample white-noise axes went wrong) nor a lone term's GLS fit
// (found in review: B alone at 13 sigma above every point of hfi_static's accelerometer beyond
// 30 s) is a model of it.
std::string limit_terms_to_the_span(const std::vector<double>& tau_s,
                                    const std::vector<double>& adev,
                                    const std::vector<int64_t>& factors, int64_t n,
                                    NoiseFitOptions& options) {
  const std::vector<size_t> use = usable_points(tau_s, adev, options, [&](size_t k) {
    return factors[k] >= 1 && n + 1 - 2 * factors[k] >= 2;
  });
  const std::vector<int> terms = selected_terms(options);
  const double decades = std::log10(tau_s[use.back()] / tau_s[use.front()]);
  if (terms.size() <= 1 || decades >= kMinDecadesForAllTerms) return "";
  const bool from_the_first_tau = tau_s[use.front()] <= tau_s.front() * (1 + 1e-12);
  if (!from_the_first_tau || !options.terms[kWhite]) {
    throw Error(fmt::format(
        "noise fit: the fitted taus ({:.4g} to {:.4g} s) span {:.2g} decades, fewer than the {:g} "
        "needed to tell the noise terms apart{}",
        tau_s[use.front()], tau_s[use.back()], decades, kMinDecadesForAllTerms,
        from_the_first_tau ? "; select N or one term alone"
                           : ": fit from a shorter tau (tau_min_s, --fit-tau-min)"));
  }
  options.terms.fill(false);
  options.terms[kWhite] = true;
  return fmt::format(
      "the fitted taus span {:.2g} decades (fewer than {:g}; a short record): too short to tell "
      "the noise terms apart; only N fitted",
      decades, kMinDecadesForAllTerms);
}
}  // namespace

namespace {
// fit_noise_model_gls on a curve of order 1 (see DeviationScale).
NoiseFit gls_eliminating(const std::vector<double>& tau_s, const std::vector<double>& adev,
                         const std::vector<int64_t>& factors, int64_t n,
                         const NoiseFitOptions& options) {
  // Backward elimination: a term whose interval reaches zero is not detected; it is dropped
  // and the rest refitted, and reported as 0 with the upper bound of the last fit that held it.
  // Without this a random walk that happens to wander low at long tau lends a spurious floor to
  // B. Of several such terms the one whose removal raises chi^2 least goes first (the same as
  // the smallest value / sigma where the terms are well apart; where the curve cannot tell them
  // apart (a short record) value / sigma is meaningless and dropped the white noise itself).
  NoiseFitOptions opt = options;
  const std::string note = limit_terms_to_the_span(tau_s, adev, factors, n, opt);
  NoiseFit fit = gls_once(tau_s, adev, factors, n, opt);
  std::array<double, kNoiseTerms> dropped_upper{};
  std::array<bool, kNoiseTerms> dropped{};
  for (int round = 0; round < kNoiseTerms; ++round) {
    int selected = 0;
    for (int t = 0; t < kNoiseTerms; ++t) selected += opt.terms[static_cast<size_t>(t)];
    std::vector<int> undetected;
    for (int t = 0; t < kNoiseTerms; ++t) {
      if (opt.terms[static_cast<size_t>(t)] && fit.active[static_cast<size_t>(t)] &&
          !(fit.lower[static_cast<size_t>(t)] > 0.0))
        undetected.push_back(t);
    }
    if (selected <= 1) break;
    if (undetected.empty()) {
      // Every term's interval excludes 0 in the fit that holds it. But that fit's covariance
      // and Wilson-Hilferty linearisation come from its own model, which follows the points it
      // was fitted to: a few-dof estimate thrown high at the longest taus gets a ramp R through
      // it, and a point on its model is no outlier. So each active term is tested again as a
      // score test is, under the hypothesis that it is absent: the terms the fit holds are
      // refitted with the covariance and linearisation of the best model without it, with the
      // fit's own inflation (the misfit neither model explains), and the term is not detected
      // unless its interval excludes 0 there too. Only where two or more terms are active
      // (without it a lone term's model is empty); a test that is not finite (a null model far
      // from the curve, as white noise without N) leaves the term as it was.
      NoiseFitOptions held = opt;
      int active_terms = 0;
      for (int t = 0; t < kNoiseTerms; ++t) {
        held.terms[static_cast<size_t>(t)] =
            opt.terms[static_cast<size_t>(t)] && fit.active[static_cast<size_t>(t)];
        active_terms += held.terms[static_cast<size_t>(t)];
      }
      const double z = normal_quantile(0.5 + 0.5 * opt.confidence);
      for (int t = 0; t < kNoiseTerms && active_terms >= 2; ++t) {
        const auto ts = static_cast<size_t>(t);
        if (!held.terms[ts]) continue;
        NoiseFitOptions without = held;
        without.terms[ts] = false;
        std::array<double, kNoiseTerms> others = fit.value;
        others[ts] = 0.0;
        const NoiseFit null_fit = gls_once(tau_s, adev, factors, n, without, &others);
        const NoiseFit test = gls_once(tau_s, adev, factors, n, held, &null_fit.value);
        // value / sigma is twice the fitted square over its standard deviation.
        const double score = 0.5 * test.value[ts] / test.sigma[ts] *
                             std::sqrt(test.covariance_inflation / fit.covariance_inflation);
        if (!test.active[ts] || (std::isfinite(score) && score <= z)) undetected.push_back(t);
      }
    }
    if (undetected.empty()) break;
    int drop = undetected.front();
    if (undetected.size() > 1) {
      double best_chi2 = std::numeric_limits<double>::infinity();
      for (const int t : undetected) {
        NoiseFitOptions without = opt;
        without.terms[static_cast<size_t>(t)] = false;
        double c = 0.0;
        (void)gls_once(tau_s, adev, factors, n, without, &fit.value, &c);
        if (c < best_chi2) drop = t, best_chi2 = c;
      }
    }
    dropped[static_cast<size_t>(drop)] = true;
    dropped_upper[static_cast<size_t>(drop)] = fit.upper[static_cast<size_t>(drop)];
    opt.terms[static_cast<size_t>(drop)] = false;
    fit = gls_once(tau_s, adev, factors, n, opt);
  }
  for (int t = 0; t < kNoiseTerms; ++t) {
    if (dropped[static_cast<size_t>(t)]) {
      fit.value[static_cast<size_t>(t)] = 0.0;
      fit.sigma[static_cast<size_t>(t)] = 0.0;
      fit.lower[static_cast<size_t>(t)] = 0.0;
      fit.upper[static_cast<size_t>(t)] = dropped_upper[static_cast<size_t>(t)];
      fit.active[static_cast<size_t>(t)] = false;
    }
    if (options.terms[static_cast<size_t>(t)] && !opt.terms[static_cast<size_t>(t)] &&
        !dropped[static_cast<size_t>(t)])
      fit.upper[static_cast<size_t>(t)] = std::numeric_limits<double>::infinity();
  }
  fit.note = note;
  return fit;
}
}  // namespace

NoiseFit fit_noise_model_gls(const std::vector<double>& tau_s, const std::vector<double>& adev,
                             const std::vector<int64_t>& factors, int64_t n,
                             const NoiseFitOptions& options) {
  // The covariance takes tau0 from the first point and the sample count from n: factors twice
  // too large gave a chi^2/dof of 0.64 for 1.27 without a word (found in review, 2026-11-27).
  // Every tau must be its factor times one tau0, and n must hold the largest factor (an n too
  // large cannot be told from the curve).
  if (tau_s.size() == factors.size() && !tau_s.empty() && factors.front() > 0) {
    const double tau0 = tau_s.front() / static_cast<double>(factors.front());
    for (std::size_t k = 0; k < tau_s.size(); ++k) {
      if (!(std::abs(tau_s[k] - tau0 * static_cast<double>(factors[k])) <= 1e-9 * tau_s[k])) {
        throw Error(fmt::format(
            "noise fit: tau {} is {:g} s, and its factor {} times tau0 {:g} s is not: tau, "
            "factors and n must come from one Allan deviation",
            k, tau_s[k], factors[k], tau0));
      }
    }
    const int64_t largest = *std::max_element(factors.begin(), factors.end());
    if (n < 2 * largest + 1) {
      throw Error(fmt::format(
          "noise fit: {} samples cannot give an Allan deviation at factor {} (needs {} or more)", n,
          largest, 2 * largest + 1));
    }
  }
  const DeviationScale s(adev);
  return s.restore(gls_eliminating(tau_s, s.scaled(), factors, n, options));
}

}  // namespace imukit::hwmodel
