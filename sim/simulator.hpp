// Simulator: body + motion + placements -> the true specific force and angular rate each sensor
// measures (DESIGN.md "Simulation model"; hardware errors are added afterwards by the scene, with
// core's ImuErrorGenerator):
//
//   p_world_s = p_world_j + R_world_j p_j_s,  R_world_s = R_world_j R_j_s,
//   f_s = R_world_s^T (d^2 p_world_s / dt^2 - g_world),   w_s = R_world_s^T w_world_j.
//
// The scene is compiled into a plan: only joints on some sensor's chain are evaluated, each
// once however many sensors share it, positions only when an accelerometer is asked for and
// rotation derivatives (fd) only for joints that carry a gyroscope.
//
// Derivative methods (docs/simulation.md has the derivations and error orders):
//  fd        central differences on the motion's frame grid: acceleration (p[k+1] - 2 p[k] +
//            p[k-1]) / h^2, angular rate (d[k-1] + d[k]) / (2 h) with d[k] = log(R[k]^T R[k+1])
//            the SO(3) increment; one-sided second-order stencils at the ends. Error O(h^2).
//            Sensor times off the grid are linearly interpolated between frames.
//  spline    per joint, on each frame interval [i, i+1], R(t) = R[i] exp(psi(t)) with psi the
//            cubic through the log coordinates psi_m = log(R[i]^T R[m]) of frames i-1 .. i+2
//            (a local cubic in the chart at R[i]); the root translation likewise. Angular
//            velocity and acceleration of exp(psi(t)) are analytic, then propagated along the
//            chain (w_c = w_p + R_c w_l, a_c = a_p + w_p x R_c w_l + R_c dw_l, and the rigid-body
//            point acceleration). Evaluated at any time. Exact for constant-rate rotations and
//            cubic-in-time translations and fixed-axis rotations; at the frames its acceleration
//            equals fd's second difference and its rate is third-order; between frames values are
//            O(h^4), rate O(h^3), acceleration O(h^2).
//  reference the published reference simulator's discretisation (seed-summary section 1,
//            defect 1; ../shared/data/reference_sim/README.md): doubled first differences for
//            acceleration and Euler-angle differences for the rate. First order in the rate.
//            For comparison with published numbers only; never the default.
//
// Times are int64 ns since the motion's frame 0. Frame positions are computed in integers when
// the motion rate is a whole number of Hz, so a sample 24 h into a scene is evaluated exactly like
// the same sample of the same motion segment simulated alone.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/signal_source.hpp"
#include "imukit/core/time.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"

