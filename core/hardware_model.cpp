#include "imukit/core/hardware_model.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>

#include <fmt/format.h>

#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"

namespace imukit {
namespace {

// Allan variance of bias instability B: (2 ln2 / pi) B^2 (IEEE Std 952, Annex C).
constexpr double kFlickerAvarFactor = 2.0 * std::numbers::ln2 / std::numbers::pi;

// Samples per processing chunk: large enough to amortise the per-chunk work, small enough that
// a chunk's values and its noise draws stay in the L1 cache.
constexpr std::size_t kChunk = 256;

// Child-stream indices (ImuErrorGenerator's comment): 8 per triad, one per term.
enum Term : uint64_t {
  kTermTurnOn = 0,
  kTermWhite = 1,
  kTermRandomWalk = 2,
  kTermBiasInstability = 3
};

void fail(const std::string& what) { throw Error("hardware model: " + what); }

// Fails on the first element x of m (row-major) with !ok(x), naming it and what was `expected`.
template <class Ok>
void check_elements(const Eigen::Ref<const Eigen::MatrixXd>& m, const std::string& name, Ok ok,
                    std::string_view expected) {
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      if (!ok(m(r, c))) {
        fail(m.cols() == 1 ? fmt::format("{}[{}] is {}, {}", name, r, m(r, c), expected)
                           : fmt::format("{}[{}][{}] is {}, {}", name, r, c, m(r, c), expected));
      }
    }
  }
}

// Every model parameter: finite, and within HardwareModel::kMaxParameterMagnitude.
void check_finite(const Eigen::Ref<const Eigen::MatrixXd>& m, const std::string& name) {
  check_elements(
      m, name, [](double x) { return std::isfinite(x); }, "expected a finite number");
  check_elements(
      m, name, [](double x) { return std::abs(x) <= HardwareModel::kMaxParameterMagnitude; },
      fmt::format("beyond any sensor's (at most {:g} in magnitude)",
                  HardwareModel::kMaxParameterMagnitude));
}

void check_non_negative(const Eigen::Vector3d& v, const std::string& name) {
  check_finite(v, name);
  for (int i = 0; i < 3; ++i) {
    if (v[i] < 0.0) fail(fmt::format("{}[{}] is {}, expected >= 0", name, i, v[i]));
  }
}

void check_non_negative(double v, const std::string& name) {
  if (!std::isfinite(v) || v < 0.0)
    fail(fmt::format("{} is {}, expected a finite number >= 0", name, v));
}

void validate_triad(const TriadModel& t, const std::string& name, double rate_hz) {
  check_non_negative(t.noise_density, name + ".noise_density");
  check_non_negative(t.bias_instability, name + ".bias_instability");
  check_non_negative(t.random_walk, name + ".random_walk");
  check_finite(t.turn_on_bias_mean, name + ".turn_on_bias_mean");
  check_non_negative(t.turn_on_bias_spread, name + ".turn_on_bias_spread");
  check_finite(t.scale, name + ".scale");
  for (int i = 0; i < 3; ++i) {
    if (t.scale[i] == 0.0) fail(fmt::format("{}.scale[{}] is 0", name, i));
  }
  check_finite(t.misalignment, name + ".misalignment");
  for (int i = 0; i < 3; ++i) {
    if (std::abs(t.misalignment(i, i) - 1.0) > 1e-9) {
      fail(fmt::format(
          "{}.misalignment[{}][{}] is {}, expected 1 (the diagonal is unit; gains go in "
          "scale)",
          name, i, i, t.misalignment(i, i)));
    }
  }
  const double lo = t.bias_instability_tau_min_s;
  const double hi = t.bias_instability_tau_max_s;
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo <= 0.0 || hi <= lo || hi > 1e6 * lo ||
      hi > 1e9) {
    fail(
        fmt::format("{}: bias-instability band [{}, {}] s must satisfy 0 < tau_min < tau_max <= "
                    "min(1e6 tau_min, 1e9 s)",
                    name, lo, hi));
  }
  // The sampled bank is flat only when the band starts a few samples above the sample period
  // (within 3 % from 5 samples on; at 2 samples the deviation reaches 13 %).
  if (!t.bias_instability.isZero(0.0) && lo * rate_hz < 5.0) {
    fail(
        fmt::format("{}: bias-instability band starts at {} s, under 5 samples at {} Hz; raise "
                    "bias_instability_tau_min_s to at least {} s",
                    name, lo, rate_hz, 5.0 / rate_hz));
  }
  check_non_negative(t.range, name + ".range");
  check_non_negative(t.resolution, name + ".resolution");
  check_non_negative(t.bandwidth_hz, name + ".bandwidth_hz");
  check_non_negative(t.rate_hz, name + ".rate_hz");
  if (t.bandwidth_hz > 0.0 && !(t.bandwidth_hz < 0.5 * rate_hz)) {
    fail(
        fmt::format("{}.bandwidth_hz is {} Hz, must be below half the rate the model runs at "
                    "({} Hz)",
                    name, t.bandwidth_hz, 0.5 * rate_hz));
  }
}

