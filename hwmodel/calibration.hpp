// Static intervals, turn-on bias and multi-position calibration of an accelerometer and a
// gyroscope (Tedaldi, Pretto, Menegatti, "A robust and easy to implement method for IMU
// calibration without external equipments", ICRA 2014):
//
// 1. Static detector: the summed per-axis variance of the accelerometer over a sliding window
//    is compared with k times its mean over the initial static period; runs below it that last
//    long enough are static poses. k is searched (1..max_k) and the one whose accelerometer
//    fit has the smallest residual wins, as in the paper, the residual taken per spare pose
//    (sum of squares / (poses - 9)) so that fits of different pose counts compare fairly.
// 2. Accelerometer: a_true = T K (a_raw - b), T upper unit-triangular (3 misalignment angles),
//    K = diag(scale), b bias; minimise sum_i (g^2 - |a_true(mean of pose i)|^2)^2 (Ceres).
// 3. Gyroscope: w_true = T_g K_g (w_raw - b_g), T_g unit diagonal with 6 small angles; b_g from
//    the initial static period, then refined. Between consecutive poses i, i+1 the calibrated
//    rate is integrated exactly per sample (R <- R exp([w dt]x)), and the gravity direction
//    of pose i carried into pose i+1 must match the direction measured there.
// Unexcited directions (poses that do not tilt every axis, rotations about fewer than three
// axes) make the problem rank deficient: calibrate() throws imukit::Error saying which,
// instead of returning numbers the data do not determine.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>  // Matrix3d::inverse in forward_misalignment
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"

namespace imukit::hwmodel {

struct StaticInterval {
  int64_t begin = 0;  // first sample
  int64_t end = 0;    // one past the last
};

struct StaticDetectorOptions {
  double window_s = 1.0;        // sliding variance window
  double init_static_s = 50.0;  // initial static period (paper: 50 s)
  double threshold_factor = 3.0;
  double min_interval_s = 1.0;  // shorter static runs are ignored
};

// Static intervals of the accelerometer (3 x n) at times t. Throws imukit::Error when the
// recording is shorter than the initial static period plus a window.
std::vector<StaticInterval> detect_static_intervals(std::span<const TimeNs> t,
                                                    const Eigen::Matrix3Xd& accel,
                                                    const StaticDetectorOptions& options);

// Per-axis mean (and standard deviation) of a channel over a sample range.
Eigen::Vector3d interval_mean(const Eigen::Matrix3Xd& x, const StaticInterval& iv);

// Turn-on bias across recordings (power cycles), as a profile states it: the mean of the runs'
// biases, their sample standard deviation (n - 1; zero from fewer than 2 runs) and the run count.
TurnOnBias turn_on_bias_stats(const std::vector<Eigen::Vector3d>& per_run_bias);

// Gyro turn-on bias of a static recording: the mean rate. Accelerometer: the mean minus the
// specific force expected for a known orientation, f = R_world_sensor^T (0, 0, g).
Eigen::Vector3d gyro_static_bias(const Eigen::Matrix3Xd& gyro);
Eigen::Vector3d accel_static_bias(const Eigen::Matrix3Xd& accel,
                                  const Eigen::Matrix3d& R_world_sensor, double gravity);

// One triad's correction: true = T diag(scale) (raw - bias). T is unit-diagonal (the
// accelerometer's is upper triangular).
struct TriadCalibration {
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& raw) const {
    return T * scale.asDiagonal() * (raw - bias);
  }
  // The forward model of core/profile.hpp: raw = diag(s) M true + bias. With T^-1 = diag(d) M
  // (d its diagonal, M unit-diagonal): s = d / scale. The accelerometer's triangular T has
  // d = 1; the gyroscope's full T has d within about 1e-4 of 1.
  Eigen::Vector3d forward_scale() const { return T.inverse().diagonal().cwiseQuotient(scale); }
  Eigen::Matrix3d forward_misalignment() const {
    const Eigen::Matrix3d inv = T.inverse();
    return inv.diagonal().cwiseInverse().asDiagonal() * inv;
  }
};

struct CalibrationOptions {
  double gravity = kStandardGravity;
  StaticDetectorOptions detector;
  int max_threshold_factor = 10;  // k searched over 1..max (integers)
  int min_poses = 9;
  bool calibrate_gyro = true;
  int max_iterations = 200;
};

struct PoseResidual {
  double norm_error = 0.0;  // |a_calibrated| - g at each pose
};

struct CalibrationResult {
  TriadCalibration accel, gyro;
  std::vector<StaticInterval> poses;
  double threshold_factor = 0.0;
  std::vector<double> accel_norm_error;  // |a_cal| - g per pose, m/s^2
  double accel_rms = 0.0, accel_max = 0.0;
  std::vector<double> gyro_direction_error_rad;  // angle between carried and measured gravity
  double gyro_rms_rad = 0.0, gyro_max_rad = 0.0;
  double seconds = 0.0;  // wall time of the optimisation
};

// calibrate()'s error when no stillness threshold found min_poses static poses (not for the
// other failures: a caller may suggest another initial static period for this one only).
class TooFewPosesError : public Error {
 public:
  using Error::Error;
};

// accel and gyro share the time stamps t (raw counts or SI). Throws TooFewPosesError for too
// few poses, imukit::Error for rank deficiency or a non-converging fit.
CalibrationResult calibrate(std::span<const TimeNs> t, const Eigen::Matrix3Xd& accel,
                            const Eigen::Matrix3Xd& gyro, const CalibrationOptions& options);

// Accelerometer fit on given static means only (used by calibrate and the leave-poses-out
// check). Throws like calibrate.
TriadCalibration fit_accelerometer(const std::vector<Eigen::Vector3d>& static_means, double gravity,
                                   int max_iterations = 200);

}  // namespace imukit::hwmodel
