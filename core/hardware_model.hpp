// HardwareModel: the error parameters of an IMU's accelerometer, gyroscope and (optionally)
// magnetometer, and ImuErrorGenerator, which turns true signals into what such a sensor reports:
//
//   y = Q(S(LPF(M x + G a) + c + b_rw(t) + b_bi(t) + n(t)))
//
// with M = diag(scale) * misalignment (the magnetometer also multiplies by its soft-iron matrix),
// G the gyroscope's g-sensitivity times the true specific force a, LPF the sensor's low-pass
// filter, c the constant bias (turn-on bias drawn once per generator, plus the magnetometer's
// hard-iron offset), b_rw a random walk (rate random walk K), b_bi the bias instability (a bank of
// Gauss-Markov processes with a flat Allan floor at 0.664 B), n white noise (density N), S
// saturation at +-range and Q rounding to the nearest multiple of the resolution.
//
// The noise terms follow IEEE Std 952's Allan-variance model
// AVAR(tau) = N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 (seed-summary section 3).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "imukit/core/rng.hpp"

namespace imukit {

struct ImuSeries;

// Error parameters of one three-axis sensor. Units are those of the sensor's quantity ("unit":
// m/s^2, rad/s or T). Defaults describe an ideal sensor.
struct TriadModel {
  Eigen::Vector3d noise_density = Eigen::Vector3d::Zero();     // N, unit/sqrt(Hz)
  Eigen::Vector3d bias_instability = Eigen::Vector3d::Zero();  // B, unit (Allan floor 0.664 B)
  Eigen::Vector3d random_walk = Eigen::Vector3d::Zero();       // K, unit/s/sqrt(Hz)
  // Band of averaging times (s) over which the simulated Allan deviation stays at 0.664 B
  // (flat within 10 %, see GaussMarkovBank); below it the deviation falls as sqrt(tau), above
  // it as 1/sqrt(tau). Default: two decades around 100 s, where MEMS floors usually lie.
  double bias_instability_tau_min_s = 10.0;
  double bias_instability_tau_max_s = 1000.0;
  Eigen::Vector3d turn_on_bias_mean = Eigen::Vector3d::Zero();    // unit
  Eigen::Vector3d turn_on_bias_spread = Eigen::Vector3d::Zero();  // 1-sigma, unit
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();                // dimensionless
  // Unit diagonal; off-diagonal entries are small angles (rad): row i says how much of the true
  // axes j != i leak into output axis i. The signal matrix is M = diag(scale) * misalignment.
  Eigen::Matrix3d misalignment = Eigen::Matrix3d::Identity();
  double range = 0.0;         // saturation at +-range (unit); 0 = none
  double resolution = 0.0;    // LSB (unit); 0 = no quantisation
  double bandwidth_hz = 0.0;  // -3 dB frequency of the sensor's low-pass; 0 = none
  double rate_hz = 0.0;       // the sensor's output data rate; 0 = not stated

  Eigen::Matrix3d signal_matrix() const { return scale.asDiagonal() * misalignment; }
};

struct GyroscopeModel : TriadModel {
  // Sensitivity to specific force, (rad/s) per (m/s^2): adds G a to the angular rate.
  Eigen::Matrix3d g_sensitivity = Eigen::Matrix3d::Zero();
};

struct MagnetometerModel : TriadModel {
  Eigen::Vector3d hard_iron = Eigen::Vector3d::Zero();  // constant field of the device, T
  // Soft-iron distortion (dimensionless), applied before scale and misalignment:
  // signal = diag(scale) * misalignment * soft_iron * field.
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();