void check_rate(double rate_hz, const char* name) {
  if (!std::isfinite(rate_hz) || rate_hz <= 0.0) {
    fail(fmt::format("{} rate is {} Hz, expected a positive number", name, rate_hz));
  }
}

// f(x) = 2x - 3 + 4 e^{-x} - e^{-2x}; below x = 0.05 the closed form loses digits to
// cancellation (f ~ 2x^3/3), so sum its Taylor series sum_{n>=3} (-1)^n (4 - 2^n) x^n / n!
// (12 terms reach double precision there).
double gauss_markov_bracket(double x) {
  if (x < 0.05) {
    double sum = 0.0;
    double power = x * x / 2.0;  // x^n / n! for n = 2
    for (int n = 3; n <= 14; ++n) {
      power *= x / n;
      const double coefficient = (n % 2 == 0 ? 1.0 : -1.0) * (4.0 - std::ldexp(1.0, n));
      sum += coefficient * power;
    }
    return sum;
  }
  return 2.0 * x - 3.0 + 4.0 * std::exp(-x) - std::exp(-2.0 * x);
}

}  // namespace

void validate_hardware_model(const HardwareModel& model, double rate_hz) {
  validate_hardware_model(model, SensorRates{rate_hz, rate_hz, rate_hz});
}

void validate_hardware_model(const HardwareModel& model, const SensorRates& rates) {
  check_rate(rates.accelerometer_hz, "accelerometer");
  check_rate(rates.gyroscope_hz, "gyroscope");
  check_rate(rates.magnetometer_hz, "magnetometer");
  validate_triad(model.accelerometer, "accelerometer", rates.accelerometer_hz);
  validate_triad(model.gyroscope, "gyroscope", rates.gyroscope_hz);
  check_finite(model.gyroscope.g_sensitivity, "gyroscope.g_sensitivity");
  validate_triad(model.magnetometer, "magnetometer", rates.magnetometer_hz);
  check_finite(model.magnetometer.hard_iron, "magnetometer.hard_iron");
  check_finite(model.magnetometer.soft_iron, "magnetometer.soft_iron");
  // The clock: a crystal is off by tens of ppm; 1 % is a broken device, not a clock error. Jitter
  // above a tenth of the period would reorder samples (the simulator clips draws at 0.45 periods).
  if (!(std::abs(model.clock.error_ppm) <= ClockModel::kMaxErrorPpm))
    fail(fmt::format("clock.error_ppm is {}, expected a finite number within +-{:g} ppm",
                     model.clock.error_ppm, ClockModel::kMaxErrorPpm));
  const double fastest =
      std::max({rates.accelerometer_hz, rates.gyroscope_hz, rates.magnetometer_hz});
  if (!(model.clock.jitter_s >= 0.0 && std::isfinite(model.clock.jitter_s)) ||
      (fastest > 0.0 && model.clock.jitter_s > 0.1 / fastest)) {
    fail(
        fmt::format("clock.jitter_s is {} s, expected >= 0 and at most a tenth of the sample "
                    "period at the fastest rate the model runs at ({} Hz: {:.3g} s)",
                    model.clock.jitter_s, fastest, 0.1 / fastest));
  }
}

