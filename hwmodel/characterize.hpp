// From measurements to the sections of a device profile (core/profile.hpp): the noise of a triad
// (overlapping Allan deviation, the GLS noise-model fit and the slope readings per axis, as
// `imukit characterize` computes them) and the calibration sections of a multi-position
// calibration. The CLI and the Python package call these, so both write the same numbers.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>

#include "imukit/core/profile.hpp"
#include "imukit/core/time.hpp"
#include "imukit/hwmodel/allan.hpp"
#include "imukit/hwmodel/calibration.hpp"
#include "imukit/hwmodel/noise_fit.hpp"

namespace imukit::hwmodel {

struct AxisNoise {
  NoiseFit fit;          // fit_noise_model_gls on the axis' Allan deviation
  SlopeReadings slopes;  // read_slopes: the classic graphical readings, for comparison
  // Every sample the same (a dead axis, or noise below one count of the converter): its Allan
  // deviation is 0 at every tau, there is nothing to fit, and fit and slopes stay zero.
  bool constant = false;
};

struct TriadNoise {
  AllanResult allan;  // the overlapping Allan deviation of the three axes
  std::array<AxisNoise, 3> axes;
};

struct TriadNoiseOptions {
  int points_per_decade = 10;  // tau grid density of the Allan deviation
  double fit_tau_min_s = 0.0;  // the fit ignores shorter averaging times
};

// Overlapping Allan deviation of the triad x (3 x n, samples at times t) with, per axis, the
// GLS noise fit and the slope readings (none for a constant axis). Throws imukit::Error for
// input allan_deviation refuses, and naming the axis when its fit fails.
TriadNoise characterize_triad(std::span<const TimeNs> t, const Eigen::Matrix3Xd& x,
                              const TriadNoiseOptions& options = {});

// The profile's noise section: the fitted N, B, K with their 1-sigma and the Allan curve.
NoiseEstimate noise_estimate(const TriadNoise& noise);

// The profile's calibration section of one triad (the forward model: raw = diag(scale)
// misalignment true + bias), with the fit's residuals (rms, max, count).
Calibration calibration_section(const TriadCalibration& c, bool raw_counts, double residual_rms,
                                double residual_max, int64_t residual_count);

// The profile sections a multi-position calibration gives: gravity, the accelerometer's
// calibration and, when `gyro`, the gyroscope's (residuals: |a| - g per pose, and the gravity
// direction error between poses).
DeviceProfile calibration_profile(const CalibrationResult& result, bool raw_counts, bool gyro,
                                  double gravity);

}  // namespace imukit::hwmodel
