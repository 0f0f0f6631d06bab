// Parameter identification (docs/identification.md): from body motion (a skeleton's motion or a
// rigid body's pose track) and a real IMU recording of a sensor worn on one joint's segment,
// estimate with Ceres what the simulator needs to reproduce that sensor:
//   - the placement (R_joint_sensor, p_joint_sensor),
//   - accelerometer and gyroscope bias (optionally a per-axis scale error),
//   - the time offset between the IMU and motion clocks (optionally a clock-rate difference),
//   - optionally the lengths of chosen segments on the sensor's chain, with Gaussian priors.
//
// Model, for IMU sample i stamped t_i on the IMU clock:
//   tau_i   = (t_i - motion_start) + time_offset + clock_rate * (t_i - t_ref)   (motion clock)
//   gyro_i  = (1 + s_g) . (R_joint_sensor^T w_J(tau_i)) + b_g
//   accel_i = (1 + s_a) . (R_joint_sensor^T (f_J(tau_i) + dw_J x p + w_J x (w_J x p))) + b_a
// with w_J, dw_J and f_J = R_world_J^T (a_J - g) the joint's angular rate, angular acceleration
// and specific force in the joint frame from the spline simulator (smooth in tau). Coarse to
// fine: the time offset first by cross-correlating angular-rate magnitudes (independent of the
// placement), the rotation by Wahba's problem on gyro (and gravity) vectors, then all
// parameters jointly by robust (Huber) least squares. Parameters the motion does not excite are
// reported as unobservable (value NaN) instead of being guessed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imukit/core/imu_series.hpp"
#include "imukit/core/time.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"

namespace imukit::sim {

// A smooth correction of the sensor segment's rotation (docs/identification.md, "Segment
// correction"): the segment's frame turns by Q(t) = Exp(a1 e1) Exp(a2 e2) Exp(a0 e0), e0 the
// segment's long axis (the twist that keypoints cannot see), e1, e2 across it; each angle a cubic
// B-spline over IMU time with uniform knots. With rotation and position free, the fitted twist
// averages zero over the samples used (its mean is a turn of the placement about e0, and is
// reported there, standard errors included).
enum class SegmentCorrection {
  none,
  twist,     // a0 only
  rotation,  // a0, a1, a2 (the two tilts held small by their prior)
};
std::string_view to_string(SegmentCorrection c);
// "none", "twist" or "rotation"; throws imukit::Error otherwise.
SegmentCorrection parse_segment_correction(std::string_view name);

struct CorrectionSpline {
  int dims = 0;                                        // 0 (none), 1 (twist) or 3 (rotation)
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // e0, e1, e2 in the joint frame (columns)
  TimeNs t0_ns = 0;                                    // IMU time of the first knot
  double knot_spacing_s = 0.0;                         // spacing of the uniform knots
  Eigen::MatrixXd control;                             // dims x (segments + 3) control points, rad
  TimeNs t1_ns() const;                                // IMU time of the last knot
  // Angles (a0, a1, a2) and their first two time derivatives at IMU time t (held at the end
  // values outside [t0, t1]); zero where dims says there is no such angle.
  Eigen::Vector3d angles(TimeNs t) const;
  Eigen::Vector3d rates(TimeNs t) const;
  Eigen::Vector3d accelerations(TimeNs t) const;
  // Q(t), the turn of the segment's frame: R_world_joint' = R_world_joint Q(t).
  Eigen::Quaterniond rotation(TimeNs t) const;
};

// How well a simulated signal reproduces a measured one, per axis: RMSE (SI units) and Pearson
// correlation (NaN for an axis whose measured or simulated signal is constant).
struct AxisFidelity {
  Eigen::Vector3d rmse = Eigen::Vector3d::Zero();
  Eigen::Vector3d correlation = Eigen::Vector3d::Zero();
};
struct Fidelity {
  AxisFidelity accel, gyro;
  int64_t samples = 0;
};
Fidelity fidelity(const Eigen::Matrix3Xd& measured_accel, const Eigen::Matrix3Xd& measured_gyro,
                  const Eigen::Matrix3Xd& simulated_accel, const Eigen::Matrix3Xd& simulated_gyro);

struct IdentifyOptions {
  int joint = -1;  // body index of the joint carrying the sensor (required)
  Placement init;  // initial placement (init.joint is ignored); identity/zero by default
  bool init_rotation_from_data = true;  // Wahba on gyro/gravity vectors instead of init's rotation

