#include "imukit/sim/placement.hpp"

#include <gtest/gtest.h>
#include <array>

#include <map>
#include <numbers>
#include <string>

#include "imukit/core/error.hpp"

namespace imukit::sim {
namespace {

TEST(Placement, AllTwelvePresetsResolveOnTheDefaultHumanoid) {
  const Body b = Body::default_humanoid(1.75);
  EXPECT_EQ(placement_presets().size(), 12u);
  for (const PlacementPreset& p : placement_presets()) {
    const Placement pl = resolve_preset(p, b);
    EXPECT_NEAR(pl.q_joint_sensor.norm(), 1.0, 1e-15) << p.name;
    EXPECT_LT(pl.p_joint_sensor.norm(), 0.6) << p.name;
    EXPECT_GT(p.rotation_range_rad.minCoeff(), 0.0) << p.name;
  }
  EXPECT_THROW(placement_preset("left_sock"), Error);
}

TEST(Placement, WatchesSitAboveTheWristScreenUpInTPose) {
  const Body b = Body::default_humanoid(1.75);
  for (const char* name : {"left_wrist_watch", "right_wrist_watch"}) {
    const Placement pl = preset_placement(name, b);
    const bool left = name[0] == 'l';
    EXPECT_EQ(pl.joint, b.index_of(left ? "left_elbow" : "right_elbow"));
    const double forearm = 0.146 * 1.75;
    EXPECT_NEAR(pl.p_joint_sensor.x(), (left ? -1 : 1) * 0.92 * forearm, 1e-12) << name;
    EXPECT_NEAR(pl.p_joint_sensor.z(), 0.03, 1e-12) << name;  // on the back of the wrist, up
    // Screen (sensor z) up, sensor x along the forearm towards the hand.
    const Eigen::Matrix3d R = pl.q_joint_sensor.toRotationMatrix();
    EXPECT_NEAR((R.col(2) - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12) << name;
    EXPECT_NEAR((R.col(0) - Eigen::Vector3d::UnitX() * (left ? -1 : 1)).norm(), 0.0, 1e-12) << name;
  }
  const Placement inner = preset_placement("left_wrist_watch_inner", b);
  EXPECT_NEAR(inner.q_joint_sensor.toRotationMatrix()(2, 2), -1.0, 1e-12);
  // Earbuds: the left one on the subject's left (-x), pointing out of the ear.
  const Placement le = preset_placement("left_earbud", b);
  EXPECT_NEAR(le.p_joint_sensor.x(), -0.075, 1e-12);
  EXPECT_NEAR((le.q_joint_sensor.toRotationMatrix().col(2) + Eigen::Vector3d::UnitX()).norm(), 0.0,
              1e-12);
  // The ankle clip is on the outside of the right shank (+x).
  EXPECT_NEAR(preset_placement("right_ankle_clip", b).p_joint_sensor.x(), 0.04, 1e-12);
}

// describe_placement inverts resolve_preset on the same body (any joint, position and
// orientation), and on a taller body keeps the fraction along the segment, the offsets across it
// and the orientation relative to the anatomy.
TEST(Placement, DescribedPlacementsResolveBackAndCarryOverToOtherProportions) {
  const Body a = Body::default_humanoid(1.60);
  const Body b = Body::default_humanoid(1.95);
  const Eigen::Quaterniond turn =
      euler_to_quaternion(Eigen::Vector3d(10, -35, 170), "ZYX", true, true);
  for (const char* joint : {"left_elbow", "right_knee", "spine", "head"}) {
    Placement pl;
    pl.joint = a.index_of(joint);
    pl.p_joint_sensor = 0.6 * a.segment_end(pl.joint) + Eigen::Vector3d(0.01, -0.02, 0.03);
    pl.q_joint_sensor = turn;
    const PlacementPreset d = describe_placement(pl, a, "s");
    const Placement back = resolve_preset(d, a);
    EXPECT_EQ(back.joint, pl.joint);
    EXPECT_LT((back.p_joint_sensor - pl.p_joint_sensor).norm(), 1e-15) << joint;
    EXPECT_LT(back.q_joint_sensor.angularDistance(pl.q_joint_sensor), 1e-14) << joint;

    const Placement moved = resolve_preset(d, b);
    const Eigen::Matrix3d Fa = anatomical_frame(a, pl.joint), Fb = anatomical_frame(b, moved.joint);
    const Eigen::Vector3d pa = Fa.transpose() * pl.p_joint_sensor;
    const Eigen::Vector3d pb = Fb.transpose() * moved.p_joint_sensor;
    EXPECT_NEAR(pb.x() / b.segment_end(moved.joint).norm(), pa.x() / a.segment_end(pl.joint).norm(),
                1e-14)
        << joint;
    EXPECT_NEAR(pb.y(), pa.y(), 1e-15) << joint;
    EXPECT_NEAR(pb.z(), pa.z(), 1e-15) << joint;
    const Eigen::Matrix3d Ra = Fa.transpose() * pl.q_joint_sensor.toRotationMatrix();
    const Eigen::Matrix3d Rb = Fb.transpose() * moved.q_joint_sensor.toRotationMatrix();
    EXPECT_LT((Ra - Rb).norm(), 1e-14) << joint;
  }
}

TEST(Placement, PresetsNeedTheirSegment) {
  Body b;
  b.add_joint("pelvis", -1, Eigen::Vector3d::Zero());
  EXPECT_THROW(preset_placement("left_wrist_watch", b), Error);
  EXPECT_NO_THROW(preset_placement("waist_belt", b));
}

// A preset needs its segment's long axis. With the thigh's offset 0 (the knee on the hip) the
// pocket phone was silently laid crosswise -- L fell back to the hip's own offset from the
// pelvis -- and read gravity on -y instead of +x (found in review, 2026-11-26). Now an error
// names the sensor, the preset and the segment; a lone root still takes the trunk's axis (+z),
// and the same body with a 40 cm thigh places the phone with x along -L (up).
TEST(Placement, APresetOnAZeroLengthSegmentIsAnErrorNamingSensorPresetAndSegment) {
  for (const double thigh : {0.0, 0.4}) {
    Body b;
    b.add_joint("pelvis", -1, Eigen::Vector3d::Zero());
    b.add_joint("right_hip", 0, Eigen::Vector3d(-0.1, 0, 0));
    b.add_joint("right_knee", 1, Eigen::Vector3d(0, 0, -thigh));
    b.add_joint("right_ankle", 2, Eigen::Vector3d(0, 0, -0.4));
    if (thigh > 0.0) {
      const Placement p = preset_placement("right_front_pocket_phone", b, "phone");
      const Eigen::Vector3d x = p.q_joint_sensor.toRotationMatrix().col(0);
      EXPECT_LT((x - Eigen::Vector3d::UnitZ()).norm(), 0.3);  // about up (the preset's tilts)
      EXPECT_NEAR(p.p_joint_sensor.z(), -0.25 * thigh, 1e-15);
      continue;
    }
    try {
      (void)preset_placement("right_front_pocket_phone", b, "phone");
      ADD_FAILURE() << "placed on a zero-length thigh";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                "sensor 'phone': preset right_front_pocket_phone: segment 'right_hip' "
                "(right_thigh) has zero length (its next joint 'right_knee' sits on it, and the "
                "offset from 'pelvis' is no bone leading into it (the root, or a branching "
                "joint)): no long axis to place a sensor along");
    }
    EXPECT_THROW((void)anatomical_frame(b, 1), Error);
    Placement on_thigh;
    on_thigh.joint = 1;
    EXPECT_THROW((void)describe_placement(on_thigh, b, "s"), Error);
    // The other segments still carry presets.
    EXPECT_EQ(preset_placement("waist_belt", b, "belt").joint, 0);
  }
  // A zero-length segment after a bone that leads only into it takes that bone's axis (the CMU
  // skeleton's hand, whose finger joints sit on its origin): a ring on the forearm's line.
  {
    Body arm;
    arm.add_joint("pelvis", -1, Eigen::Vector3d::Zero());
    arm.add_joint("right_shoulder", 0, Eigen::Vector3d(-0.2, 0, 0.5));
    arm.add_joint("right_elbow", 1, Eigen::Vector3d(-0.3, 0, 0));
    arm.add_joint("right_wrist", 2, Eigen::Vector3d(-0.25, 0, 0));
    arm.add_joint("right_hand", 3, Eigen::Vector3d::Zero());  // a finger joint on its origin
    EXPECT_EQ(anatomical_frame(arm, 3).col(0), Eigen::Vector3d(-1, 0, 0));
    EXPECT_NO_THROW((void)preset_placement("right_index_ring", arm, "ring"));
  }
  // A lone root has no length either, but takes the trunk's axis.
  Body lone;
  lone.add_joint("pelvis", -1, Eigen::Vector3d::Zero());
  EXPECT_EQ(anatomical_frame(lone, 0).col(0), Eigen::Vector3d::UnitZ());
  EXPECT_EQ(preset_placement("waist_belt", lone, "belt").joint, 0);
}

TEST(Placement, EulerConventionsAreExplicit) {
  const Eigen::Vector3d a(0.1, -0.2, 0.3);
  const Eigen::Matrix3d X = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d Y = Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d Z = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_LT((euler_to_quaternion(a, "XYZ", true, false).toRotationMatrix() - X * Y * Z).norm(),
            1e-15);
  EXPECT_LT((euler_to_quaternion(a, "XYZ", false, false).toRotationMatrix() - Z * Y * X).norm(),
            1e-15);
  EXPECT_LT((euler_to_quaternion(a * 180 / std::numbers::pi, "xyz", true, true).toRotationMatrix() -
             X * Y * Z)
                .norm(),
            1e-14);
  // The reference simulator's placement (pytorch3d "XYZ") is intrinsic XYZ: its sceneA numbers.
  const Eigen::Quaterniond q = euler_to_quaternion(
      Eigen::Vector3d(0.17453292519943295, -0.3490658503988659, 0.5235987755982988), "XYZ", true,
      false);
  EXPECT_NEAR(q.w(), 0.9515485246437886, 1e-15);
  EXPECT_NEAR(q.y(), -0.18930785741199999, 1e-15);
  EXPECT_THROW(euler_to_quaternion(a, "XXY", true, false), Error);
  EXPECT_THROW(euler_to_quaternion(a, "XY", true, false), Error);
}

// vary_placement (PPDA's placement group). Draws, in order: swap (one index), shift (3), long
// axis (1), flip (1), rotations about sensor x, y, z (3, always).
Eigen::Matrix3d rotation_about(const Eigen::Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

TEST(VaryPlacement, EqualsTheRotationsComposedByHandInTheStatedOrder) {
  const Body b = Body::default_humanoid(1.75);
  const std::string name = "left_wrist_watch";
  const Placement p0 = preset_placement(name, b);
  PlacementVariation v;
  v.rotation_range_rad = Eigen::Vector3d(0.3, 0.2, 0.5);
  v.long_axis_range_rad = 0.4;
  v.flip = true;
  v.shift = true;
  int flipped = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    Rng rng(seed), ref(seed);
    std::string preset = name;
    const Placement p = vary_placement(p0, preset, v, b, rng);
    EXPECT_EQ(preset, name);
    // By hand from a second generator of the same seed.
    const Eigen::Vector3d range = placement_preset(name).position_range_m;
    const Eigen::Matrix3d lan = anatomical_frame(b, p0.joint);
    Eigen::Vector3d d;
    for (int k = 0; k < 3; ++k) d[k] = -range[k] + 2.0 * range[k] * ref.uniform();
    const Eigen::Matrix3d RL = rotation_about(lan.col(0), -0.4 + 0.8 * ref.uniform());
    const int flip_axis = static_cast<int>(4.0 * ref.uniform()) - 1;  // -1: no flip
    flipped += flip_axis >= 0 ? 1 : 0;
    Eigen::Matrix3d R = RL * p0.q_joint_sensor.toRotationMatrix();
    if (flip_axis >= 0) R = R * rotation_about(Eigen::Vector3d::Unit(flip_axis), std::numbers::pi);
    for (int k = 0; k < 3; ++k) {
      const double r = v.rotation_range_rad[k];
      R = R * rotation_about(Eigen::Vector3d::Unit(k), -r + 2.0 * r * ref.uniform());
    }
    EXPECT_LT((p.q_joint_sensor.toRotationMatrix() - R).norm(), 1e-14) << seed;
    EXPECT_NEAR(p.q_joint_sensor.norm(), 1.0, 1e-15) << seed;
    EXPECT_LT((p.p_joint_sensor - RL * (p0.p_joint_sensor + lan * d)).norm(), 1e-15) << seed;
    EXPECT_EQ(p.joint, p0.joint);
    EXPECT_EQ(rng.next_u64(), ref.next_u64()) << seed;  // the same number of draws
  }
  EXPECT_GT(flipped, 15);  // both branches seen (Binomial(40, 3/4): P(<= 15) < 1e-6)
  EXPECT_LT(flipped, 40);
}

TEST(VaryPlacement, ShiftStaysInsideThePresetsRangeAndCoversIt) {
  const Body b = Body::default_humanoid(1.75);
  for (const char* name : {"left_wrist_watch", "right_front_pocket_phone", "chest_strap"}) {
    const PlacementPreset& pp = placement_preset(name);
    const Placement p0 = resolve_preset(pp, b);
    const Eigen::Matrix3d lan = anatomical_frame(b, p0.joint);
    PlacementVariation v;
    v.shift = true;
    Rng rng(7);
    Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
    for (int i = 0; i < 2000; ++i) {
      std::string preset = name;
      const Placement p = vary_placement(p0, preset, v, b, rng);
      // The shift in (L, A, N); lan is orthonormal.
      const Eigen::Vector3d d = lan.transpose() * (p.p_joint_sensor - p0.p_joint_sensor);
      for (int k = 0; k < 3; ++k) {
        EXPECT_LE(std::abs(d[k]), pp.position_range_m[k] * (1.0 + 1e-12) + 1e-15) << name;
        lo[k] = std::min(lo[k], d[k]);
        hi[k] = std::max(hi[k], d[k]);
      }
      // Zero rotation ranges: the orientation stays (up to renormalisation).
      EXPECT_LT((p.q_joint_sensor.coeffs() - p0.q_joint_sensor.coeffs()).norm(), 1e-15) << name;
    }
    // Uniform over the range: 2000 draws reach within 1 % of both ends (miss chance 2e-9).
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(lo[k], -0.99 * pp.position_range_m[k]) << name << " axis " << k;
      EXPECT_GT(hi[k], 0.99 * pp.position_range_m[k]) << name << " axis " << k;
    }
  }
  // A sensor without a preset is not shifted, and the shift then draws nothing.
  const Placement p0 = preset_placement("left_wrist_watch", b);
  PlacementVariation v;
  v.shift = true;
  Rng rng(3), ref(3);
  std::string none;
  const Placement p = vary_placement(p0, none, v, b, rng);
  EXPECT_EQ(p.p_joint_sensor, p0.p_joint_sensor);
  for (int k = 0; k < 3; ++k) ref.uniform();  // only the three rotation draws
  EXPECT_EQ(rng.next_u64(), ref.next_u64());
}

// The paper's "discrete 180-degree flips along each axis": none, or a half turn about the
// sensor's x, y or z, a quarter of the draws each. Only z turned until review, 2026-11-27, so a
// sensor was never mounted upside down.
TEST(VaryPlacement, FlipIsNoneOrAHalfTurnAboutEachSensorAxisAQuarterOfTheTime) {
  const Body b = Body::default_humanoid(1.75);
  const Placement p0 = preset_placement("right_wrist_watch", b);
  const Eigen::Matrix3d R0 = p0.q_joint_sensor.toRotationMatrix();
  PlacementVariation v;
  v.flip = true;
  Rng rng(11);
  std::array<int, 4> seen{};  // none, about x, about y, about z
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    std::string preset = "right_wrist_watch";
    const Placement p = vary_placement(p0, preset, v, b, rng);
    EXPECT_EQ(p.p_joint_sensor, p0.p_joint_sensor);
    // In the sensor's own frame the change is diag(+-1, +-1, +-1) with one axis kept (or all).
    const Eigen::Matrix3d D = R0.transpose() * p.q_joint_sensor.toRotationMatrix();
    int kept = -1, outcome = -1;
    for (int k = 0; k < 3; ++k)
      if (D(k, k) > 0.0) kept = kept < 0 ? k : 3;  // 3: more than one axis kept
    if (kept == 3) {
      outcome = 0;
      EXPECT_LT((D - Eigen::Matrix3d::Identity()).norm(), 1e-14) << i;
    } else {
      ASSERT_GE(kept, 0) << i;  // a proper rotation keeps at least one axis
      outcome = 1 + kept;
      const Eigen::Matrix3d half = rotation_about(Eigen::Vector3d::Unit(kept), std::numbers::pi);
      EXPECT_LT((D - half).norm(), 1e-14) << i;
    }
    ++seen[static_cast<std::size_t>(outcome)];
  }
  // Multinomial(4000, 1/4 each): sigma = 27.4; 5 sigma.
  for (int count : seen) EXPECT_NEAR(count, n / 4, 137);
}

