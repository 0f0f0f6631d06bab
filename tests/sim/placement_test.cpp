#include "sim/placement.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include "core/error.hpp"

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
    const Placement pl = resolve_preset(placement_preset(name), b);
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
  const Placement inner = resolve_preset(placement_preset("left_wrist_watch_inner"), b);
  EXPECT_NEAR(inner.q_joint_sensor.toRotationMatrix()(2, 2), -1.0, 1e-12);
  // Earbuds: the left one on the subject's left (-x), pointing out of the ear.
  const Placement le = resolve_preset(placement_preset("left_earbud"), b);
  EXPECT_NEAR(le.p_joint_sensor.x(), -0.075, 1e-12);
  EXPECT_NEAR((le.q_joint_sensor.toRotationMatrix().col(2) + Eigen::Vector3d::UnitX()).norm(), 0.0,
              1e-12);
  // The ankle clip is on the outside of the right shank (+x).
  EXPECT_NEAR(resolve_preset(placement_preset("right_ankle_clip"), b).p_joint_sensor.x(), 0.04,
              1e-12);
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
  EXPECT_THROW(resolve_preset(placement_preset("left_wrist_watch"), b), Error);
  EXPECT_NO_THROW(resolve_preset(placement_preset("waist_belt"), b));
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

}  // namespace
}  // namespace imukit::sim
