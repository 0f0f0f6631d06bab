// Device profile: what imukit knows about one IMU (noise, turn-on bias, calibration, limits), as
// the JSON file `imukit.profile/1` described in docs/formats.md. `characterize` and `calibrate`
// each fill their own sections of the same file (update_profile keeps the rest, including keys
// this version does not know), and the simulator turns a profile into a HardwareModel.
//
// All numbers are SI (m/s^2, rad/s, T, s, Hz, rad). Every section is optional; a section that
// is present is complete (its required fields are there and valid).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/hardware_model.hpp"
#include "imukit/core/rng.hpp"

namespace imukit {

inline constexpr std::string_view kProfileSchema = "imukit.profile/1";

struct DeviceInfo {
  std::string vendor;
  std::string model;
  std::string serial;
  std::string name;  // what the user calls it ("left wrist", "unit 3")
  bool operator==(const DeviceInfo&) const = default;
};

// Allan deviation per axis at averaging times tau (s), as characterize measured it.
struct AllanCurve {
  std::vector<double> tau_s;                // increasing, > 0
  std::array<std::vector<double>, 3> adev;  // per axis, same length as tau_s, unit
  bool operator==(const AllanCurve&) const = default;
};

// The noise section: each parameter per axis with its 1-sigma uncertainty. Parameters are
// optional one by one (a recording too short for random walk has none).
struct NoiseEstimate {
  std::optional<Eigen::Vector3d> noise_density;  // N, unit/sqrt(Hz)
  std::optional<Eigen::Vector3d> noise_density_sigma;
  std::optional<Eigen::Vector3d> bias_instability;  // B, unit
  std::optional<Eigen::Vector3d> bias_instability_sigma;
  // The averaging-time band (s) where the bias-instability floor lies: [tau_min, tau_max].
  std::optional<std::array<double, 2>> bias_instability_band_s;
  std::optional<Eigen::Vector3d> random_walk;  // K, unit/s/sqrt(Hz)
  std::optional<Eigen::Vector3d> random_walk_sigma;
  std::optional<AllanCurve> allan;
  bool operator==(const NoiseEstimate&) const = default;
};

struct TurnOnBias {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();    // unit, over power cycles
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();  // 1-sigma, unit
  std::optional<int64_t> runs;                       // power cycles measured
  bool operator==(const TurnOnBias&) const = default;
};

struct CalibrationResidual {
  double rms = 0.0;
  double max = 0.0;
  int64_t count = 0;  // residuals (static poses, pose pairs) behind rms and max
  bool operator==(const CalibrationResidual&) const = default;
};

// The sensor's deterministic error as a forward model, reading = diag(scale) misalignment
// true + bias; a reading is corrected by true = (diag(scale) misalignment)^-1 (reading - bias).
// With raw_counts the readings are ADC counts: scale in counts per SI unit, bias in counts.
struct Calibration {
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  Eigen::Matrix3d misalignment = Eigen::Matrix3d::Identity();  // unit diagonal, rad off it
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  bool raw_counts = false;
  std::optional<CalibrationResidual> residual;
  bool operator==(const Calibration&) const = default;
};

struct SensorLimits {
  std::optional<double> range;         // +-full scale, unit
  std::optional<double> resolution;    // LSB, unit
  std::optional<double> rate_hz;       // output data rate
  std::optional<double> bandwidth_hz;  // -3 dB of the sensor's low-pass
  bool operator==(const SensorLimits&) const = default;
};

struct SensorProfile {
  std::optional<NoiseEstimate> noise;
  std::optional<TurnOnBias> turn_on_bias;
  std::optional<Calibration> calibration;
  std::optional<SensorLimits> limits;
  bool operator==(const SensorProfile&) const = default;
};

struct GyroscopeProfile : SensorProfile {
  std::optional<Eigen::Matrix3d> g_sensitivity;  // (rad/s) per (m/s^2)
  bool operator==(const GyroscopeProfile&) const = default;
};

struct MagnetometerProfile : SensorProfile {
  std::optional<Eigen::Vector3d> hard_iron;  // T
  std::optional<Eigen::Matrix3d> soft_iron;  // dimensionless
  bool operator==(const MagnetometerProfile&) const = default;
};

// The device's sample clock (HardwareModel's ClockModel): "clock": {"error_ppm": e, "jitter_s": j}.
struct ClockProfile {
  std::optional<double> error_ppm;  // frequency error, ppm (+ = the device clock runs fast)
  std::optional<double> jitter_s;   // 1-sigma sample-time jitter, s
  bool operator==(const ClockProfile&) const = default;
};

struct DeviceProfile {
  std::optional<DeviceInfo> device;
  std::optional<double> gravity;  // m/s^2, the value the measurements assumed
  std::optional<ClockProfile> clock;
  std::optional<SensorProfile> accelerometer;
  std::optional<GyroscopeProfile> gyroscope;
  std::optional<MagnetometerProfile> magnetometer;
  bool operator==(const DeviceProfile&) const = default;
};

// Parses profile JSON. Throws imukit::Error naming source_name:line:column; a semantic error
// also names the JSON path ("accelerometer.noise.noise_density: expected an array of 3 numbers,
// got a string") and points at its value (or, for a missing key, at the object that lacks it);
// a missing or unknown schema is rejected. Unknown keys are ignored.
DeviceProfile parse_profile(std::string_view text, const std::string& source_name);
// A profile inline in another JSON document, such as a scene's sensors[i].hardware:
// `profile_text` is the profile's own JSON (the caller's serialisation of the value), `document`
// the text of the file it sits in at `json_path` (json_path_offset's syntax,
// "sensors[0].hardware"). Errors are parse_profile's, at their line and column in `document` and
// named by the whole path: "scene.json:8:40: sensors[0].hardware.clock.error_ppm: ...". The
// document is only searched for an error, so reading many inline profiles stays linear. With
// rate_hz, the rules that depend on the rate a model runs at are checked too, as
// read_profile_for_rate does.
DeviceProfile parse_inline_profile(std::string_view profile_text, std::string_view document,
                                   std::string_view json_path, const std::string& source_name,
                                   std::optional<double> rate_hz = std::nullopt);
DeviceProfile read_profile(const std::string& path);

// Reads the profile at `path` (as read_profile) and checks it for a hardware model run at
// rate_hz: the rules of validate_hardware_model that depend on the rate (a bandwidth below half
// of it, a bias-instability band starting 5 samples in, clock jitter at most a tenth of its
// period), so a failure names path:line:column and the file's key
// (accelerometer.limits.bandwidth) rather than the model's field (bandwidth_hz).
DeviceProfile read_profile_for_rate(const std::string& path, double rate_hz);

// JSON text of the profile (ends with a newline). Throws imukit::Error naming the field if a
// number is not finite or a value would not read back (the writer checks what the reader does).
std::string format_profile(const DeviceProfile& profile);
// Writes atomically (a temporary file renamed over path). Throws imukit::Error on I/O failure.
void write_profile(const std::string& path, const DeviceProfile& profile);

// The sections present in `update` replace those of `base`; the others stay. Sections are:
// device, gravity, clock, and per sensor noise, turn_on_bias, calibration, limits, g_sensitivity
// (gyroscope), hard_iron and soft_iron (magnetometer).
DeviceProfile merge_profile(DeviceProfile base, const DeviceProfile& update);
// The same on text: keeps everything of `existing_text` that `update` does not replace, keys
// unknown to this version included. Throws like parse_profile if existing_text is not a profile.
std::string merge_profile_text(std::string_view existing_text, const std::string& source_name,
                               const DeviceProfile& update);
// Reads path if it exists, merges `update` into it, writes it back (creates it otherwise).
void update_profile(const std::string& path, const DeviceProfile& update);

// The HardwareModel a profile describes. Per sensor: noise densities, bias instability (and its
// band when given), random walk; turn-on bias mean and spread, or, without a turn_on_bias
// section, the calibration's bias with spread 0; calibration scale and misalignment; range,
// resolution, bandwidth and rate from limits; g-sensitivity, hard and soft iron; the clock's
// error and jitter. Absent fields
// keep the ideal defaults. Throws imukit::Error for a calibration of raw counts (an SI model
// cannot reproduce counts).
HardwareModel to_hardware_model(const DeviceProfile& profile);

// Spreads of a drawn hardware model: the relative 1-sigma of each axis' scale and the 1-sigma of
// each off-diagonal misalignment angle (rad).
struct HardwareSpread {
  double scale = 0.0;
  double misalignment_rad = 0.0;
  bool operator==(const HardwareSpread&) const = default;
};

// One plausible unit of the device a profile describes (PPDA's hardware group): to_hardware_model
// (profile) with, per triad, accelerometer then gyroscope, noise density, bias instability and
// random walk drawn from their stated 1-sigma uncertainties (3 normal draws per stated sigma
// vector, kept >= 0; none where no sigma is stated), then each axis' scale multiplied by
// exp(spread.scale n) (log-normal, median 1; about 1 + spread.scale n for small spreads, never
// <= 0) and each off-diagonal
// misalignment angle moved by spread.misalignment_rad n
// (n ~ N(0, 1): 3 + 6 draws per triad, taken even at zero spread). The magnetometer and the
// clock stay to_hardware_model's. Throws like to_hardware_model.
HardwareModel draw_hardware_model(const DeviceProfile& profile, const HardwareSpread& spread,
                                  Rng& rng);

}  // namespace imukit