TEST(VaryPlacement, SwapRenamesThePresetAndResolvesIt) {
  const Body b = Body::default_humanoid(1.75);
  PlacementVariation v;
  v.swap_presets = {"left_wrist_watch", "right_wrist_watch", "right_front_pocket_phone"};
  EXPECT_FALSE(v.keeps_position());
  const Placement p0 = preset_placement("left_wrist_watch", b);
  std::map<std::string, int> seen;
  Rng rng(5);
  for (int i = 0; i < 300; ++i) {
    std::string preset = "left_wrist_watch";
    const Placement p = vary_placement(p0, preset, v, b, rng);
    ++seen[preset];
    const Placement want = preset_placement(preset, b);
    EXPECT_EQ(p.joint, want.joint) << preset;
    EXPECT_EQ(p.p_joint_sensor, want.p_joint_sensor) << preset;
    EXPECT_LT((p.q_joint_sensor.coeffs() - want.q_joint_sensor.coeffs()).norm(), 1e-15) << preset;
  }
  EXPECT_EQ(seen.size(), 3u);
  for (const auto& [name, count] : seen) EXPECT_GT(count, 60) << name;  // 100 expected
  // A preset not in the list (or none) is not swapped: no index draw.
  Rng rng2(5), ref(5);
  std::string other = "chest_strap";
  const Placement chest = preset_placement(other, b);
  const Placement p = vary_placement(chest, other, v, b, rng2);
  EXPECT_EQ(other, "chest_strap");
  EXPECT_EQ(p.p_joint_sensor, chest.p_joint_sensor);
  for (int k = 0; k < 3; ++k) ref.uniform();
  EXPECT_EQ(rng2.next_u64(), ref.next_u64());
}

TEST(VaryPlacement, KeepsPositionOnlyWithoutSwapShiftOrLongAxisTurn) {
  PlacementVariation v;
  v.rotation_range_rad = Eigen::Vector3d::Constant(1.0);
  v.flip = true;
  EXPECT_TRUE(v.keeps_position());
  PlacementVariation shift = v;
  shift.shift = true;
  EXPECT_FALSE(shift.keeps_position());
  PlacementVariation turn = v;
  turn.long_axis_range_rad = 0.1;
  EXPECT_FALSE(turn.keeps_position());
}

}  // namespace
}  // namespace imukit::sim