bool is_ideal(const TriadModel& t) {
  return t.noise_density.isZero(0.0) && t.bias_instability.isZero(0.0) &&
         t.random_walk.isZero(0.0) && t.turn_on_bias_mean.isZero(0.0) &&
         t.turn_on_bias_spread.isZero(0.0) && t.scale == Eigen::Vector3d::Ones() &&
         t.misalignment == Eigen::Matrix3d::Identity() && t.range == 0.0 && t.resolution == 0.0 &&
         t.bandwidth_hz == 0.0;
}

bool is_ideal(const GyroscopeModel& g) {
  return is_ideal(static_cast<const TriadModel&>(g)) && g.g_sensitivity.isZero(0.0);
}

bool is_ideal(const MagnetometerModel& m) {
  return is_ideal(static_cast<const TriadModel&>(m)) && m.hard_iron.isZero(0.0) &&
         m.soft_iron == Eigen::Matrix3d::Identity();
}

double gauss_markov_allan_variance(double variance, double correlation_time_s, double tau_s) {
  assert(correlation_time_s > 0.0 && tau_s > 0.0);
  const double x = tau_s / correlation_time_s;
  return variance * gauss_markov_bracket(x) / (x * x);
}

double gauss_markov_allan_variance_discrete(double variance, double correlation_time_s, double dt_s,
                                            int64_t m) {
  assert(correlation_time_s > 0.0 && dt_s > 0.0 && m >= 1);
  // With a = phi = e^{-h}, h = dt/T, and Q(n) = sum_{|d|<n} (n - |d|) a^|d|
  // = (n (1 - a^2) - 2 a (1 - a^n)) / (1 - a)^2 the variance of a sum of n samples (in units of
  // the process variance), the Allan difference of two adjacent sums of m has variance
  // 4 Q(m) - Q(2m), so AVAR = variance (4 Q(m) - Q(2m)) / (2 m^2)
  //                         = variance (m (1 - a^2) - a v (2 + v)) / (m^2 (1 - a)^2), v = 1 - a^m.
  // The numerator N cancels to O((m h)^3) when m h is small; there its Taylor series in h,
  // N = sum_{k>=3} (-1)^k (4 (m+1)^k - (2m+1)^k - m 2^k - 3) h^k / k! (the k = 0, 1, 2 terms
  // vanish), converges fast because (2m+1) h < 0.4.
  const double h = dt_s / correlation_time_s;
  const double md = static_cast<double>(m);
  const double u = -std::expm1(-h);  // 1 - a
  if (u == 0.0) return 0.0;
  double numerator = 0.0;
  if (md * h < 0.1) {
    double h_power = h * h / 2.0;  // h^k / k! for k = 2
    double p1 = (md + 1.0) * (md + 1.0);
    double p2 = (2.0 * md + 1.0) * (2.0 * md + 1.0);
    double p3 = 4.0;
    for (int k = 3; k <= 60; ++k) {
      h_power *= h / k;
      p1 *= md + 1.0;
      p2 *= 2.0 * md + 1.0;
      p3 *= 2.0;
      const double term = (k % 2 == 0 ? 1.0 : -1.0) * (4.0 * p1 - p2 - md * p3 - 3.0) * h_power;
      numerator += term;
      if (std::abs(term) <= 1e-18 * std::abs(numerator)) break;
    }
  } else {
    const double v = -std::expm1(-md * h);
    numerator = md * -std::expm1(-2.0 * h) - std::exp(-h) * v * (2.0 + v);
  }
  return variance * std::max(numerator, 0.0) / (md * md * u * u);
}

