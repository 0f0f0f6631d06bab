// Placement (seed-summary section 1, "Placement P"): where a sensor sits on the body: the joint
// whose segment carries it, its position in that joint's frame (m) and its orientation
// q_joint_sensor (a vector in sensor axes maps to joint axes by R_joint_sensor).
//
// Presets describe common wearables in the *anatomical frame* of their segment, so that they
// fit any body whose segments are named (the default humanoid, a BVH skeleton, the reference
// body). The anatomical frame of joint j, built from the body's neutral pose:
//   L  long axis, unit vector from the joint to the segment's end (Body::segment_end),
//   A  anterior: the body's forward direction with its L component removed (the body's up
//      when L is parallel to forward, e.g. a foot),
//   N  = s (L x A), s = -1 on left_ segments and +1 otherwise: for T-pose arms N points up
//      (the back of the hand, palm down), for legs it points laterally (away from the midline),
//      for the trunk and head towards the subject's left.
// A preset gives the position as a fraction along L plus offsets along A and N (m), and the
// sensor's x and z axes in (L, A, N) coordinates (y = z x x). Each preset also states the range
// over which the placement plausibly varies (uniform half-widths; used by augmentation).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/rng.hpp"
#include "imukit/sim/body.hpp"

namespace imukit::sim {

struct Placement {
  int joint = -1;
  Eigen::Vector3d p_joint_sensor = Eigen::Vector3d::Zero();            // m
  Eigen::Quaterniond q_joint_sensor = Eigen::Quaterniond::Identity();  // unit
};

struct PlacementPreset {
  std::string name;
  std::string description;
  std::string joint;        // canonical joint whose segment carries the sensor
  double along = 0.0;       // fraction of the segment from the joint towards its end
  double anterior_m = 0.0;  // offset along A
  double normal_m = 0.0;    // offset along N
  Eigen::Vector3d sensor_x_lan = Eigen::Vector3d::UnitX();  // sensor x in (L, A, N)
  Eigen::Vector3d sensor_z_lan = Eigen::Vector3d::UnitZ();  // sensor z in (L, A, N)
  // Plausible variation (uniform half-widths): position along L, A, N (m) and rotation about
  // the sensor's x, y, z axes (rad).
  Eigen::Vector3d position_range_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_range_rad = Eigen::Vector3d::Zero();
};

const std::vector<PlacementPreset>& placement_presets();
// Throws imukit::Error listing the preset names when `name` is unknown.
const PlacementPreset& placement_preset(std::string_view name);

// The anatomical frame (columns L, A, N) of joint j, in the joint's frame. A root without length
// takes the trunk's axis (+z) as L; any other segment of zero length (its limb's next joint on
// its origin) has no L: imukit::Error naming the segment.
Eigen::Matrix3d anatomical_frame(const Body& body, int joint);

// The preset on this body. Throws imukit::Error if the body has no such segment or it has zero
// length (not a root), naming the sensor (when given and not the preset's own name), the preset
// and the segment.
Placement resolve_preset(const PlacementPreset& preset, const Body& body,
                         std::string_view sensor = {});
// The preset called `preset` on this body (unknown names and missing segments throw, as above).
Placement preset_placement(std::string_view preset, const Body& body, std::string_view sensor = {});

// The inverse: `placement` on `body` as a preset named `name` (its segment's canonical joint, the
// position as a fraction along the segment plus offsets across it, the axes in the anatomical
// frame; no ranges), so that resolve_preset carries it over to a body of other proportions -- a
// watch 80 % down one subject's forearm sits 80 % down another's. Throws imukit::Error for a
// segment of zero length (no long axis to measure along).
PlacementPreset describe_placement(const Placement& placement, const Body& body, std::string name);

// How a placement varies for augmentation (PPDA's placement group, seed-summary section 2),
// applied by vary_placement in this order: swap to a preset drawn from swap_presets (when the
// sensor's preset is one of them), shift within the preset's position range (L, A, N), rotation
// about the segment's long axis L, flip (none, or 180 deg about the sensor's x, y or z: 1/4 each),
// rotation about the sensor's x, y, z (three draws always). Rotations are composed, never added
// as angles:
// q_joint_sensor' = R_L q_joint_sensor R_flip Rx Ry Rz.
struct PlacementVariation {
  Eigen::Vector3d rotation_range_rad = Eigen::Vector3d::Zero();  // U[-r, r] about sensor x, y, z
  double long_axis_range_rad = 0.0;  // extra U[-r, r] about the segment's long axis (0 = off)
  bool flip = false;  // none or 180 degrees about the sensor's x, y or z, probability 1/4 each
  // Shift within the preset's position range (sensors without a preset stay).
  bool shift = false;
  // Swap: a sensor whose preset is in this list is moved to a preset drawn uniformly from it.
  std::vector<std::string> swap_presets;
  // True when the variation never moves a sensor's position: no swap, no shift, no long-axis turn.
  bool keeps_position() const;
  bool operator==(const PlacementVariation&) const = default;
};

// `placement` varied by `v`, drawing from rng in the order above. `preset` is the sensor's preset
// name ("" for none); it is updated when the sensor is swapped to another preset.
Placement vary_placement(Placement placement, std::string& preset, const PlacementVariation& v,
                         const Body& body, Rng& rng);

// Euler angles -> quaternion with the convention spelled out (DESIGN.md): `order` a permutation
// or repetition of three axes from "XYZ" ("ZYX", "ZXZ", ...), intrinsic (each rotation about the
// already rotated axes: R = R1(a1) R2(a2) R3(a3)) or extrinsic (fixed axes: R = R3 R2 R1),
// angles in rad or deg. Throws imukit::Error for a malformed order.
Eigen::Quaterniond euler_to_quaternion(const Eigen::Vector3d& angles, std::string_view order,
                                       bool intrinsic, bool degrees);

}  // namespace imukit::sim