  // What to estimate (the others stay at their initial value: init placement, zero bias/scale,
  // the given time offset, no clock-rate difference, nominal segment lengths).
  bool rotation = true;
  bool position = true;
  bool accel_bias = true;
  bool gyro_bias = true;
  bool accel_scale = false;
  bool gyro_scale = false;
  bool time_offset = true;
  bool clock_rate = false;  // the time scale between the streams: (1 + clock_rate)
  // Bound of |clock_rate|: 2e-4 suits two real clocks; streams aligned by duration (a camera's
  // effective frame rate, e.g. UTD-MHAD) need percent. Above 1e-3 the coarse step also searches
  // the clock rate on a grid (the drift over the recording then exceeds the offset search).
  double max_clock_rate = 2e-4;
  // Joints on the sensor's chain whose offset from their parent (the parent segment's length)
  // is estimated, each with a Gaussian prior of relative width segment_prior (at most 6).
  std::vector<int> segments;
  double segment_prior = 0.05;
  // Gaussian priors (1 sigma per axis) on the biases; 0: none. Short recordings against a motion
  // with model error (keypoints) otherwise let the constant biases soak up that error.
  double accel_bias_prior_mps2 = 0.0;
  double gyro_bias_prior_radps = 0.0;

  // Clocks: motion frame 0 is at motion_start_ns on the IMU clock.
  TimeNs motion_start_ns = 0;
  bool coarse_time_offset = true;  // cross-correlation of |w| first
  double max_time_offset_s = 1.0;  // search range of the coarse step
  // The start when coarse_time_offset is false. The cross-correlation then searches only
  // +-given_offset_search_s around it (0: start exactly there), and where nothing correlates
  // there (r < 0.3) the start stays as given.
  double time_offset_init_s = 0.0;
  double given_offset_search_s = 0.25;
  // Motion-time intervals [begin, end] (ns since frame 0) that are not real motion (filled gaps
  // of a pose track): IMU samples that would read them are left out.
  std::vector<std::pair<TimeNs, TimeNs>> invalid_motion;

  // Smooth correction of the sensor segment's rotation (CorrectionSpline); each knot's angles
  // have a Gaussian prior (twist_prior_rad for a0, tilt_prior_rad for a1, a2) and each knot's
  // angular acceleration (second difference of the control points / spacing^2) one of
  // correction_smoothness_radps2.
  SegmentCorrection correction = SegmentCorrection::none;
  double correction_knot_spacing_s = 0.3;
  double twist_prior_rad = 1.5;
  double tilt_prior_rad = 0.1;
  double correction_smoothness_radps2 = 30.0;

  Eigen::Vector3d gravity_world = kStandardGravityWorld;
  double huber_sigmas = 3.0;  // Huber threshold, in residual standard deviations
  int max_iterations = 100;
  // Levenberg-Marquardt stops when a step changes the cost by less than this fraction. The
  // spline's angular rate jumps slightly at every motion frame, so with a clock rate the cost is
  // a fine staircase in it and the solver crawls at the 1e-7 level: 1e-6 (Ceres' default) costs
  // nothing measurable in accuracy there (docs/identification.md) and is 3-5x faster.
  double function_tolerance = 1e-12;
  int threads = 1;
  // Singular values of the column-scaled Jacobian below this fraction of the largest mark
  // directions the data do not determine.
  double observability_threshold = 1e-6;
};

// One estimated scalar with its standard error (from the covariance of the final fit).
struct ParameterEstimate {
  std::string name;  // e.g. "position.x", "rotation.y", "accel_bias.z", "time_offset"
  std::string unit;
  double value = 0.0;
  double std_error = 0.0;
  bool estimated = false;  // false: held at its initial value
  bool observable = true;  // false: value and std_error are NaN
};

struct TriadRms {
  double accel = 0.0;  // m/s^2, RMS over the samples and axes
  double gyro = 0.0;   // rad/s
};

struct IdentifyResult {
  Placement placement;  // joint = options.joint
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_scale = Eigen::Vector3d::Zero();  // s_a: measured = (1 + s_a) true
  Eigen::Vector3d gyro_scale = Eigen::Vector3d::Zero();
  double time_offset_s = 0.0;                             // see the model above
  double coarse_time_offset_s = 0.0;                      // from the cross-correlation
  double clock_rate = 0.0;                                // dimensionless (1e-6 = 1 ppm)
  double coarse_clock_rate = 0.0;                         // from the coarse search (or 0)
  TimeNs motion_start_ns = 0;                             // options.motion_start_ns
  Eigen::Vector3d gravity_world = kStandardGravityWorld;  // options.gravity_world, as used
  TimeNs t_ref_ns = 0;                                    // IMU time the clock rate is referred to
  std::vector<std::pair<int, double>> segment_lengths;    // (joint, identified length m)

  std::vector<ParameterEstimate> parameters;
  std::vector<std::string> unobservable;  // names of parameters the data do not determine

  CorrectionSpline correction;        // dims 0 unless options.correction
  Eigen::MatrixXd correction_angles;  // dims x samples used: the angles at each sample, rad

