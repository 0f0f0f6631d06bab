// Allan-family deviations of IMU rate signals: overlapping Allan deviation (ADEV), modified
// Allan deviation (MDEV) and overlapping Hadamard deviation (HDEV), per axis, on a log-spaced
// grid of averaging times, with confidence intervals from equivalent degrees of freedom.
//
// Definitions (IEEE Std 1139, NIST SP 1065 "Handbook of Frequency Stability Analysis", Riley
// 2008), for n rate samples y_i at the mean period tau0, averaging factor m, tau = m tau0, and
// S_k = sum_{i<k} y_i (so the "phase" is x_k = tau0 S_k):
//   AVAR(m) = 1/(2 m^2 (n+1-2m)) sum_{j=0}^{n-2m} (S_{j+2m} - 2 S_{j+m} + S_j)^2
//   MVAR(m) = 1/(2 m^4 (n+2-3m)) sum_{j=0}^{n+1-3m} (sum_{i=j}^{j+m-1} S_{i+2m} - 2 S_{i+m} +
//   S_i)^2 HVAR(m) = 1/(6 m^2 (n+1-3m)) sum_{j=0}^{n-3m} (S_{j+3m} - 3 S_{j+2m} + 3 S_{j+m} -
//   S_j)^2
// The cumulative sum makes each tau O(n) (MVAR's inner sum slides over j), and all axes share
// one pass: S is stored sample-major (all axes of one sample adjacent). The mean of each axis is
// removed before summing (differences of S do not change) and S is built with Kahan-compensated
// summation, so S stays small and exact to half an ulp per entry.
//
// Confidence intervals: nu * s^2 / sigma^2 ~ chi^2(nu) with nu the equivalent degrees of
// freedom of the estimator for the dominant power-law noise (frequency PSD ~ f^alpha; white FM
// alpha = 0 is the angle/velocity random walk N, flicker FM -1 bias instability, random-walk FM
// -2 rate random walk K, white PM 2 quantisation). nu is computed from the estimator's own
// correlation structure: for Gaussian terms z_j, nu = 2 E[s^2]^2 / Var[s^2]
// = M c_0^2 / sum_{|l|<M} (1 - |l|/M) c_l^2 with c_l the covariance of the terms at lag l,
// obtained from the generalised autocovariance of the phase of that noise (-|t| for white FM,
// t^2 ln|t| flicker FM, |t|^3 random-walk FM, a unit impulse for white PM); this is the quantity
// Greenhall & Riley (PTTI 2003) tabulate, and for ADEV it agrees with SP 1065 Table 5's simple
// formulas (tests/hwmodel/allan_test.cpp). The dominant alpha at each tau is read from the
// local slope of the measured curve unless the caller fixes it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "imukit/core/sampling.hpp"
#include "imukit/core/time.hpp"

namespace imukit::hwmodel {

enum class Deviation { kAllan, kModifiedAllan, kHadamard };

// Averaging factors m (in samples) spaced evenly in log10 with points_per_decade per decade from
// 1 to max_factor, rounded to integers and deduplicated. n samples; max_factor 0 means n / 4.
std::vector<int64_t> log_spaced_factors(int64_t n, int points_per_decade = 10,
                                        int64_t max_factor = 0);

struct AllanOptions {
  int points_per_decade = 10;
  int64_t max_factor = 0;        // 0: n / 4
  std::vector<int64_t> factors;  // explicit grid (overrides the two above); each in [1, n/3]
  bool allan = true;
  bool modified = true;
  bool hadamard = true;
  double confidence = 0.6826894921370859;  // two-sided, 1 sigma by default
  std::optional<int> alpha;                // fix the noise type for the intervals (2, 0, -1 or -2)
  unsigned threads = 0;                    // 0: std::thread::hardware_concurrency()
  // ADEV and HDEV factors up to this share one pass over the cumulative sums (each reads the
  // newest part from memory once between them, the rest from the cache); each larger one sweeps
  // them alone. 0: automatic (the factors whose 2m-sample window of all axes fits in 6 MB of
  // cache; 65,536 for 6 axes). A tuning knob only: results agree either way to rounding.
  int64_t shared_factor_limit = 0;
};

// One deviation over the grid: rows are axes, columns averaging factors.
struct DeviationCurve {
  bool computed = false;
  Eigen::MatrixXd deviation;  // unit of the input
  Eigen::MatrixXd lower;      // confidence interval bounds
  Eigen::MatrixXd upper;
  Eigen::MatrixXd edf;         // equivalent degrees of freedom
  Eigen::MatrixXi alpha;       // power-law noise type the interval assumed
  std::vector<int64_t> terms;  // number of squared differences in each estimate
};

struct AllanResult {
  // From the time stamps; tau0 = sampling.mean_period_s, or where samples are missing
  // (sampling.samples_missing()) sampling.mean_period_between_gaps_s: the samples either side
  // of a gap count as neighbours.
  SamplingStats sampling;
  double tau0_s = 0.0;
  bool uniform = true;  // false: time stamps jitter by more than 1 % of the median period
  std::vector<int64_t> factors;
  std::vector<double> tau_s;  // factors * tau0_s
  DeviationCurve allan, modified, hadamard;

  const DeviationCurve& curve(Deviation d) const {
    return d == Deviation::kAllan ? allan : d == Deviation::kModifiedAllan ? modified : hadamard;
  }
};

// Deviations of the rows of `samples` (axes x n, one column per sample) taken at times t (n
// entries, non-decreasing, ns). Throws imukit::Error for fewer than 8 samples, a zero duration,
// non-finite values or a factor outside [1, n/3].
AllanResult allan_deviation(std::span<const TimeNs> t,
                            const Eigen::Ref<const Eigen::MatrixXd>& samples,
                            const AllanOptions& options = {});

// The automatic AllanOptions::shared_factor_limit for `axes` axes: the largest factor whose
// 2m-sample window of the cumulative sums of all axes fits in 6 MB, at least 1024.
int64_t default_shared_factor_limit(int axes);

// Equivalent degrees of freedom of one estimate: n rate samples, factor m, noise exponent alpha
// in {2, 1, 0, -1, -2} (1, flicker PM, is treated as 2: it does not occur in the IMU model).
double equivalent_dof(Deviation kind, int64_t n, int64_t m, int alpha);

// Confidence interval [lower, upper] of a deviation `dev` with edf nu at two-sided `confidence`.
std::pair<double, double> deviation_interval(double dev, double nu, double confidence);

// Power-law noise type suggested by a log-log slope mu of the Allan *variance*
// (AVAR ~ tau^mu): mu <= -1.5 white PM (2), otherwise round(-mu - 1) clamped to [-2, 0].
int alpha_from_avar_slope(double mu);

}  // namespace imukit::hwmodel