  Eigen::Matrix3d signal_matrix() const { return TriadModel::signal_matrix() * soft_iron; }
};

// The device's sample clock (used by the simulator, which decides when samples are taken;
// ImuErrorGenerator ignores it): the device believes it samples at the nominal rate f, but its
// clock runs (1 + error_ppm 1e-6) times as fast as true time, so sample k is taken at true time
// k / (f (1 + error_ppm 1e-6)) plus a white timing jitter of 1-sigma jitter_s, while the device
// stamps it k / f.
struct ClockModel {
  // A crystal is off by tens of ppm; beyond this, a broken device (validate_hardware_model and
  // the profile reader refuse it).
  static constexpr double kMaxErrorPpm = 1e4;
  double error_ppm = 0.0;  // frequency error of the device clock, ppm (+ = runs fast)
  double jitter_s = 0.0;   // 1-sigma jitter of each sample instant, s
  bool ideal() const { return error_ppm == 0.0 && jitter_s == 0.0; }
};

struct HardwareModel {
  // Above this magnitude (of the sensor's unit, or as a gain) a parameter describes no sensor,
  // and the simulated samples could overflow to infinity without a word (noise density 1e300
  // did). The profile reader refuses it at the file's key, validate_hardware_model in any model.
  static constexpr double kMaxParameterMagnitude = 1e12;
  TriadModel accelerometer;        // m/s^2
  GyroscopeModel gyroscope;        // rad/s
  MagnetometerModel magnetometer;  // T
  ClockModel clock;
};

// Which rate each triad's generator runs at (Hz). The gyroscope's g-sensitivity needs the true
// specific force at the gyroscope's sample times, whatever the accelerometer's rate.
struct SensorRates {
  double accelerometer_hz = 0.0;
  double gyroscope_hz = 0.0;
  double magnetometer_hz = 0.0;
};

// Throws imukit::Error naming the offending field (e.g. "gyroscope.noise_density[2]") for
// non-finite or negative parameters (a clock error beyond +-1e4 ppm or a jitter above a tenth of
// the fastest rate's period included), a misalignment without unit diagonal, a bias-instability
// band that is empty, wider than 6 decades, reaching past 1e9 s or (with B > 0) starting under
// 5 samples, or a bandwidth at or above the Nyquist frequency of the rate the generator will
// run at.
void validate_hardware_model(const HardwareModel& model, double rate_hz);
void validate_hardware_model(const HardwareModel& model, const SensorRates& rates);

// True when the triad changes nothing: apply() copies the input through.
bool is_ideal(const TriadModel& triad);
bool is_ideal(const GyroscopeModel& gyro);
bool is_ideal(const MagnetometerModel& mag);

// Kalibr's discrete-time noise values for a filter running at rate_hz (seed-summary section 3):
// sigma_d = N sqrt(f) is also the per-sample white-noise sigma the generator uses, and
// sigma_bd = K / sqrt(f) = K sqrt(dt) its random-walk step.
inline double discrete_white_noise_sigma(double noise_density, double rate_hz) {
  return noise_density * std::sqrt(rate_hz);
}
inline double discrete_random_walk_sigma(double random_walk, double rate_hz) {
  return random_walk / std::sqrt(rate_hz);
}

// Allan variance of a first-order Gauss-Markov process with stationary variance `variance` and
// correlation time T (autocovariance R(d) = variance exp(-|d|/T)), averaged over continuous
// windows of length tau: (variance T^2/tau^2) (2 tau/T - 3 + 4 e^{-tau/T} - e^{-2 tau/T}).
// A Taylor series replaces the bracket when tau/T is small, where the closed form cancels.
double gauss_markov_allan_variance(double variance, double correlation_time_s, double tau_s);

// The same for the sampled process (exact AR(1): x[k+1] = phi x[k] + sqrt(1-phi^2) s w,
// phi = exp(-dt/T)), overlapping Allan variance of averages of m samples (tau = m dt), from the
// variance of sums of n samples Q(n) = sum_{|d|<n} (n-|d|) phi^|d|: variance (4 Q(m) - Q(2m)) /
// (2 m^2) (derivation and the series used for small m dt/T in the source).
double gauss_markov_allan_variance_discrete(double variance, double correlation_time_s, double dt_s,
                                            int64_t m);

// A sum of independent first-order Gauss-Markov processes with log-spaced correlation times
// (one per decade, from a decade below the band to half a decade above it) and equal
// variances: the bumps of their Allan variances (each peaks near tau = 1.89 T) add up to a floor
// flat within 1.5 % over [tau_min, tau_max] (10 % is promised; 3 % for the sampled processes
// when tau_min is as short as 5 samples, the least the generator accepts), like the flicker
// floor of a real sensor. The variances are scaled so that the floor's geometric mid-point (the
// square root of its highest and lowest value on a 1/20-decade grid over the band) is (2 ln2/pi)
// B^2, the Allan variance of bias instability B.
class GaussMarkovBank {
 public:
  // rate_hz > 0 scales with the Allan variance of the sampled processes at that rate (what the
  // generator produces); rate_hz == 0 scales with the continuous-time formula.
  static GaussMarkovBank design(double bias_instability, double tau_min_s, double tau_max_s,
                                double rate_hz = 0.0);