GaussMarkovBank GaussMarkovBank::design(double bias_instability, double tau_min_s, double tau_max_s,
                                        double rate_hz) {
  assert(tau_min_s > 0.0 && tau_max_s > tau_min_s && bias_instability >= 0.0 && rate_hz >= 0.0);
  // Correlation times: one per decade, from a decade below the band to half a decade above it
  // (a process's Allan-variance bump rises as tau/T below its peak at 1.89 T and falls as T/tau
  // above it, so the band's lower edge needs the longer reach).
  const double a = std::log10(tau_min_s) - 1.0;
  const double b = std::log10(tau_max_s) + 0.5;
  const int count = static_cast<int>(std::ceil(b - a)) + 1;
  GaussMarkovBank bank;
  for (int j = 0; j < count; ++j) {
    bank.correlation_time_s_.push_back(std::pow(10.0, a + (b - a) * j / (count - 1)));
  }
  bank.sigma_.assign(count, 1.0);

  // Unit-variance Allan variance over the band on a 1/20-decade grid.
  const double decades = std::log10(tau_max_s / tau_min_s);
  const int steps = std::max(2, static_cast<int>(std::ceil(20.0 * decades)));
  double lowest = INFINITY;
  double highest = 0.0;
  for (int i = 0; i <= steps; ++i) {
    const double tau = tau_min_s * std::pow(tau_max_s / tau_min_s, static_cast<double>(i) / steps);
    double avar = 0.0;
    if (rate_hz > 0.0) {
      const auto m = std::max<int64_t>(1, std::llround(tau * rate_hz));
      avar = bank.allan_variance_discrete(1.0 / rate_hz, m);
    } else {
      avar = bank.allan_variance(tau);
    }
    lowest = std::min(lowest, avar);
    highest = std::max(highest, avar);
  }
  const double target = kFlickerAvarFactor * bias_instability * bias_instability;
  const double sigma = std::sqrt(target / std::sqrt(lowest * highest));
  bank.sigma_.assign(count, sigma);
  return bank;
}

double GaussMarkovBank::allan_variance(double tau_s) const {
  double sum = 0.0;
  for (std::size_t j = 0; j < sigma_.size(); ++j) {
    sum += gauss_markov_allan_variance(sigma_[j] * sigma_[j], correlation_time_s_[j], tau_s);
  }
  return sum;
}

double GaussMarkovBank::allan_variance_discrete(double dt_s, int64_t m) const {
  double sum = 0.0;
  for (std::size_t j = 0; j < sigma_.size(); ++j) {
    sum += gauss_markov_allan_variance_discrete(sigma_[j] * sigma_[j], correlation_time_s_[j], dt_s,
                                                m);
  }
  return sum;
}

// One triad's generator state. Terms that are off keep their flag false and cost nothing.
struct ImuErrorGenerator::Triad {
  Triad(const TriadModel& model, const Eigen::Matrix3d& signal_matrix,
        const Eigen::Matrix3d& g_sensitivity, const Eigen::Vector3d& hard_iron, double rate_hz,
        const Rng& base, uint64_t triad_index);

  void apply(double* y, const double* true_specific_force, std::size_t n);

  bool ideal = true;

  bool use_matrix = false;
  Eigen::Matrix3d matrix = Eigen::Matrix3d::Identity();
  bool use_g = false;
  Eigen::Matrix3d g_sensitivity = Eigen::Matrix3d::Zero();

  // Second-order Butterworth low-pass by the bilinear transform with the cutoff pre-warped
  // (K = tan(pi fc / fs)), so its gain at fc is exactly 1/sqrt(2) (-3.01 dB) and at DC exactly 1:
  // H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2), run in transposed direct form II.
  bool use_lpf = false;
  double b0 = 1.0, b1 = 0.0, b2 = 0.0, a1 = 0.0, a2 = 0.0;
  double z1[3] = {0.0, 0.0, 0.0};
  double z2[3] = {0.0, 0.0, 0.0};
  bool lpf_primed = false;

  bool use_constant = false;
  Eigen::Vector3d constant = Eigen::Vector3d::Zero();

  bool use_white = false;
  double white_sigma[3] = {0.0, 0.0, 0.0};
  Rng white_rng;

  bool use_random_walk = false;
  double random_walk_step[3] = {0.0, 0.0, 0.0};
  double random_walk_state[3] = {0.0, 0.0, 0.0};
  Rng random_walk_rng;

