#include "imukit/hwmodel/noise_fit.hpp"

#include <fmt/core.h>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "imukit/core/error.hpp"
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

// Sigma^-1/2 applied to x, with Sigma = D^1/2 C D^1/2 split into its diagonal D and correlation
// matrix C first: the variances span many decades, the correlations do not.
struct Whitener {
  Eigen::VectorXd inv_sd;
  Eigen::MatrixXd transform;  // C^-1/2 (symmetric)
  explicit Whitener(const Eigen::MatrixXd& sigma) {
    inv_sd = sigma.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd corr = inv_sd.asDiagonal() * sigma * inv_sd.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(corr);
    // The covariance sums are approximate (sampled lags, about 1e-3 relative), so directions
    // with eigenvalues below 1e-4 of the largest carry rounding, not information: floor them.
    const Eigen::VectorXd ev = es.eigenvalues().cwiseMax(es.eigenvalues().maxCoeff() * 1e-4);
    transform = es.eigenvectors() * ev.cwiseSqrt().cwiseInverse().asDiagonal() *
                es.eigenvectors().transpose();
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
  Eigen::MatrixXd Aa(Aw.rows(), static_cast<Eigen::Index>(act.size()));
  for (size_t k = 0; k < act.size(); ++k) Aa.col(static_cast<Eigen::Index>(k)) = Aw.col(act[k]);
  const Eigen::MatrixXd info = Aa.transpose() * Aa;
  const Eigen::MatrixXd inv =
      info.ldlt().solve(Eigen::MatrixXd::Identity(info.rows(), info.cols()));
  for (size_t i = 0; i < act.size(); ++i)
    for (size_t j = 0; j < act.size(); ++j)
      cov(act[i], act[j]) = inv(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
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
    fit.lower[t] = std::sqrt(std::max(0.0, sq - z * sd_sq));
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
  const double w[3] = {1.0, -2.0, 1.0};
  // Cross-covariance of the (unnormalised) second differences z1_j, z2_{j+l}, in S units.
  auto cross = [&](double l) {
    double total = 0.0;
    for (int term = 0; term < 4; ++term) {
      if (g[term] == 0.0) continue;
      double s = 0.0;
      for (int p = 0; p < 3; ++p)
        for (int q = 0; q < 3; ++q) s += w[p] * w[q] * term_gacv(term, l + q * b - p * a);
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
  // Sum of f over integer lags in [-(M1-1), M2-1]: exactly near zero, then a trapezoid rule on
  // nodes spaced max(1, m/16) out to 6 max(m1, m2), then geometrically spaced nodes.
  const double mmax = static_cast<double>(std::max(m1, m2));
  auto side = [&](double sign, double end) {
    double sum = 0.0;
    double l = 0.0;
    double prev = f(0.0);
    const double exact_end = std::min(end, 64.0);
    while (l < exact_end) {
      l += 1.0;
      prev = f(sign * l);
      sum += prev;
    }
    const double mid_end = std::min(end, std::max(exact_end, 6.0 * mmax));
    const double step = std::max(1.0, std::floor(mmax / 16.0));
    while (l < end) {
      const double next = l < mid_end ? std::min(mid_end, l + step)
                                      : std::min(end, std::max(l + 1.0, std::floor(l * 1.1)));
      const double cur = f(sign * next);
      sum += 0.5 * (prev + cur) * (next - l) + 0.5 * (cur - prev);
      prev = cur;
      l = next;
    }
    return sum;
  };
  const double total =
      f(0.0) + side(1.0, static_cast<double>(M2 - 1)) + side(-1.0, static_cast<double>(M1 - 1));
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

NoiseFit fit_noise_model(const std::vector<double>& tau_s, const std::vector<double>& adev,
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

SlopeReadings read_slopes(const std::vector<double>& tau, const std::vector<double>& adev,
                          const std::vector<double>& lower, const std::vector<double>& upper) {
  SlopeReadings out;
  const size_t n = tau.size();
  if (n < 3 || adev.size() != n || lower.size() != n || upper.size() != n) return out;
  // Local slope of log ADEV against log tau, central differences.
  std::vector<double> slope(n);
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k == 0 ? 0 : k - 1, b = k + 1 < n ? k + 1 : n - 1;
    slope[k] = std::log(adev[b] / adev[a]) / std::log(tau[b] / tau[a]);
  }
  auto rel_sigma = [&](size_t k) { return 0.5 * (upper[k] - lower[k]) / adev[k]; };
  auto read = [&](double target, auto value_at) {
    SlopeReading r;
    size_t best = 0;
    double err = 1e300;
    for (size_t k = 0; k < n; ++k) {
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
  const auto it = std::min_element(adev.begin(), adev.end());
  const auto k = static_cast<size_t>(it - adev.begin());
  out.bias_instability.found = true;
  out.bias_instability.tau_s = tau[k];
  out.bias_instability.slope = slope[k];
  out.bias_instability.value = *it / kFlickerFloorFactor;
  out.bias_instability.sigma = out.bias_instability.value * rel_sigma(k);
  return out;
}

}  // namespace imukit::hwmodel

namespace imukit::hwmodel {

namespace {
NoiseFit gls_once(const std::vector<double>& tau_s, const std::vector<double>& adev,
                  const std::vector<int64_t>& factors, int64_t n, const NoiseFitOptions& options) {
  if (tau_s.size() != adev.size() || tau_s.size() != factors.size()) {
    throw Error("noise fit: tau, deviation and factor lists differ in length");
  }
  const std::vector<size_t> use = usable_points(tau_s, adev, options, [&](size_t k) {
    return factors[k] >= 1 && n + 1 - 2 * factors[k] >= 2;
  });
  const std::vector<int> terms = selected_terms(options);
  const double tau0 = tau_s[use.front()] / static_cast<double>(factors[use.front()]);

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
  NoiseFit fit = fit_noise_model(t1, a1, e1, first);

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
  for (int it = 0; it < 2; ++it) {
    // The covariance needs some noise in the model; a floor of white noise at 1e-6 of the
    // first point's level keeps it positive definite when the fit zeroed every noise term.
    std::array<double, kNoiseTerms> model = fit.value;
    model[kWhite] =
        std::max(model[kWhite], 1e-6 * adev[use.front()] * std::sqrt(tau_s[use.front()]));
    Eigen::MatrixXd sigma(rows, rows);
    for (Eigen::Index i = 0; i < rows; ++i)
      for (Eigen::Index j = 0; j <= i; ++j)
        sigma(i, j) = sigma(j, i) =
            allan_variance_covariance(model, tau0, n, factors[use[static_cast<size_t>(i)]],
                                      factors[use[static_cast<size_t>(j)]]);
    const Whitener whiten(sigma);
    Aw = whiten(basis_m);
    const Eigen::VectorXd bw = whiten(avar);
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
  const int dof = static_cast<int>(rows) - static_cast<int>(act.size());
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
  return fit;
}
}  // namespace

NoiseFit fit_noise_model_gls(const std::vector<double>& tau_s, const std::vector<double>& adev,
                             const std::vector<int64_t>& factors, int64_t n,
                             const NoiseFitOptions& options) {
  // Backward elimination: a term whose interval reaches zero is not detected; it is dropped
  // (the weakest first, by value / sigma) and the rest refitted, and reported as 0 with the
  // upper bound of the last fit that held it. Without this a random walk that happens to
  // wander low at long tau lends a spurious floor to B.
  NoiseFitOptions opt = options;
  NoiseFit fit = gls_once(tau_s, adev, factors, n, opt);
  std::array<double, kNoiseTerms> dropped_upper{};
  std::array<bool, kNoiseTerms> dropped{};
  for (int round = 0; round < kNoiseTerms; ++round) {
    int weakest = -1;
    double weakest_score = 1e300;
    int selected = 0;
    for (int t = 0; t < kNoiseTerms; ++t) selected += opt.terms[static_cast<size_t>(t)];
    for (int t = 0; t < kNoiseTerms; ++t) {
      if (!opt.terms[static_cast<size_t>(t)] || !fit.active[static_cast<size_t>(t)] ||
          fit.lower[static_cast<size_t>(t)] > 0.0)
        continue;
      const double score =
          fit.sigma[static_cast<size_t>(t)] > 0
              ? fit.value[static_cast<size_t>(t)] / fit.sigma[static_cast<size_t>(t)]
              : 0.0;
      if (score < weakest_score) weakest_score = score, weakest = t;
    }
    if (weakest < 0 || selected <= 1) break;
    dropped[static_cast<size_t>(weakest)] = true;
    dropped_upper[static_cast<size_t>(weakest)] = fit.upper[static_cast<size_t>(weakest)];
    opt.terms[static_cast<size_t>(weakest)] = false;
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
  }
  return fit;
}

}  // namespace imukit::hwmodel
