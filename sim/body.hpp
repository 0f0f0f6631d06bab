// Body: the skeleton of the simulation model (seed-summary section 1, "Body B"): a tree of joints,
// each with the offset (m) from its parent joint expressed in the parent's frame at the neutral
// pose. Joint j's frame moves with the segment that starts at j (joint "left_elbow" carries the
// forearm), so a sensor "on the forearm" hangs from joint left_elbow.
//
// Canonical names (lower case, left_/right_ prefix) let presets fit any body whose segments are
// named: the alias table maps both CMU BVH naming schemes (3dsMax release: LeftHip, LeftKnee,
// Chest, LeftCollar, LeftShoulder, LeftElbow, LeftWrist; MotionBuilder release: LeftUpLeg, LeftLeg,
// Spine1, LeftShoulder (= clavicle!), LeftArm, LeftForeArm, LeftHand) and a few common others. The
// two CMU schemes disagree on "LeftShoulder", so the scheme is detected from the whole name set.
//
// World frame: Z up; neutral pose x = subject's right, y = forward, z = up (seed-summary 1).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imukit::sim {

// What a human-body simulation takes as positions and angles. Beyond them an input is corrupt or
// in another unit, and the simulator's derivatives lose all precision (found in review: Euler
// angles of 1e300 deg, sensor positions of 1e300 m and a root translation of 1e17 m, where a
// double's spacing is 16 m, passed without a word). The readers refuse them as errors naming the
// place (file:line:column, or the JSON path), not as warnings: no recording of a body comes near
// them, and a warning would let the nonsense through into the signals.
//  - max_root_translation_m, 3e7 m (30,000 km): where the body is in the world, which may be
//    geodetic (UTM northings reach 1e7 m, Web Mercator 2.0e7 m, ECEF 6.4e6 m on the ground and
//    2.7e7 m at the GPS satellites; 1e6 m refused them all, review of 2026-11-26). The bound is
//    set by precision: the simulator differences the translations against the frame's own, which
//    is exact, so only the inputs' own rounding, half a double's spacing each, reaches the
//    accelerations. Below 2^25 m = 3.4e7 m the spacing is at most 2^-28 m = 3.7e-9 m, and a
//    second difference of three rounded values is off by 0.71 spacings rms (2 at most) times the
//    frame rate squared: at 1 kHz, a fast motion-capture rate, 2.6e-3 m/s^2 rms (7.5e-3 at most),
//    below the white noise of the quietest MEMS accelerometers sampled there (ADXL355, 22.5
//    ug/sqrt(Hz) over 500 Hz: 4.9e-3 m/s^2 rms; a phone's ICM-42688, 70 ug/sqrt(Hz): 1.5e-2);
//    at 100 Hz 100 times less. At 1e8 m (spacing 1.5e-8 m) 1 kHz would be 1.1e-2 m/s^2 rms, and
//    at 1e17 m (16 m) nothing is left.
//  - max_position_m, 1e6 m (1000 km, as keypoints' coordinates): joint offsets, End Sites and
//    sensor positions, lengths within a body for which 1000 km is already a wrong unit; there a
//    double's spacing, 1.2e-10 m, puts second differences at 1 kHz 2e-4 m/s^2 off.
//  - max_euler_deg, 1e7 deg (27,778 turns: a week of turning round once every 22 s, as the
//    unwrapped angles of a long BVH grow; 1e6 deg would refuse a day of it). There the angle's
//    rounding in radians, 2e-11 rad, puts angular accelerations at 1 kHz 8e-5 rad/s^2 off.
// BVH keeps its tighter bound on lengths and root positions (BvhLimits::max_length_m): there it
// catches a wrong scale.
struct PlausibilityLimits {
  static constexpr double max_root_translation_m = 3e7;
  static constexpr double max_position_m = 1e6;
  static constexpr double max_euler_deg = 1e7;
};

struct Joint {
  std::string name;                                               // canonical when known
  std::string source_name;                                        // as the input spelled it
  int parent = -1;                                                // -1 for the root
  Eigen::Vector3d offset_parent_joint = Eigen::Vector3d::Zero();  // m, in the parent's frame
  // Where the segment ends when no child joint says so (BVH "End Site"), in this joint's frame.
  std::optional<Eigen::Vector3d> end_offset;
};

class Body {
 public:
  // Appends a joint; parents come before children (asserted), so index order is a valid
  // evaluation order. Throws imukit::Error for a duplicate name. Returns the new index.
  int add_joint(std::string name, int parent, const Eigen::Vector3d& offset_parent_joint,
                std::string source_name = {});
  std::size_t size() const { return joints_.size(); }
  const Joint& joint(std::size_t i) const { return joints_[i]; }
  Joint& joint(std::size_t i) { return joints_[i]; }
  const std::vector<Joint>& joints() const { return joints_; }

  // Index of a joint by canonical name, source name, segment name ("left_forearm") or alias.
  std::optional<int> find(std::string_view name) const;
  // Like find, but throws imukit::Error listing the known names.
  int index_of(std::string_view name) const;
  // Joints from the root down to j, root first.
  std::vector<int> chain(int j) const;
  std::vector<int> children(int j) const;
  // The segment's end in joint j's frame: the child joint the segment points to (the child on
  // the chain to the distal limb end: the one with the longest subtree, ties to the first), else
  // end_offset, else the continuation of the parent's offset. Zero for a lone root.
  Eigen::Vector3d segment_end(int j) const;
  // The child segment_end's segment points to, or -1 for a leaf. When that child sits at j's
  // origin the segment has no length (segment_end then falls back as for a leaf).
  int segment_child(int j) const;
  // Neutral-pose joint positions in the world frame (root at the origin).
  std::vector<Eigen::Vector3d> neutral_positions() const;
  // Unit forward direction of the body at the neutral pose: up x right, where right points from
  // the left hip (or shoulder) to the right one; +y when the body has neither pair.
  Eigen::Vector3d forward_direction() const;

  // A T-pose humanoid (arms along +-x, facing +y, z up) with 21 canonical joints, segment
  // lengths from anthropometric ratios of the stature (Winter, Biomechanics and Motor Control of
  // Human Movement, 4th ed., fig. 4.1). The root (pelvis) sits at the origin.
  static Body default_humanoid(double height_m = 1.75);

 private:
  std::vector<Joint> joints_;
};

// A body from explicit joints (scenes' "body": {"joints": [...]}, Python's Body.from_arrays):
// names (canonicalised through the alias table like BVH names, the given spelling kept as the
// source name), parent indices (-1 for the first joint only; each parent before its child) and
// offsets (3 x joints, m, in the parent's frame at the neutral pose). Throws imukit::Error,
// prefixed by `what`, naming the joint at fault.
Body body_from_joints(const std::vector<std::string>& names, const std::vector<int>& parents,
                      const Eigen::Ref<const Eigen::Matrix3Xd>& offsets, const std::string& what);

// Every canonical joint name (the default humanoid has all of them).
const std::vector<std::string>& canonical_joint_names();
// The segment a canonical joint carries ("left_elbow" -> "left_forearm"); empty if none.
std::string segment_name(std::string_view canonical_joint);
// Canonical names for a set of source joint names (same order): alias table with the CMU scheme
// detected from the set; unknown names, and second claims on a canonical name, keep the source
// name unchanged.
std::vector<std::string> canonicalize_joint_names(const std::vector<std::string>& source_names);

}  // namespace imukit::sim
