// Body motion from 3D keypoints (docs/keypoints.md): joint positions over time, as a depth
// camera (Kinect) or a video pose estimator (Human3.6M-style 17 joints) gives them, become an
// imukit Body (segment offsets from robust per-trial statistics) and Motion (per-segment
// rotations), ready for the simulator, scenes, PPDA and identification.
//
// Pipeline (each step documented in docs/keypoints.md):
//   1. checks: >= 2 frames, times strictly increasing, no infinities, no keypoint missing in
//      every frame (imukit::Error naming the keypoint);
//   2. repairs, each a warning naming the frames: frozen frames (a frame repeating the previous
//      one exactly: a dropped camera frame) become missing; left/right limb swaps are undone;
//      of a bone whose length is off its median by more than max_bone_deviation, the keypoint
//      that jumped (further from its neighbouring frames' midpoint) becomes missing; missing
//      samples are weights of zero in step 4; jumps (a keypoint snapping back after a tracking
//      failure) are named and their stretches listed in invalid_motion;
//   3. world frame: up from KeypointMotionOptions::up, else from the body's own axis while it
//      stands upright; forward (+y) the mean facing direction of the hips; x = y cross z
//      (right); z = 0 at the floor (the lowest keypoints), the root over the origin at frame 0;
//   4. smoothing and resampling: every coordinate is a penalised cubic B-spline (a smoothing
//      spline) whose frequency response is 1 / (1 + (f / cutoff_hz)^4), a zero-phase 2nd-order
//      Butterworth, evaluated on the output grid (rate_hz);
//   5. rotations: each segment's bone direction (origin -> end keypoint) fixes two degrees of
//      freedom; the twist about the bone comes from the segment's secondary directions where
//      they are observable (weighted by how far they are from the bone), is smoothed, and is
//      filled by minimum-twist (parallel-transport) propagation where no secondary is
//      observable (a straight elbow, a straight knee): the guess is documented per segment;
//   6. body: every joint's offset in its parent's neutral frame is the median over frames;
//      per-subject offsets can be passed in (options.body, e.g. average_bodies of the trials).
//
// Neutral pose: imukit's convention (x right, y forward, z up); each segment states its bone
// direction at neutral (arms along +-x, T-pose; legs and trunk along -+z; feet +y).
// Rotations are continuous: quaternion signs follow the previous frame (no q/-q flips) and the
// twist is unwrapped, so nothing jumps near pi.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imukit/core/time.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/motion.hpp"

namespace imukit::sim {

inline constexpr std::string_view kKeypointTopologySchema = "imukit.keypoint_topology/1";

// A direction in the world computed from keypoints (indices into the topology's keypoints):
// `to - from`, or with `cross`, (a_to - a_from) x (b_to - b_from) (a plane's normal, e.g. the
// elbow's hinge axis from the upper arm and the forearm). `neutral` is the same direction at the
// neutral pose, in the body frame (x right, y forward, z up); it need not be unit.
struct SecondaryDirection {
  int a_from = -1, a_to = -1;
  int b_from = -1, b_to = -1;  // -1 unless cross
  bool cross = false;
  Eigen::Vector3d neutral = Eigen::Vector3d::UnitY();
  // A fallback counts only as far as the segment's other candidates are not seen: its weight
  // is scaled by 1 - the largest weight among them (Human3.6M's hip line for the thigh, used
  // where the knee is straight).
  bool fallback = false;
};

// One Body joint: the segment that starts at keypoint `origin` and points at keypoint `end`
// (-1: a leaf without an end keypoint, which keeps its parent's rotation).
struct KeypointSegment {
  std::string joint;  // Body joint name (canonical where it applies: left_elbow = forearm)
  int parent = -1;    // index into KeypointTopology::segments (parents first); -1 for the root
  int origin = -1;    // keypoint index
  int end = -1;       // keypoint index or -1
  Eigen::Vector3d neutral = Eigen::Vector3d::UnitZ();  // bone direction at neutral (unit)
  // Candidates for the twist about the bone, combined by weight (how far from the bone each
  // is); empty: minimum twist throughout.
  std::vector<SecondaryDirection> secondary;
  std::string twist_note;  // how the twist is found, for docs and reports
};

struct KeypointTopology {
  std::string name;
  std::vector<std::string> keypoints;     // the J keypoints in input order
  std::vector<KeypointSegment> segments;  // segments[0] is the root (origin = root position)
  // Left/right limb groups (pairs of keypoint indices, proximal to distal) whose labels a
  // tracker may swap; checked for swaps frame by frame.
  std::vector<std::vector<std::pair<int, int>>> swap_groups;
  std::vector<int> feet;  // the lowest keypoints (floor height); may be empty
  // Keypoint pairs whose midpoints give the body's long axis when upright: lower (ankles or
  // hips) and upper (shoulders); empty: the root segment's bone direction.
  std::vector<std::pair<int, int>> upright_lower, upright_upper;
  // Left -> right keypoints whose difference is the body's right direction (hips).
  std::pair<int, int> left_right = {-1, -1};