namespace imukit::sim {

enum class DerivativeMethod { fd, spline, reference };
std::string_view to_string(DerivativeMethod method);
// "fd", "spline" or "reference"; throws imukit::Error otherwise.
DerivativeMethod parse_derivative_method(std::string_view name);

// The default Earth magnetic field in the world frame (T): a mid-latitude northern-hemisphere
// field, 20 uT horizontal along world +y (the subject faces magnetic north in the neutral pose)
// and 44 uT down (|B| = 48.3 uT, inclination 65.6 deg). Scenes may set their own.
inline const Eigen::Vector3d kDefaultEarthMagneticField(0.0, 20e-6, -44e-6);

struct SensorOutputs {
  bool accelerometer = true;
  bool gyroscope = true;
  bool orientation = false;   // q_world_sensor
  bool magnetometer = false;  // R_world_sensor^T B_world
};

struct SensorSpec {
  std::string name;
  Placement placement;
  SensorOutputs outputs;
};

// The gravity a simulation takes, |g_world| in m/s^2: 0.1 (a small asteroid's is less, no
// wearable's) to 100, checked the same way for a scene's simulation.gravity, simulate --gravity
// and Python's Scene(gravity=): a scene once took [0, 0, 0] that --gravity refused.
struct GravityLimits {
  static constexpr double min_m_s2 = 0.1;
  static constexpr double max_m_s2 = 100.0;
  static constexpr const char* text = "[0.1, 100] m/s^2 (the Earth's is 9.81)";
};
// Throws imukit::Error "<what>: |g| = N m/s^2 is outside [0.1, 100] m/s^2 ..." unless within.
void check_gravity(const Eigen::Vector3d& gravity_world, const std::string& what);

// Motion frames per streamed chunk: at least 8 (the spline's and the differences' stencils reach
// across a chunk's edge), at most 1e7 (a chunk's frames are held in memory at once). Throws
// imukit::Error "<what>: must be a whole number in [8, 1e7], got N" otherwise. One check
// for the scene file, the Python Scene and the simulator (three copies until review, 2026-11-27).
void check_chunk_frames(double chunk_frames, const std::string& what);

struct SimulationOptions {
  DerivativeMethod method = DerivativeMethod::fd;
  Eigen::Vector3d gravity_world = kStandardGravityWorld;
  Eigen::Vector3d magnetic_field_world = kDefaultEarthMagneticField;  // T
  double rate_hz = 0.0;         // sensor sample rate; 0 = the motion's frame rate
  int64_t chunk_frames = 4096;  // motion frames per streamed chunk: check_chunk_frames
  // spline: evaluate samples that fall on frames through the vectorised on-frame path (the same
  // values to rounding; docs/simulation.md). Off only to compare the two paths.
  bool spline_on_frames = true;
  // Where the motion's frames come faster than the sensor samples, band-limit the motion to the
  // sensor's Nyquist frequency before sampling it (AntiAliasFilter): what a sensor's filter
  // before its converter does. Off, the motion is point-sampled and its content above the
  // Nyquist frequency folds into the band.
  bool anti_alias = true;
};

// The anti-aliasing filter of SimulationOptions::anti_alias: the sensor's specific force,
// angular rate and magnetic field at a sample time t are their values on the motion's frames
// weighted by k((t_frame - t) f_s), k(x) = sinc(x) w(x) with w the Kaiser window (beta 6) over
// |x| <= 12 sensor periods, the weights normalised to sum to 1 (constants pass exactly). Frames
// past the motion's ends hold its first and last values. Cut at the Nyquist frequency f_s / 2:
// flat within 0.1 % to 0.4 f_s (0.12 % where the frames come barely faster than the samples),
// and content from 0.6 f_s up -- what folds into 0..0.4 f_s -- at least 60 dB down
// (docs/simulation.md, "Anti-aliasing"; tests/sim measure both).
// Orientation outputs are the pose at t itself. The hardware model's bandwidth low-pass runs
// afterwards, on the samples, as before.
struct AntiAliasFilter {
  static constexpr double half_width_periods = 12.0;
  static constexpr double kaiser_beta = 6.0;
  // k(x), x in sensor periods.
  static double kernel(double x);
};

// The samples of one sensor for a block of times. Channels not requested have 0 columns.
struct SensorBlock {
  std::vector<TimeNs> t;
  Eigen::Matrix3Xd specific_force;                 // m/s^2, sensor frame
  Eigen::Matrix3Xd angular_rate;                   // rad/s, sensor frame
  Eigen::Matrix3Xd magnetic_field;                 // T, sensor frame
  std::vector<Eigen::Quaterniond> q_world_sensor;  // unit, sign-canonical: w > 0 (so3.hpp)
};

// Which joints a scene needs and how they connect.
struct SimulationPlan {
  std::vector<int> joints;        // body indices, parents first
  std::vector<int> parent;        // index into `joints`, -1 for the root
  std::vector<int> sensor_joint;  // per sensor, index into `joints`
  std::vector<char> needs_rate;   // per plan joint: carries a gyroscope (fd/reference)
  bool needs_position = false;    // some sensor has an accelerometer
  bool needs_rotation = false;    // some sensor has a gyroscope, orientation or magnetometer
};

SimulationPlan compile_plan(const Body& body, const std::vector<SensorSpec>& sensors);

// The sensor sample rate of a simulation with `options` over `motion`: options.rate_hz, or the
// motion's frame rate when that is 0.
double sample_rate_hz(const SimulationOptions& options, const MotionSource& motion);
// How many samples k / rate_hz (k = 0, 1, ...) lie within `frames` frames of a motion at
// motion_rate_hz (the last at or before the last frame). Throws unless rate_hz is finite and > 0.
int64_t sample_count(double motion_rate_hz, int64_t frames, double rate_hz);

class Simulator {
 public:
  Simulator(const Body& body, std::vector<SensorSpec> sensors, SimulationOptions options = {});
  ~Simulator();
  Simulator(Simulator&&) noexcept;
  Simulator& operator=(Simulator&&) noexcept;