  // Bias instability: processes p = 0..P-1 per axis, x[k+1] = phi_p x[k] + q_{a,p} w.
  std::size_t bank_size = 0;
  std::vector<double> bank_phi;         // P
  std::vector<double> bank_innovation;  // 3 P, axis-major: sqrt(1 - phi^2) sigma_p B_a
  std::vector<double> bank_state;       // 3 P, axis-major
  Rng bank_rng;

  double range = 0.0;
  double resolution = 0.0;

  std::vector<double> draws;
};

ImuErrorGenerator::Triad::Triad(const TriadModel& model, const Eigen::Matrix3d& signal_matrix,
                                const Eigen::Matrix3d& g, const Eigen::Vector3d& hard_iron,
                                double rate_hz, const Rng& base, uint64_t triad_index)
    : white_rng(base.child(8 * triad_index + kTermWhite)),
      random_walk_rng(base.child(8 * triad_index + kTermRandomWalk)),
      bank_rng(base.child(8 * triad_index + kTermBiasInstability)) {
  const double dt = 1.0 / rate_hz;

  use_matrix = signal_matrix != Eigen::Matrix3d::Identity();
  matrix = signal_matrix;
  use_g = !g.isZero(0.0);
  g_sensitivity = g;

  if (model.bandwidth_hz > 0.0) {
    use_lpf = true;
    const double k = std::tan(std::numbers::pi * model.bandwidth_hz / rate_hz);
    const double sqrt2 = std::numbers::sqrt2;
    const double norm = 1.0 / (1.0 + sqrt2 * k + k * k);
    b0 = k * k * norm;
    b1 = 2.0 * b0;
    b2 = b0;
    a1 = 2.0 * (k * k - 1.0) * norm;
    a2 = (1.0 - sqrt2 * k + k * k) * norm;
  }

  constant = hard_iron;
  if (!model.turn_on_bias_spread.isZero(0.0)) {
    Rng turn_on = base.child(8 * triad_index + kTermTurnOn);
    for (int a = 0; a < 3; ++a)
      constant[a] += turn_on.normal(model.turn_on_bias_mean[a], model.turn_on_bias_spread[a]);
  } else {
    constant += model.turn_on_bias_mean;
  }
  use_constant = !constant.isZero(0.0);

  if (!model.noise_density.isZero(0.0)) {
    use_white = true;
    for (int a = 0; a < 3; ++a) {
      white_sigma[a] = discrete_white_noise_sigma(model.noise_density[a], rate_hz);
    }
  }
  if (!model.random_walk.isZero(0.0)) {
    use_random_walk = true;
    for (int a = 0; a < 3; ++a) {
      random_walk_step[a] = discrete_random_walk_sigma(model.random_walk[a], rate_hz);
    }
  }
  if (!model.bias_instability.isZero(0.0)) {
    // A unit bank (B = 1) scaled per axis; the processes start in their stationary distribution
    // so the Allan floor holds from the first sample.
    const GaussMarkovBank unit = GaussMarkovBank::design(1.0, model.bias_instability_tau_min_s,
                                                         model.bias_instability_tau_max_s, rate_hz);
    bank_size = unit.sigmas().size();
    bank_phi.resize(bank_size);
    bank_innovation.resize(3 * bank_size);
    bank_state.resize(3 * bank_size);
    for (std::size_t p = 0; p < bank_size; ++p) {
      const double h = dt / unit.correlation_times_s()[p];
      bank_phi[p] = std::exp(-h);
      const double innovation = std::sqrt(-std::expm1(-2.0 * h));  // sqrt(1 - phi^2)
      for (int a = 0; a < 3; ++a) {
        const double sigma = unit.sigmas()[p] * model.bias_instability[a];
        bank_innovation[a * bank_size + p] = innovation * sigma;
        bank_state[a * bank_size + p] = sigma * bank_rng.normal();
      }
    }
  }

  range = model.range;
  resolution = model.resolution;
  ideal = !use_matrix && !use_g && !use_lpf && !use_constant && !use_white && !use_random_walk &&
          bank_size == 0 && range == 0.0 && resolution == 0.0;
}

