// Augmentation policies (seed-summary section 2, paper Table III): a sub-policy picks, for each
// of the four groups -- movement amplitude, movement speed, sensor placement, hardware -- either
// identity or one method with one parameter option; a policy is a list of sub-policies with
// sampling probabilities. One sub-policy is drawn per mini-batch (sample_sub_policy), or the
// training loop picks one by index (the paper learns the probabilities with Gumbel-softmax over
// logits it owns; the augmenter only applies what it is told).
//
// Built in: "imukit" and "paper", the paper's full grid of 9 x 9 x 2 x 5 = 810 sub-policies in the
// same order (amplitude slowest, hardware fastest). They differ only in the hardware group:
// "paper" uses the paper's shared numbers (noise sigma s and bias U(-1, 1) in m/s^2 AND in rad/s,
// its defect 6), "imukit" scales the gyroscope separately (noise s / 10 rad/s, bias U(-0.05,
// 0.05) rad/s, accelerometer bias U(-0.5, 0.5) m/s^2).
//
// Each PPDA group also has an STDA counterpart (amplitude -> magnitude scaling / warping, speed
// -> time scaling / warping, placement -> rotation, hardware -> jittering), used when the input
// is a recording rather than a simulation (stda_counterparts).
//
// JSON: "schema": "imukit.policy/1" (docs/formats.md). Syntax errors name file:line:column,
// semantic errors the JSON path.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/augment/stda.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/sim/placement.hpp"

namespace imukit::augment {

inline constexpr std::string_view kPolicySchema = "imukit.policy/1";

// The plausible range of every parameter: a policy outside it is refused when it is read (and
// by Policy::validate), not when a draw from it breaks the simulation. Draws beyond these would
// not be human motion or a real sensor.
struct PolicyLimits {
  static constexpr double max_amplitude_sigma = 2.0;            // the grids use up to 0.6
  static constexpr double min_speed = 0.01, max_speed = 100.0;  // speed factor b
  static constexpr double max_speed_ratio = 100.0;
  static constexpr int max_knots = 1000;       // amplitude and speed warping
  static constexpr double max_accel = 1000.0;  // m/s^2: noise sigma and bias half-width
  static constexpr double max_gyro = 100.0;    // rad/s: noise sigma and bias half-width
  static constexpr double max_scale_spread = 1.0;
  static constexpr double max_misalignment_spread_deg = 90.0;
};

enum class WarpMethod { identity, scaling, warping };
std::string_view to_string(WarpMethod method);

// Movement amplitude: each chosen joint's relative rotation q becomes exp(s(t) log q), s = a ~
// N(1, sigma^2) (scaling) or the not-a-knot spline through K+2 knots ~ N(1, sigma^2) over the
// window (warping). One draw per joint.
struct AmplitudeOp {
  WarpMethod method = WarpMethod::identity;
  double sigma = 0.0;
  int knots = 2;
  // Joint names; empty = every joint but the root (whose world orientation and translation stay).
  std::vector<std::string> joints;
  bool operator==(const AmplitudeOp&) const = default;
};

// Movement speed: the motion is re-timed, then simulated, so a faster motion gives physically
// larger rates and accelerations. scaling: b ~ U[lo, hi] (b > 1 faster) around the window centre;
// warping: tsaug's warp with K speed changes and ratio r over the window.
struct SpeedOp {
  WarpMethod method = WarpMethod::identity;
  double lo = 1.0, hi = 1.0;
  int knots = 2;
  double ratio = 1.0;
  bool operator==(const SpeedOp&) const = default;
};

// Sensor placement, drawn per window and sensor. Rotations are composed, never added as angles:
// q_joint_sensor' = R_L(forearm) q_joint_sensor R_flip Rx Ry Rz, with L the segment's long axis.
// Another subject's sensor placements (sensors of an imukit.scene/1 file), each described in
// its segment's anatomical frame (sim::describe_placement; the preset's name is the sensor's),
// so they carry over to a body of other proportions.
struct SubjectPlacements {
  std::string scene_path;  // as written in the policy
  std::vector<sim::PlacementPreset> sensors;
  bool operator==(const SubjectPlacements& other) const { return scene_path == other.scene_path; }
};

// The variation itself (rotation ranges, long-axis turn, flip, shift, preset swap) is sim's
// PlacementVariation, applied by sim::vary_placement; the subject swap needs the policy's
// subjects and stays here.
struct PlacementOp : sim::PlacementVariation {
  bool enabled = false;
  // Swap between subjects: per window one subject is drawn uniformly, and each sensor it has (by
  // name) takes its placement, position and orientation. Before the other placement changes.
  std::vector<SubjectPlacements> swap_subjects;
  // No sensor changes position (disabled, or no swap of either kind, no shift, no long-axis turn).
  bool keeps_positions() const { return !enabled || (keeps_position() && swap_subjects.empty()); }
  bool operator==(const PlacementOp&) const = default;
};

// Hardware errors added to the simulated signal, drawn per window and sensor.
struct HardwareOp {
  enum class Kind { identity, ranges, profile };
  Kind kind = Kind::identity;
  // ranges: white noise with these per-sample sigmas plus a constant bias per axis ~ U(-b, b).
  double accel_noise = 0.0;  // m/s^2
  double accel_bias = 0.0;   // m/s^2
  double gyro_noise = 0.0;   // rad/s
  double gyro_bias = 0.0;    // rad/s
  // profile: the device's HardwareModel (noise densities, bias instability, random walk, turn-on
  // bias mean and spread, bandwidth...), drawn per window and sensor by draw_hardware_model
  // (core/profile.hpp): the noise parameters from their stated 1-sigma uncertainties, scale and
  // misalignment perturbed by these 1-sigma spreads.
  std::optional<DeviceProfile> profile;
  std::string profile_path;   // as written in the JSON (for describe / round trips)
  double scale_spread = 0.0;  // relative
  double misalignment_spread_rad = 0.0;
  bool operator==(const HardwareOp&) const = default;
};

struct SubPolicy {
  AmplitudeOp amplitude;
  SpeedOp speed;
  PlacementOp placement;
  HardwareOp hardware;
  bool is_identity() const;
  // "amplitude=scaling(0.2) speed=warping(K=2,r=1.5) placement=rotation(25deg) hardware=ranges(..)"
  std::string describe() const;
  bool operator==(const SubPolicy&) const = default;
};

struct Policy {
  std::string name;
  std::vector<SubPolicy> sub_policies;
  std::vector<double> probabilities;  // same size, >= 0, sum 1 (uniform when built in)
  // STDA counterparts: the rotation range (paper: U[-180, 180] per axis) and jitter in standard
  // deviations when the data is z-scored.
  double stda_rotation_rad = 3.141592653589793;

