// Noise-model fit of an Allan deviation curve (IEEE Std 952 / 1293 Allan-variance model):
//
//   AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2
//
// Q quantisation (unit s), N white noise density (unit/sqrt(Hz), the angle or velocity random
// walk), B bias instability (unit), K rate random walk (unit/s/sqrt(Hz)), R rate ramp (unit/s).
// The squares are found by non-negative weighted least squares (Lawson & Hanson 1974, ch. 23)
// with weights 1/Var(AVAR_k) = nu_k / (2 AVAR_k^2) from the equivalent degrees of freedom of each
// estimate, re-weighted with the model's own values (weights taken from the noisy estimates bias
// a fit low). Terms the data do not support come out exactly zero instead of negative or
// invented: a white-noise-plus-random-walk curve still has a minimum of sqrt(2NK/sqrt3)/..., and
// reading "B = minimum / 0.664" there reports a bias instability that is not in the signal.
//
// The textbook slope readings are reported beside the fit for comparison: N where the curve's
// log-log slope is closest to -1/2 (line extended to tau = 1 s), K where it is closest to +1/2
// (read at tau = 3 s), B = minimum / 0.6643, Q on slope -1 at tau = sqrt 3, R on slope +1 at
// tau = sqrt 2. docs/hwmodel.md says which to trust.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace imukit::hwmodel {

enum NoiseTerm { kQuantization = 0, kWhite = 1, kBiasInstability = 2, kRandomWalk = 3, kRamp = 4 };
inline constexpr int kNoiseTerms = 5;
const char* noise_term_name(int term);  // "Q", "N", "B", "K", "R"

// sqrt(2 ln 2 / pi): the Allan deviation of the flicker floor is this times B.
inline constexpr double kFlickerFloorFactor = 0.6642824702679601;

// The model's Allan variance at tau for coefficients (Q, N, B, K, R).
double model_allan_variance(const std::array<double, kNoiseTerms>& coefficients, double tau_s);

struct NoiseFitOptions {
  std::array<bool, kNoiseTerms> terms = {true, true, true, true, true};  // which to fit
  double confidence = 0.95;  // of the reported intervals
  int reweight_iterations = 4;
  // Overlapping estimates at neighbouring taus are strongly correlated, which a least-squares
  // covariance ignores: the parameter covariance is multiplied by this factor for every grid
  // point per decade beyond one estimate per octave (see docs/hwmodel.md; measured by simulation).
  bool correct_for_correlation = true;
  // Only points with tau in [tau_min_s, tau_max_s] are fitted: a sensor's own filter, a
  // vibration or decimation shapes the curve at short tau in ways the model has no term for.
  double tau_min_s = 0.0;
  double tau_max_s = 1e300;
};

struct NoiseFit {
  std::array<double, kNoiseTerms> value{};  // Q, N, B, K, R (0 when not supported)
  std::array<double, kNoiseTerms> sigma{};  // 1-sigma, delta method on the fitted squares
  std::array<double, kNoiseTerms> lower{};  // interval at options.confidence
  std::array<double, kNoiseTerms> upper{};
  // Term detected: positive in the fit (the GLS fit also needs its interval to exclude 0;
  // an undetected term has value 0 and upper = its upper bound).
  std::array<bool, kNoiseTerms> active{};
  double chi2_per_dof = 0.0;          // of the last weighted fit
  int points = 0;                     // taus used
  double covariance_inflation = 1.0;  // correlation factor times max(1, chi2/dof)
  // Why selected terms were not fitted (empty when all were): a GLS fit on a short record's
  // curve, spanning fewer than kMinDecadesForAllTerms, fits N alone (the others' upper bounds
  // are then infinite).
  std::string note;
};

// A curve spanning fewer decades of tau cannot tell the five slopes apart (found in review: a
// 50-sample record of white noise "detected" Q or B and dropped N on a fifth of its axes).
inline constexpr double kMinDecadesForAllTerms = 2.0;

// Textbook readings off the curve, each with its 1-sigma from the estimate's interval.
struct SlopeReading {
  bool found = false;  // a part of the curve has a slope within 0.15 of the target
  double value = 0.0;
  double sigma = 0.0;
  double tau_s = 0.0;  // where it was read
  double slope = 0.0;  // the curve's local log-log slope there (NaN for the minimum's when a
                       // neighbour's deviation is zero)
};
struct SlopeReadings {
  SlopeReading quantization, white, bias_instability, random_walk, ramp;
};

// tau (s, increasing), adev and its equivalent degrees of freedom per tau (same length). Throws
// imukit::Error when fewer than 2 usable points remain (positive deviation, edf >= 1).
// This form treats the estimates as independent (weights from the edf, covariance inflated for
// the grid density); use it for curves whose raw data are not at hand.
NoiseFit fit_noise_model(const std::vector<double>& tau_s, const std::vector<double>& adev,
                         const std::vector<double>& edf, const NoiseFitOptions& options = {});

// Generalised least squares for a curve computed here (overlapping ADEV of n samples at the
// averaging factors `factors`): the full covariance of the Allan-variance estimates across taus
// is computed from the current model (each noise term's phase autocovariance, as in
// allan.hpp's edf, cross-correlated between the two factors), and the fit is whitened with it;
// then re-fitted with the new model's covariance. Neighbouring overlapping estimates are
// correlated (above 0.9 at 10 points per decade), so a fit that ignores it reports intervals
// several times too narrow and trades K against B where a random walk wanders. On a short
// record's curve (from its first tau) spanning fewer than kMinDecadesForAllTerms decades only N
// is fitted, and `note` says so; a span that tau_min_s cuts that short is an imukit::Error.
NoiseFit fit_noise_model_gls(const std::vector<double>& tau_s, const std::vector<double>& adev,
                             const std::vector<int64_t>& factors, int64_t n,
                             const NoiseFitOptions& options = {});

// Covariance of the overlapping Allan-variance estimates at factors m1, m2 (n samples, sample
// period tau0) when the signal's noise is the model `coefficients` (Q, N, B, K; R is treated
// as deterministic): the sum over every lag of the two second-difference series' squared
// cross-covariance, exact to rounding for Q, N and K and to 1e-9 relative with B, for any pair
// of factors, from a few hundred evaluations of the cross term per pair (growing as log n).
double allan_variance_covariance(const std::array<double, kNoiseTerms>& coefficients, double tau0_s,
                                 int64_t n, int64_t m1, int64_t m2);

// adev_lower/adev_upper: 1-sigma interval of each estimate (for the readings' uncertainties).
// Deviations that are zero or not finite are not read (no reading is ever NaN).
SlopeReadings read_slopes(const std::vector<double>& tau_s, const std::vector<double>& adev,
                          const std::vector<double>& adev_lower,
                          const std::vector<double>& adev_upper);

}  // namespace imukit::hwmodel