  int keypoint_index(std::string_view name) const;  // -1 when unknown
};

// Built-in topologies: "kinect_v1_20" (Kinect v1 / UTD-MHAD joint order) and "h36m_17" (the
// Human3.6M 17-joint order of VideoPose3D, MotionBERT and similar estimators).
std::vector<std::string> keypoint_topology_names();
// Throws imukit::Error listing the known names.
KeypointTopology keypoint_topology(std::string_view name);
// A user topology from JSON ("schema": "imukit.keypoint_topology/1", docs/formats.md); errors
// name the source and the JSON path.
KeypointTopology parse_keypoint_topology(std::string_view text, const std::string& source_name);
// A built-in name, or else a JSON file.
KeypointTopology load_keypoint_topology(const std::string& name_or_path);
// The topology as JSON (the built-ins can be written out and edited).
std::string keypoint_topology_json(const KeypointTopology& topology);

// Keypoint positions: frame f, keypoint j at column f * keypoints + j (m, any fixed camera or
// world frame, right-handed); NaN marks a missing keypoint. Times: t_s (strictly increasing) or,
// when t_s is empty, frame f at f / rate_hz.
struct Keypoints {
  std::size_t keypoints = 0;
  Eigen::Matrix3Xd positions;
  std::vector<double> t_s;
  double rate_hz = 0.0;
  int64_t frames() const {
    return keypoints == 0
               ? 0
               : static_cast<int64_t>(positions.cols()) / static_cast<int64_t>(keypoints);
  }
};

// Files (docs/formats.md, "Keypoints"): CSV with a header `t,<kp>_x,<kp>_y,<kp>_z,...` (t in s;
// columns in any order, every topology keypoint once; `nan` or an empty field = missing), or
// NumPy .npy of shape (frames, keypoints, 3) float32/float64 with times from rate_hz (a CSV
// without a t column needs rate_hz too; one with a t column refuses it). Errors name the file, line
// and column or byte.
Keypoints read_keypoints(const std::string& path, const KeypointTopology& topology,
                         std::optional<double> rate_hz = std::nullopt);
Keypoints parse_keypoints_csv(std::string_view text, const std::string& source_name,
                              const KeypointTopology& topology,
                              std::optional<double> rate_hz = std::nullopt);

struct KeypointMotionOptions {
  double rate_hz = 100.0;  // output frame rate (the smoothing spline is evaluated there)
  double cutoff_hz = 3.0;  // smoothing: gain 1/2 at cutoff_hz (docs/keypoints.md)
  // Up (against gravity) in the input's frame, e.g. the IMU's gravity reading at rest mapped to
  // the camera frame, negated. None: estimated from the data.
  std::optional<Eigen::Vector3d> up;
  // Offsets to use instead of estimating them (per-subject lengths): a Body with the topology's
  // joints in the same order and parents, e.g. from average_bodies over a subject's trials.
  std::optional<Body> body;
  bool fix_swaps = true;
  bool drop_frozen_frames = true;
  // A bone longer or shorter than its median by more than this fraction (and 5 cm) drops the
  // keypoint of its two that jumped in that frame (0: never drop).
  double max_bone_deviation = 0.3;
  // A keypoint stepping faster than this between two frames it is seen in (consecutive, or
  // across the frames it is missing in), and three times faster than in the neighbouring
  // steps, is a jump: named in a warning and its stretch (widened by 0.5 / cutoff_hz on each
  // side) put in invalid_motion; the data are kept (0: no check).
  double jump_speed_mps = 4.0;
  // Secondary directions closer than these angles to the bone carry no twist information
  // (weight 0) and beyond the second full weight; in between a smooth ramp.
  double twist_min_angle_deg = 10.0;
  double twist_full_angle_deg = 25.0;
};

// Per segment: how much of the twist came from the data.
struct SegmentReport {
  std::string joint;
  double length_m = 0.0;        // |offset| of the segment's end (0 for a leaf)
  double length_iqr_m = 0.0;    // interquartile range of the per-frame bone length
  double twist_observed = 0.0;  // fraction of output frames with twist weight >= 0.5
};

struct KeypointMotion {
  Body body;
  Motion motion;
  double start_s = 0.0;  // input time of motion frame 0
  std::vector<std::string> warnings;
  // world = R_world_input (input - origin_input); up_input is world +z in the input frame.
  Eigen::Matrix3d R_world_input = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_input = Eigen::Vector3d::Zero();
  Eigen::Vector3d up_input = Eigen::Vector3d::UnitZ();
  std::string up_source;       // "option", "upright body" or "trunk"
  double input_rate_hz = 0.0;  // mean input frame rate
  // Input frames touched by each repair (sorted); a frame may be in several lists.
  std::vector<int64_t> missing_frames;  // some keypoint NaN on input
  std::vector<int64_t> frozen_frames;
  std::vector<int64_t> swapped_frames;
  std::vector<int64_t> outlier_frames;
  std::vector<int64_t> jump_frames;  // the frame after each jump
  int64_t flagged_frames = 0;        // input frames in any list
  // Motion-time intervals [begin, end] (ns since motion frame 0, sorted, disjoint) filled over
  // two or more consecutive input frames without data (from the frame with data before to the
  // one after), over steps in time of 2.5 frame periods or more, and around jumps; the motion
  // there is a guess. IdentifyOptions::invalid_motion takes them as is.
  std::vector<std::pair<TimeNs, TimeNs>> invalid_motion;
  std::vector<SegmentReport> segments;
};

// The whole pipeline (header comment). Throws imukit::Error for unusable input: fewer than 2
// frames, a keypoint missing everywhere, a keypoint count that does not match the topology,
// non-increasing or non-finite times, infinite coordinates or beyond 1e6 m, an input longer
// than 1e7 s or 1e7 output frames, bad options.
KeypointMotion motion_from_keypoints(const Keypoints& keypoints, const KeypointTopology& topology,
                                     const KeypointMotionOptions& options = {});

// The joint-wise median of several bodies with the same joints (names and parents): per-subject
// offsets from several trials. Throws imukit::Error when the bodies differ in structure.
Body average_bodies(std::span<const Body> bodies);

// Forward kinematics of every joint at every frame (world frame): positions 3 x (frames * joints)
// (column f * joints + j) and rotations R_world_joint (index f * joints + j). For synthetic
// keypoints (round trips) and checks.
struct WorldPoses {
  std::size_t joints = 0;
  Eigen::Matrix3Xd positions;
  std::vector<Eigen::Quaterniond> rotations;
};
WorldPoses world_poses(const Body& body, const Motion& motion);

// Smoothing used by step 4, exposed for tests and other resampling: a cubic B-spline on a
// uniform knot grid fitted to (t_i, y_i) with weights w_i (0 = missing) minimising
//   sum_i w_i (y_i - s(t_i))^2 + lambda int s''(t)^2 dt + tension int s'(t)^2 dt,
// lambda = wbar / (h (2 pi cutoff_hz)^4) with h the mean sample spacing and wbar the mean
// positive weight, so the gain is 1 / (1 + (f / cutoff_hz)^4) (1/2 at cutoff_hz) where the data
// are dense, then evaluated (derivative `order` 0..2) at the query times. y is C x n (channels
// in rows).
Eigen::MatrixXd smooth_and_resample(std::span<const double> t, const Eigen::MatrixXd& y,
                                    std::span<const double> w, double cutoff_hz,
                                    std::span<const double> t_out, int order = 0,
                                    double tension = 0.0);

}  // namespace imukit::sim