  const SimulationPlan& plan() const { return plan_; }
  const std::vector<SensorSpec>& sensors() const { return sensors_; }
  const SimulationOptions& options() const { return options_; }

  // Number of sensor samples a motion of `frames` frames gives (times 0 .. (frames-1)/rate).
  int64_t sample_count(const MotionSource& motion, int64_t frames) const;
  // The same for samples k / rate_hz at any rate (a device clock's true sampling rate, say).
  int64_t sample_count(const MotionSource& motion, int64_t frames, double rate_hz) const;
  // Sample n's time.
  TimeNs sample_time_ns(const MotionSource& motion, int64_t n) const;
  // The motion frame at or before time t (ns since frame 0).
  static int64_t frame_at(TimeNs t, double motion_rate_hz);
  // True when evaluate() band-limits the motion (SimulationOptions::anti_alias): the motion's
  // frame rate is above the sensor rate.
  bool anti_aliases(const MotionSource& motion) const;
  // Motion frames whose samples a streamed block takes: chunk_frames, or, anti-aliasing, at
  // least 4 times the filter's reach (each block evaluates its frames and the reach on both
  // sides: 1/60 Hz from 1 kHz frames evaluated 70 times as many frames as the motion has with
  // blocks of 4096 frames; review, 2026-11-27). Memory stays bounded: evaluate() takes the
  // frames in chunks.
  int64_t block_frames(const MotionSource& motion) const;
  // The most samples a streamed block holds: chunks of frames alone held every sample of
  // chunk_frames frames, 253 MB for a 1 Hz motion simulated at 5 kHz (review, 2026-11-27).
  static constexpr std::size_t kMaxBlockSamples = 65536;

  // Values at the given times (ns since frame 0, increasing, inside the motion) for every
  // sensor: out[s] is resized. Reads only the frames the times need (and, anti-aliasing, the
  // filter's reach around them).
  void evaluate(MotionSource& motion, std::span<const TimeNs> times, std::vector<SensorBlock>& out);

  // Streams the whole motion (or its first `frame_limit` frames; required for an endless
  // source) in chunks of options().chunk_frames frames, and of at most kMaxBlockSamples samples:
  // `sink(sensor, block)` is called for each sensor and chunk in time order. Memory does not
  // grow with the motion's length, nor with the samples per frame.
  void run(MotionSource& motion,
           const std::function<void(std::size_t sensor, const SensorBlock& block)>& sink,
           std::optional<int64_t> frame_limit = std::nullopt);

 private:
  struct Workspace;
  // The motion sampled at the times, each value its own (no filter).
  void evaluate_points(MotionSource& motion, std::span<const TimeNs> times,
                       std::vector<SensorBlock>& out);
  void evaluate_band_limited(MotionSource& motion, std::span<const TimeNs> times,
                             std::vector<SensorBlock>& out);
  SimulationPlan plan_;
  std::vector<SensorSpec> sensors_;
  SimulationOptions options_;
  std::vector<Eigen::Vector3d> offsets_;  // per plan joint, offset from its plan parent
  std::unique_ptr<Workspace> ws_;
  std::vector<TimeNs> frame_times_;        // evaluate_band_limited's frames
  std::vector<SensorBlock> frame_blocks_;  // and the values on them
};

// The motion the `spline` method differentiates, sampled at any times (ns since frame 0,
// increasing, inside the motion): every joint's rotation relative to its parent and the root
// translation (the spline's cubic through the stencil's frames), as a Motion of times.size()
// frames at rate_hz (the spacing the caller gives the new frames). The root must be joint 0.
// Identification bakes a fitted time warp and rotation correction into a motion with it.
Motion spline_resample(const Body& body, MotionSource& motion, std::span<const TimeNs> times,
                       double rate_hz);

// One simulated sensor as a core SignalSource (what mock devices and the hardware model
// consume): true specific force and angular rate at any times inside the motion.
class SimulatedSensorSource : public SignalSource {
 public:
  // `motion` must outlive this object.
  SimulatedSensorSource(const Body& body, const SensorSpec& sensor, MotionSource& motion,
                        SimulationOptions options = {});
  void evaluate(std::span<const TimeNs> times, Eigen::Matrix3Xd* specific_force,
                Eigen::Matrix3Xd* angular_rate) override;

 private:
  Simulator simulator_;
  MotionSource& motion_;
  std::vector<SensorBlock> blocks_;
};

}  // namespace imukit::sim