void ImuErrorGenerator::Triad::apply(double* y, const double* force, std::size_t n) {
  if (ideal || n == 0) return;
  for (std::size_t begin = 0; begin < n; begin += kChunk) {
    const std::size_t count = std::min(kChunk, n - begin);
    double* block = y + 3 * begin;
    const double* block_force = use_g ? force + 3 * begin : nullptr;

    if (use_matrix || use_g) {
      for (std::size_t i = 0; i < count; ++i) {
        Eigen::Map<Eigen::Vector3d> column(block + 3 * i);
        Eigen::Vector3d signal =
            use_matrix ? Eigen::Vector3d(matrix * column) : Eigen::Vector3d(column);
        if (use_g)
          signal.noalias() +=
              g_sensitivity * Eigen::Map<const Eigen::Vector3d>(block_force + 3 * i);
        column = signal;
      }
    }

    if (use_lpf) {
      if (!lpf_primed) {
        // Steady state for a constant input equal to the first sample (the sensor was on
        // before the stream began), so a still device reads its value from the first sample.
        for (int a = 0; a < 3; ++a) {
          z1[a] = (1.0 - b0) * block[a];
          z2[a] = (b2 - a2) * block[a];
        }
        lpf_primed = true;
      }
      for (int a = 0; a < 3; ++a) {
        double s1 = z1[a];
        double s2 = z2[a];
        for (std::size_t i = 0; i < count; ++i) {
          const double x = block[3 * i + a];
          const double out = b0 * x + s1;
          s1 = b1 * x - a1 * out + s2;
          s2 = b2 * x - a2 * out;
          block[3 * i + a] = out;
        }
        z1[a] = s1;
        z2[a] = s2;
      }
    }

    if (use_constant) {
      for (std::size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) block[3 * i + a] += constant[a];
      }
    }

    if (use_random_walk) {
      draws.resize(3 * count);
      random_walk_rng.fill_normal(draws);
      for (std::size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) {
          block[3 * i + a] += random_walk_state[a];
          random_walk_state[a] += random_walk_step[a] * draws[3 * i + a];
        }
      }
    }

    if (bank_size > 0) {
      const std::size_t p_count = bank_size;
      draws.resize(3 * p_count * count);
      bank_rng.fill_normal(draws);
      const double* w = draws.data();
      for (std::size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) {
          double* state = bank_state.data() + a * p_count;
          const double* q = bank_innovation.data() + a * p_count;
          double sum = 0.0;
          for (std::size_t p = 0; p < p_count; ++p) {
            sum += state[p];
            state[p] = bank_phi[p] * state[p] + q[p] * w[p];
          }
          w += p_count;
          block[3 * i + a] += sum;
        }
      }
    }

    if (use_white) {
      draws.resize(3 * count);
      white_rng.fill_normal(draws);
      for (std::size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) block[3 * i + a] += white_sigma[a] * draws[3 * i + a];
      }
    }

    saturate_and_quantise(std::span<double>(block, 3 * count), range, resolution);
  }
}

void saturate_and_quantise(std::span<double> values, double range, double resolution) {
  if (range > 0.0)
    for (double& v : values) v = std::clamp(v, -range, range);
  if (resolution > 0.0) {
    // Round to the nearest LSB, ties away from zero (std::round does not depend on the
    // floating-point rounding mode).
    // A value of 2^52 LSBs or more is already on the grid (and a tiny LSB would overflow
    // the quotient to infinity): it stays as it is.
    for (double& v : values) {
      const double steps = v / resolution;
      if (std::abs(steps) < 0x1p52) v = resolution * std::round(steps);
    }
    // A range that is not a whole number of LSBs rounded a saturated reading outwards, past
    // full scale (range 1, LSB 0.4: 1.2; found in review, 2026-11-27). Readings stay on the
    // largest grid value inside the range (the range itself when it is a whole number).
    if (range > 0.0) {
      const double limit = resolution * std::floor(range / resolution * (1.0 + 1e-12));
      for (double& v : values) v = std::clamp(v, -limit, limit);
    }
  }
}

ImuErrorGenerator::ImuErrorGenerator(const HardwareModel& model, double rate_hz, Rng& rng)
    : ImuErrorGenerator(model, SensorRates{rate_hz, rate_hz, rate_hz}, rng) {}

