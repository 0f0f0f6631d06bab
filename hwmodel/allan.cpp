#include "hwmodel/allan.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <map>
#include <string>
#include <thread>

#include "core/error.hpp"
#include "hwmodel/chi_square.hpp"

namespace imukit::hwmodel {
namespace {

// Squared differences are added into a block sum that is flushed every kBlock terms, so the
// rounding error of an n-term sum grows like (kBlock + n / kBlock) ulp instead of n ulp.
constexpr int64_t kBlock = 1024;

// S (axes x (n+1), sample-major) for each kind of deviation: the kernels below read it at
// offsets 0, m, 2m (and 3m) in one sweep. A is the compile-time axis count (0: runtime `axes`).
template <int A>
struct Kernels {
  static int count(int axes) { return A > 0 ? A : axes; }

  static void allan(const double* S, int64_t n, int64_t m, int axes, double* out) {
    const int k = count(axes);
    double total[16] = {}, block[16] = {};
    const int64_t terms = n + 1 - 2 * m;
    for (int64_t j0 = 0; j0 < terms; j0 += kBlock) {
      const int64_t j1 = std::min(terms, j0 + kBlock);
      for (int a = 0; a < k; ++a) block[a] = 0.0;
      for (int64_t j = j0; j < j1; ++j) {
        const double* s0 = S + j * k;
        const double* s1 = s0 + m * k;
        const double* s2 = s1 + m * k;
        for (int a = 0; a < k; ++a) {
          const double d = s2[a] - 2.0 * s1[a] + s0[a];
          block[a] += d * d;
        }
      }
      for (int a = 0; a < k; ++a) total[a] += block[a];
    }
    const double scale = 1.0 / (2.0 * double(m) * double(m) * double(terms));
    for (int a = 0; a < k; ++a) out[a] = total[a] * scale;
  }

  static void hadamard(const double* S, int64_t n, int64_t m, int axes, double* out) {
    const int k = count(axes);
    double total[16] = {}, block[16] = {};
    const int64_t terms = n + 1 - 3 * m;
    for (int64_t j0 = 0; j0 < terms; j0 += kBlock) {
      const int64_t j1 = std::min(terms, j0 + kBlock);
      for (int a = 0; a < k; ++a) block[a] = 0.0;
      for (int64_t j = j0; j < j1; ++j) {
        const double* s0 = S + j * k;
        const double* s1 = s0 + m * k;
        const double* s2 = s1 + m * k;
        const double* s3 = s2 + m * k;
        for (int a = 0; a < k; ++a) {
          const double d = s3[a] - 3.0 * s2[a] + 3.0 * s1[a] - s0[a];
          block[a] += d * d;
        }
      }
      for (int a = 0; a < k; ++a) total[a] += block[a];
    }
    const double scale = 1.0 / (6.0 * double(m) * double(m) * double(terms));
    for (int a = 0; a < k; ++a) out[a] = total[a] * scale;
  }