  // Throws imukit::Error for an empty list, bad probabilities or invalid parameters.
  void validate() const;
};

// The built-in grids ("imukit", "paper"); throws imukit::Error listing the names.
Policy builtin_policy(std::string_view name);
std::vector<std::string> builtin_policy_names();
// One group's options in grid order (identity first), exposed for tests.
std::vector<AmplitudeOp> paper_amplitude_options();
std::vector<SpeedOp> paper_speed_options();
std::vector<PlacementOp> paper_placement_options();
std::vector<HardwareOp> paper_hardware_options(bool paper_numbers);

// Parses imukit.policy/1 JSON. Profile and subject scene files named inside are read relative
// to base_dir.
Policy parse_policy(std::string_view text, const std::string& source_name,
                    const std::string& base_dir);
// A built-in name ("paper", "imukit") or a JSON file.
Policy read_policy(const std::string& name_or_path);
// JSON text that parse_policy reads back to an equal policy (profiles by their path).
std::string format_policy(const Policy& policy);

// Index drawn with the policy's probabilities (one uniform draw).
std::size_t sample_sub_policy(const Policy& policy, Rng& rng);

// The STDA methods standing in for a sub-policy on recorded data, in application order
// (amplitude, speed, placement, hardware; identities left out). Every method but jittering acts
// on physical units (a rotation or scaling of z-scored channels is neither); jittering comes
// last. `normalized`: the hardware ranges' jitter sigmas are the accelerometer's noise in
// standard deviations for every channel, to add after z-scoring; a device profile's are always
// its white noise per sample in physical units at `rate_hz`, the data's sample rate (0: the
// profile's own rate, 100 Hz if it states none), to add before z-scoring.
std::vector<StdaSpec> stda_counterparts(const SubPolicy& sub, const Policy& policy, bool normalized,
                                        double rate_hz = 0.0);

}  // namespace imukit::augment