  // Residual RMS and per-axis fidelity of the model against the measurement over the samples
  // used: before = the motion as given (the initial position, the initial rotation or, with
  // init_rotation_from_data, Wahba's at time offset 0; zero bias/scale, no time offset or clock
  // rate, no correction), over the samples used that lie inside the motion at offset 0 (the
  // others' columns of accel_before/gyro_before are NaN; fidelity_before.samples counts them;
  // none: NaN figures); after = identified.
  TriadRms rms_before, rms_after;
  Fidelity fidelity_before, fidelity_after;
  double sigma_accel = 0.0, sigma_gyro = 0.0;  // robust residual std used to weight the fit
  int64_t samples_used = 0;
  int64_t samples_excluded = 0;  // outside the motion or in invalid_motion
  int iterations = 0;
  bool converged = false;
  double seconds = 0.0;
  std::string solver_summary;
  // Results that are determined but implausible (e.g. a scale error beyond 10 %: with a motion
  // whose own acceleration is noisier than the sensor, the fit shrinks the scale towards zero,
  // the errors-in-variables bias; hold such parameters fixed).
  std::vector<std::string> warnings;

  // Per used sample: IMU time, measurement, and the simulated measurement before and after.
  std::vector<TimeNs> t;
  Eigen::Matrix3Xd accel, gyro;
  Eigen::Matrix3Xd accel_before, gyro_before, accel_after, gyro_after;
};

// Runs the identification. The IMU series needs both accelerometer and gyroscope. Throws
// imukit::Error for unusable input (no overlap with the motion, too few samples, ...).
IdentifyResult identify(const Body& body, MotionSource& motion, const ImuSeries& imu,
                        const IdentifyOptions& options);

// The identification as JSON ("imukit.placement/1", docs/formats.md): the sensor entry in the
// scene layout plus hardware bias/scale, timing, the segment correction, uncertainties, fit
// statistics and fidelity.
std::string placement_json(const IdentifyResult& result, const Body& body);

// The fit baked into a motion, so that simulating the identified placement on it reproduces the
// fitted model (docs/identification.md, "The fitted motion"): frame k is IMU time
// first_ns + k / rate_hz; it holds the input motion at the fitted motion time of that instant
// (time offset and clock rate; held at the motion's ends beyond them, an error when every
// frame lies beyond the same end) with the segment correction applied to the sensor's joint
// (R_parent_joint Q) and undone on its children (Q^T R_joint_child, so they keep their world
// orientation).
Motion fitted_motion(const Body& body, MotionSource& motion, const IdentifyResult& result,
                     TimeNs first_ns, int64_t frames, double rate_hz);

// The grid of a fitted scene on an IMU's time stamps: from the first stamp at the IMU's sampling
// rate to the last. Without samples missing (SamplingStats::samples_missing) that is the mean
// rate and one frame per sample (frame k on sample k, the last on the last); with samples
// missing the mean rate is low by their share and the frames drift off the samples (88.6 Hz
// for a 120 Hz IMU that lost 0.5 s; found in review, 2026-11-27), so the rate is the mean
// between the gaps and the frames span the recording at it (a gap's samples have frames, the
// samples after it frames of their own times).
struct FittedSceneClock {
  TimeNs first_ns = 0;
  int64_t frames = 0;
  double rate_hz = 0.0;
};
FittedSceneClock fitted_scene_clock(std::span<const TimeNs> imu_t);

// A scene folder that `imukit simulate`, read_scene and PPDA's Augmenter load (docs/formats.md,
// "Fitted scenes"): `motion.csv` (the fitted motion, joint-quaternion CSV), `scene.json` (the
// body's joints, that motion, spline simulation at the motion's rate with gravity_world, one
// sensor `sensor_name` at the identified placement with the fitted biases and scale errors as
// its hardware, calibration section: reading = (1 + s) true + b) and `placement.json`
// (placement_json). Creates dir. Throws imukit::Error when a placement or hardware parameter
// was not identifiable (NaN) or a file cannot be written.
void write_fitted_scene(const std::string& dir, const Body& body, const Motion& fitted,
                        const IdentifyResult& result, const std::string& sensor_name,
                        const Eigen::Vector3d& gravity_world);

// A rigid body's pose track (optical motion capture): world orientation and position per row,
// NaN where the tracker lost the body.
struct PoseTrack {
  std::vector<TimeNs> t;  // uniform
  std::vector<Eigen::Quaterniond> q_world_body;
  Eigen::Matrix3Xd p_world_body;
};

// A pose track as a one-joint Body ("pose") and Motion: leading and trailing missing rows are
// dropped, inner gaps filled (slerp, linear) and listed so identification can skip them.
struct PoseMotion {
  Body body;
  Motion motion;
  TimeNs start_ns = 0;                          // time of frame 0 on the track's clock
  std::vector<std::pair<TimeNs, TimeNs>> gaps;  // filled frames, motion time [first, last]
  int64_t missing_rows = 0;                     // filled inner rows
};
PoseMotion pose_track_motion(const PoseTrack& track, const std::string& source);

}  // namespace imukit::sim