  // The inner sum W_j = sum_{i=j}^{j+m-1} D_i, D_i = S_{i+2m} - 2 S_{i+m} + S_i, slides:
  // W_{j+1} = W_j + D_{j+m} - D_j, kept with Kahan compensation so it does not drift.
  static void modified(const double* S, int64_t n, int64_t m, int axes, double* out) {
    const int k = count(axes);
    auto D = [&](int64_t i, int a) {
      return S[(i + 2 * m) * k + a] - 2.0 * S[(i + m) * k + a] + S[i * k + a];
    };
    double w[16] = {}, wc[16] = {}, total[16] = {}, block[16] = {};
    for (int64_t i = 0; i < m; ++i) {
      for (int a = 0; a < k; ++a) {
        const double y = D(i, a) - wc[a];
        const double t = w[a] + y;
        wc[a] = (t - w[a]) - y;
        w[a] = t;
      }
    }
    const int64_t terms = n + 2 - 3 * m;
    for (int64_t j0 = 0; j0 < terms; j0 += kBlock) {
      const int64_t j1 = std::min(terms, j0 + kBlock);
      for (int a = 0; a < k; ++a) block[a] = 0.0;
      for (int64_t j = j0; j < j1; ++j) {
        for (int a = 0; a < k; ++a) block[a] += w[a] * w[a];
        if (j + 1 < terms) {
          for (int a = 0; a < k; ++a) {
            const double y = (D(j + m, a) - D(j, a)) - wc[a];
            const double t = w[a] + y;
            wc[a] = (t - w[a]) - y;
            w[a] = t;
          }
        }
      }
      for (int a = 0; a < k; ++a) total[a] += block[a];
    }
    const double md = double(m);
    const double scale = 1.0 / (2.0 * md * md * md * md * double(terms));
    for (int a = 0; a < k; ++a) out[a] = total[a] * scale;
  }
};

using KernelFn = void (*)(const double*, int64_t, int64_t, int, double*);

KernelFn pick(Deviation kind, int axes) {
  auto choose = [&](auto tag) -> KernelFn {
    using K = decltype(tag);
    switch (kind) {
      case Deviation::kAllan: return &K::allan;
      case Deviation::kModifiedAllan: return &K::modified;
      case Deviation::kHadamard: return &K::hadamard;
    }
    return nullptr;
  };
  switch (axes) {
    case 1: return choose(Kernels<1>{});
    case 3: return choose(Kernels<3>{});
    case 6: return choose(Kernels<6>{});
    default: return choose(Kernels<0>{});
  }
}

int64_t estimator_terms(Deviation kind, int64_t n, int64_t m) {
  switch (kind) {
    case Deviation::kAllan: return n + 1 - 2 * m;
    case Deviation::kModifiedAllan: return n + 2 - 3 * m;
    case Deviation::kHadamard: return n + 1 - 3 * m;
  }
  return 0;
}

// Generalised autocovariance of the phase of power-law noise with frequency exponent alpha, up
// to a positive factor (which cancels in the edf): see the header.
double phase_gacv(double t, int alpha) {
  const double at = std::abs(t);
  switch (alpha) {
    case 0: return -at;
    case -1: return at == 0.0 ? 0.0 : t * t * std::log(at);
    case -2: return at * at * at;
    default: return at < 0.5 ? 1.0 : 0.0;  // white PM: an impulse at lag 0
  }
}

// Autocorrelation of the difference weights: ADEV (1,-2,1) -> (1,-4,6,-4,1); HDEV (-1,3,-3,1)
// -> (-1,6,-15,20,-15,6,-1); offsets in units of m.
struct WeightAcf {
  std::vector<std::pair<int, double>> taps;
};
WeightAcf weight_acf(Deviation kind) {
  if (kind == Deviation::kHadamard) {
    return {{{-3, -1.0}, {-2, 6.0}, {-1, -15.0}, {0, 20.0}, {1, -15.0}, {2, 6.0}, {3, -1.0}}};
  }
  return {{{-2, 1.0}, {-1, -4.0}, {0, 6.0}, {1, -4.0}, {2, 1.0}}};
}

// Covariance of the estimator's terms at lag l (samples).
double term_covariance(Deviation kind, int64_t m, double l, int alpha) {
  const WeightAcf acf = weight_acf(kind);
  const double md = double(m);
  auto second_diff_cov = [&](double lag) {
    double c = 0.0;
    for (const auto& [k, w] : acf.taps) c += w * phase_gacv(lag + k * md, alpha);
    return c;
  };
  if (kind != Deviation::kModifiedAllan) return second_diff_cov(l);
  // MDEV's term is a box sum of m second differences: cov = sum_{|u|<m} (m - |u|) c2(l + u).
  if (alpha == 2) {
    // Impulse phase covariance: the box sums collapse to a triangle, exactly.
    double c = 0.0;
    for (const auto& [k, w] : acf.taps) c += w * std::max(0.0, md - std::abs(l + k * md));
    return c;
  }
  // Other noises: c2 is smooth between kinks at multiples of m; integrate the triangle-weighted
  // sum with at most 64 nodes per side (trapezoid), exact when m <= 64.
  const int64_t step = std::max<int64_t>(1, m / 64);
  double c = 0.0;
  for (int64_t u = -(m - 1); u <= m - 1; u += step) {
    c += double(step) * (md - std::abs(double(u))) * second_diff_cov(l + double(u));
  }
  return c;
}

}  // namespace

std::vector<int64_t> log_spaced_factors(int64_t n, int points_per_decade, int64_t max_factor) {
  if (points_per_decade < 1) throw Error("Allan deviation: points per decade must be at least 1");
  if (max_factor <= 0) max_factor = n / 4;
  std::vector<int64_t> f;
  if (max_factor < 1) return f;
  const double decades = std::log10(double(max_factor));
  const int steps = int(std::floor(decades * points_per_decade + 1e-9));
  for (int i = 0; i <= steps; ++i) {
    const auto m = int64_t(std::llround(std::pow(10.0, double(i) / points_per_decade)));
    if (m >= 1 && m <= max_factor && (f.empty() || m > f.back())) f.push_back(m);
  }
  if (f.empty() || f.back() != max_factor) f.push_back(max_factor);
  return f;
}

double equivalent_dof(Deviation kind, int64_t n, int64_t m, int alpha) {
  assert(m >= 1 && n >= 1);
  if (alpha == 1 || alpha > 2) alpha = 2;
  if (alpha < -2) alpha = -2;
  const int64_t M = estimator_terms(kind, n, m);
  if (M < 1) return 0.0;
  const double c0 = term_covariance(kind, m, 0.0, alpha);
  auto f = [&](double l) {
    const double c = term_covariance(kind, m, l, alpha);
    return (1.0 - l / double(M)) * c * c;
  };
  double sum = 0.0;  // sum over l = 1 .. M-1 of f(l)
  const int span = kind == Deviation::kAllan ? 2 : 3;
  if (alpha == 2 && kind != Deviation::kModifiedAllan) {
    // Impulse covariance: only lags that are multiples of m correlate.
    for (int k = 1; k <= span && k * m < M; ++k) sum += f(double(k * m));
  } else {
    // Every lag up to 256, then a trapezoid rule with step max(1, m/64) up to 4 spans (c_l is
    // smooth between kinks at multiples of m), then log-spaced nodes for the decaying tail.
    const int64_t exact_end = std::min<int64_t>(M - 1, 256);
    for (int64_t l = 1; l <= exact_end; ++l) sum += f(double(l));
    int64_t l = exact_end;
    const int64_t mid_end = std::min<int64_t>(M - 1, std::max<int64_t>(exact_end, 4 * span * m));
    const int64_t step = std::max<int64_t>(1, m / 64);
    double prev = f(double(l));
    while (l < mid_end) {
      const int64_t next = std::min(mid_end, l + step);
      const double cur = f(double(next));
      // Sum of f over the integers in (l, next], exact when f is linear there.
      sum += 0.5 * (prev + cur) * double(next - l) + 0.5 * (cur - prev);
      prev = cur;
      l = next;
    }
    while (l < M - 1) {
      const int64_t next = std::min<int64_t>(M - 1, std::max<int64_t>(l + 1, int64_t(double(l) * 1.05)));
      const double cur = f(double(next));
      sum += 0.5 * (prev + cur) * double(next - l) + 0.5 * (cur - prev);
      prev = cur;
      l = next;
    }
  }
  const double denom = c0 * c0 + 2.0 * sum;
  if (!(denom > 0.0)) return 1.0;
  return std::max(1.0, double(M) * c0 * c0 / denom);
}

std::pair<double, double> deviation_interval(double dev, double nu, double confidence) {
  assert(confidence > 0.0 && confidence < 1.0 && nu > 0.0);
  const double tail = 0.5 * (1.0 - confidence);
  const double var = dev * dev;
  const double lo = std::sqrt(nu * var / chi_square_quantile(1.0 - tail, nu));
  const double hi = std::sqrt(nu * var / chi_square_quantile(tail, nu));
  return {lo, hi};
}

int alpha_from_avar_slope(double mu) {
  if (mu <= -1.5) return 2;
  const double a = std::round(-mu - 1.0);
  return int(std::clamp(a, -2.0, 0.0));
}

AllanResult allan_deviation(std::span<const TimeNs> t, const Eigen::Ref<const Eigen::MatrixXd>& samples,
                            const AllanOptions& options) {
  const auto n = int64_t(samples.cols());
  const int axes = int(samples.rows());
  if (axes < 1 || axes > 16) throw Error("Allan deviation: between 1 and 16 axes are supported");
  if (int64_t(t.size()) != n) {
    throw Error("Allan deviation: " + std::to_string(t.size()) + " time stamps for " +
                std::to_string(n) + " samples");
  }
  if (n < 8) throw Error("Allan deviation: at least 8 samples are needed, got " + std::to_string(n));
  AllanResult r;
  r.sampling = analyze_sampling(t);
  if (!(r.sampling.duration > 0)) throw Error("Allan deviation: the time stamps span no time");
  // The mean period measured from the time stamps, never a nominal rate (seed-summary s. 3).
  r.tau0_s = r.sampling.mean_period_s;
  r.uniform = r.sampling.is_uniform();
  r.factors = options.factors.empty()
                  ? log_spaced_factors(n, options.points_per_decade, options.max_factor)
                  : options.factors;
  for (int64_t m : r.factors) {
    if (m < 1 || 3 * m > n) {
      throw Error("Allan deviation: averaging factor " + std::to_string(m) +
                  " outside [1, n/3] for n = " + std::to_string(n));
    }
  }
  if (options.max_factor > 0 && options.factors.empty() && 3 * options.max_factor > n) {
    throw Error("Allan deviation: maximum averaging factor above n/3");
  }
  for (int64_t m : r.factors) r.tau_s.push_back(double(m) * r.tau0_s);
  if (!samples.allFinite()) throw Error("Allan deviation: the samples contain NaN or infinity");

  // Cumulative sums of the mean-free samples, Kahan-compensated.
  const Eigen::VectorXd mean = samples.rowwise().mean();
  std::vector<double> S(size_t(n + 1) * size_t(axes));
  {
    std::vector<double> sum(size_t(axes), 0.0), comp(size_t(axes), 0.0);
    for (int a = 0; a < axes; ++a) S[size_t(a)] = 0.0;
    for (int64_t i = 0; i < n; ++i) {
      for (int a = 0; a < axes; ++a) {
        const double y = (samples(a, i) - mean(a)) - comp[size_t(a)];
        const double tt = sum[size_t(a)] + y;
        comp[size_t(a)] = (tt - sum[size_t(a)]) - y;
        sum[size_t(a)] = tt;
        S[size_t(i + 1) * size_t(axes) + size_t(a)] = tt;
      }
    }
  }

  std::vector<Deviation> kinds;
  if (options.allan) kinds.push_back(Deviation::kAllan);
  if (options.modified) kinds.push_back(Deviation::kModifiedAllan);
  if (options.hadamard) kinds.push_back(Deviation::kHadamard);
  const size_t grid = r.factors.size();
  std::map<Deviation, Eigen::MatrixXd> variance;
  for (Deviation d : kinds) variance[d] = Eigen::MatrixXd::Zero(axes, Eigen::Index(grid));

  // Tasks (kind, factor), largest factors first; threads take the next task from a counter.
  struct Task {
    Deviation kind;
    size_t index;
  };
  std::vector<Task> tasks;
  for (size_t k = grid; k-- > 0;) {
    for (Deviation d : kinds) tasks.push_back({d, k});
  }
  std::atomic<size_t> next{0};
  auto worker = [&] {
    double out[16];
    for (size_t i = next.fetch_add(1); i < tasks.size(); i = next.fetch_add(1)) {
      const Task& task = tasks[i];
      pick(task.kind, axes)(S.data(), n, r.factors[task.index], axes, out);
      Eigen::MatrixXd& v = variance.at(task.kind);
      for (int a = 0; a < axes; ++a) v(a, Eigen::Index(task.index)) = out[a];
    }
  };
  unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  threads = unsigned(std::min<size_t>(threads, tasks.size()));
  if (threads <= 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    for (unsigned i = 0; i < threads; ++i) pool.emplace_back(worker);
    for (auto& th : pool) th.join();
  }

  // Noise type per (axis, tau) from the local log-log slope of the variance (ADEV's when
  // computed), over neighbours within +-0.25 decade.
  const Eigen::MatrixXd& slope_source =
      options.allan ? variance.at(Deviation::kAllan) : variance.at(kinds.front());
  Eigen::MatrixXi alpha(axes, Eigen::Index(grid));
  for (int a = 0; a < axes; ++a) {
    for (size_t k = 0; k < grid; ++k) {
      if (options.alpha) {
        alpha(a, Eigen::Index(k)) = *options.alpha;
        continue;
      }
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      int cnt = 0;
      const double lk = std::log10(r.tau_s[k]);
      for (size_t q = 0; q < grid; ++q) {
        const double lq = std::log10(r.tau_s[q]);
        const double v = slope_source(a, Eigen::Index(q));
        if (std::abs(lq - lk) <= 0.25 + 1e-12 && v > 0.0) {
          const double y = std::log10(v);
          sx += lq, sy += y, sxx += lq * lq, sxy += lq * y;
          ++cnt;
        }
      }
      const double den = cnt * sxx - sx * sx;
      const double mu = (cnt >= 2 && den > 0) ? (cnt * sxy - sx * sy) / den : -1.0;
      // ADEV's slope of -2 covers both white and flicker PM, which are treated alike.
      alpha(a, Eigen::Index(k)) = alpha_from_avar_slope(mu);
    }
  }

  for (Deviation d : kinds) {
    DeviationCurve& c = d == Deviation::kAllan           ? r.allan
                        : d == Deviation::kModifiedAllan ? r.modified
                                                         : r.hadamard;
    c.computed = true;
    const Eigen::MatrixXd& v = variance.at(d);
    c.deviation = v.cwiseMax(0.0).cwiseSqrt();
    c.lower.resize(axes, Eigen::Index(grid));
    c.upper.resize(axes, Eigen::Index(grid));
    c.edf.resize(axes, Eigen::Index(grid));
    c.alpha = alpha;
    for (size_t k = 0; k < grid; ++k) {
      c.terms.push_back(estimator_terms(d, n, r.factors[k]));
      std::map<int, double> edf_cache;
      for (int a = 0; a < axes; ++a) {
        const int al = alpha(a, Eigen::Index(k));
        auto it = edf_cache.find(al);
        if (it == edf_cache.end()) {
          it = edf_cache.emplace(al, equivalent_dof(d, n, r.factors[k], al)).first;
        }
        const double nu = it->second;
        const auto [lo, hi] = deviation_interval(c.deviation(a, Eigen::Index(k)), nu, options.confidence);
        c.edf(a, Eigen::Index(k)) = nu;
        c.lower(a, Eigen::Index(k)) = lo;
        c.upper(a, Eigen::Index(k)) = hi;
      }
    }
  }
  return r;
}

}  // namespace imukit::hwmodel