  const std::vector<double>& correlation_times_s() const { return correlation_time_s_; }
  const std::vector<double>& sigmas() const { return sigma_; }  // stationary 1-sigma each

  double allan_variance(double tau_s) const;
  double allan_variance_discrete(double dt_s, int64_t m) const;

 private:
  std::vector<double> correlation_time_s_;
  std::vector<double> sigma_;
};

// The generator's last two steps, S and Q above, on any readings: saturation at +-range, then
// rounding to the nearest multiple of resolution (ties away from zero), the readings kept on the
// largest multiple inside the range. 0 switches either off.
void saturate_and_quantise(std::span<double> values, double range, double resolution);

// Applies a HardwareModel to blocks of true samples, in place, as a stream: applying block after
// block gives bit for bit what one big block gives. Construction draws the turn-on biases and
// the bias-instability processes' initial (stationary) states.
//
// Randomness: the constructor takes exactly one 64-bit draw from the caller's Rng and seeds the
// generator's own base stream with it, so two generators built from the same Rng differ and the
// caller's next draws do not depend on the model. Each noise term of each triad then draws from
// its own child stream of that base (Rng::child(8 * triad + term)), and terms whose parameters
// are all zero draw nothing: turning one term on or off leaves every other term's values
// unchanged for the same seed. Within a term, draws are taken sample by sample, x-y-z (the bias
// instability: sample, axis, then process), so block boundaries do not matter.
class ImuErrorGenerator {
 public:
  ImuErrorGenerator(const HardwareModel& model, double rate_hz, Rng& rng);
  ImuErrorGenerator(const HardwareModel& model, const SensorRates& rates, Rng& rng);
  ~ImuErrorGenerator();
  ImuErrorGenerator(ImuErrorGenerator&&) noexcept;
  ImuErrorGenerator& operator=(ImuErrorGenerator&&) noexcept;

  // Accelerometer: true specific force (m/s^2, 3 x n) in, measured out.
  void apply_accelerometer(Eigen::Ref<Eigen::Matrix3Xd> specific_force);
  // Gyroscope: true angular rate (rad/s) in, measured out. true_specific_force (same columns)
  // feeds the g-sensitivity; it may have 0 columns when the model's g_sensitivity is zero.
  void apply_gyroscope(Eigen::Ref<Eigen::Matrix3Xd> angular_rate,
                       const Eigen::Ref<const Eigen::Matrix3Xd>& true_specific_force);
  // Magnetometer: true field (T) in, measured out.
  void apply_magnetometer(Eigen::Ref<Eigen::Matrix3Xd> field);
  // Every channel the series has, gyroscope first (it needs the true specific force).
  void apply(ImuSeries& series);

  // The constant bias each triad got at construction (turn-on bias, plus hard iron for the
  // magnetometer).
  Eigen::Vector3d accelerometer_constant_bias() const;
  Eigen::Vector3d gyroscope_constant_bias() const;
  Eigen::Vector3d magnetometer_constant_bias() const;

 private:
  struct Triad;
  std::vector<Triad> triads_;  // accelerometer, gyroscope, magnetometer
};

}  // namespace imukit