ImuErrorGenerator::ImuErrorGenerator(const HardwareModel& model, const SensorRates& rates,
                                     Rng& rng) {
  validate_hardware_model(model, rates);
  const Rng base(rng.next_u64());
  triads_.reserve(3);
  triads_.emplace_back(model.accelerometer, model.accelerometer.signal_matrix(),
                       Eigen::Matrix3d::Zero(), Eigen::Vector3d::Zero(), rates.accelerometer_hz,
                       base, 0);
  triads_.emplace_back(model.gyroscope, model.gyroscope.signal_matrix(),
                       model.gyroscope.g_sensitivity, Eigen::Vector3d::Zero(), rates.gyroscope_hz,
                       base, 1);
  triads_.emplace_back(model.magnetometer, model.magnetometer.signal_matrix(),
                       Eigen::Matrix3d::Zero(), model.magnetometer.hard_iron, rates.magnetometer_hz,
                       base, 2);
}

ImuErrorGenerator::~ImuErrorGenerator() = default;
ImuErrorGenerator::ImuErrorGenerator(ImuErrorGenerator&&) noexcept = default;
ImuErrorGenerator& ImuErrorGenerator::operator=(ImuErrorGenerator&&) noexcept = default;

// The triads walk the samples through raw pointers, 3 doubles per column: Ref<Matrix3Xd> also
// binds to blocks of taller matrices, which would not be laid out that way.
#define IMUKIT_ASSERT_PACKED(m) assert((m).cols() == 0 || (m).outerStride() == 3)

void ImuErrorGenerator::apply_accelerometer(Eigen::Ref<Eigen::Matrix3Xd> specific_force) {
  IMUKIT_ASSERT_PACKED(specific_force);
  triads_[0].apply(specific_force.data(), nullptr, static_cast<std::size_t>(specific_force.cols()));
}

void ImuErrorGenerator::apply_gyroscope(
    Eigen::Ref<Eigen::Matrix3Xd> angular_rate,
    const Eigen::Ref<const Eigen::Matrix3Xd>& true_specific_force) {
  IMUKIT_ASSERT_PACKED(angular_rate);
  IMUKIT_ASSERT_PACKED(true_specific_force);
  Triad& gyro = triads_[1];
  if (gyro.use_g && true_specific_force.cols() != angular_rate.cols())
    throw Error(fmt::format(
        "hardware model: the gyroscope's g-sensitivity needs one specific force per sample: {} "
        "for {} samples",
        true_specific_force.cols(), angular_rate.cols()));
  gyro.apply(angular_rate.data(), gyro.use_g ? true_specific_force.data() : nullptr,
             static_cast<std::size_t>(angular_rate.cols()));
}

void ImuErrorGenerator::apply_magnetometer(Eigen::Ref<Eigen::Matrix3Xd> field) {
  IMUKIT_ASSERT_PACKED(field);
  triads_[2].apply(field.data(), nullptr, static_cast<std::size_t>(field.cols()));
}

void ImuErrorGenerator::apply(ImuSeries& series) {
  // The gyroscope's g-sensitivity reads the true specific force (an assertion only, until a
  // review of 2026-11-27 found a gyro-only series aborting the process).
  if (series.has_gyro() && triads_[1].use_g && !series.has_accel())
    throw Error(
        "hardware model: the gyroscope's g-sensitivity needs the accelerometer's samples; the "
        "series has none");
  if (series.has_gyro()) apply_gyroscope(series.gyro, series.accel);
  if (series.has_accel()) apply_accelerometer(series.accel);
  if (series.has_mag()) apply_magnetometer(series.mag);
}

Eigen::Vector3d ImuErrorGenerator::accelerometer_constant_bias() const {
  return triads_[0].constant;
}
Eigen::Vector3d ImuErrorGenerator::gyroscope_constant_bias() const { return triads_[1].constant; }
Eigen::Vector3d ImuErrorGenerator::magnetometer_constant_bias() const {
  return triads_[2].constant;
}

}  // namespace imukit
