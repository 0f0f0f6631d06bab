#include "imukit/sim/body.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"

namespace imukit::sim {
namespace {

TEST(Body, DefaultHumanoidHasTheCanonicalJointsScaledByHeight) {
  const Body b = Body::default_humanoid(1.75);
  EXPECT_EQ(b.size(), 21u);
  for (const std::string& n : canonical_joint_names()) EXPECT_TRUE(b.find(n).has_value()) << n;
  const Body tall = Body::default_humanoid(2.0);
  for (std::size_t j = 0; j < b.size(); ++j) {
    EXPECT_NEAR(
        (tall.joint(j).offset_parent_joint - b.joint(j).offset_parent_joint * (2.0 / 1.75)).norm(),
        0.0, 1e-15);
  }
  // Shoulder at 0.818 H above the ground: 0.818 H - 0.56 H above the pelvis root.
  const auto p = b.neutral_positions();
  EXPECT_NEAR(p[static_cast<std::size_t>(b.index_of("left_shoulder"))].z(), (0.818 - 0.56) * 1.75,
              1e-12);
  EXPECT_NEAR(p[static_cast<std::size_t>(b.index_of("left_ankle"))].z(), (0.039 - 0.56) * 1.75,
              1e-12);
  // Facing +y, left on -x.
  EXPECT_NEAR((b.forward_direction() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-15);
  EXPECT_LT(p[static_cast<std::size_t>(b.index_of("left_wrist"))].x(), -0.5);
  EXPECT_THROW(Body::default_humanoid(0.0), Error);
}

TEST(Body, FindsJointsBySegmentNameAndAlias) {
  const Body b = Body::default_humanoid();
  EXPECT_EQ(b.find("left_forearm"), b.find("left_elbow"));
  EXPECT_EQ(b.find("L_ELBOW"), b.find("left_elbow"));
  EXPECT_EQ(b.find("Hips"), b.find("pelvis"));
  EXPECT_FALSE(b.find("tail").has_value());
  EXPECT_THROW(b.index_of("tail"), Error);
  EXPECT_EQ(b.chain(b.index_of("left_wrist")).size(), 7u);
}

TEST(Body, SegmentNamedLikeItsJointIsNotFoundOnABodyWithoutTheJoint) {
  // pelvis, neck, head and the clavicles name both a joint and its segment; looking one up on a
  // body without that joint used to recurse until the stack overflowed (a scene's "segment":
  // "head" on a one-joint body, or a quaternion-CSV column for a missing joint).
  Body b;
  b.add_joint("root", -1, Eigen::Vector3d::Zero());
  b.add_joint("arm", 0, Eigen::Vector3d(0.3, 0.0, 0.0));
  for (const char* name : {"pelvis", "neck", "head", "left_clavicle", "right_clavicle", "HEAD"}) {
    EXPECT_FALSE(b.find(name).has_value()) << name;
    EXPECT_THROW(b.index_of(name), Error) << name;
  }
  // A segment whose joint has another name still resolves through it.
  Body c;
  c.add_joint("left_elbow", -1, Eigen::Vector3d::Zero());
  EXPECT_EQ(c.find("left_forearm"), std::optional<int>(0));
  EXPECT_FALSE(c.find("left_upper_arm").has_value());
}

TEST(Body, AliasTableMapsBothCmuSchemes) {
  const std::vector<std::string> max = {
      "Hips",   "LHipJoint",  "LeftHip",      "LeftKnee",  "LeftAnkle", "lowerback", "Chest",
      "Chest2", "LeftCollar", "LeftShoulder", "LeftElbow", "LeftWrist", "Neck",      "Head"};
  const std::vector<std::string> max_c = canonicalize_joint_names(max);
  EXPECT_EQ(max_c,
            (std::vector<std::string>{"pelvis", "LHipJoint", "left_hip", "left_knee", "left_ankle",
                                      "spine", "chest", "Chest2", "left_clavicle", "left_shoulder",
                                      "left_elbow", "left_wrist", "neck", "head"}));
  const std::vector<std::string> mb = {"Hips",         "LeftUpLeg", "LeftLeg",     "LeftFoot",
                                       "LeftToeBase",  "LowerBack", "Spine",       "Spine1",
                                       "LeftShoulder", "LeftArm",   "LeftForeArm", "LeftHand",
                                       "Neck",         "Neck1",     "Head"};
  EXPECT_EQ(canonicalize_joint_names(mb),
            (std::vector<std::string>{"pelvis", "left_hip", "left_knee", "left_ankle", "left_toe",
                                      "spine", "Spine", "chest", "left_clavicle", "left_shoulder",
                                      "left_elbow", "left_wrist", "neck", "Neck1", "head"}));
  EXPECT_EQ(segment_name("left_elbow"), "left_forearm");
}

TEST(Body, RejectsDuplicateNames) {
  Body b;
  b.add_joint("a", -1, Eigen::Vector3d::Zero());
  EXPECT_THROW(b.add_joint("a", 0, Eigen::Vector3d::Zero()), Error);
  EXPECT_THROW(b.add_joint("b", 0, Eigen::Vector3d(NAN, 0, 0)), Error);
}

}  // namespace
}  // namespace imukit::sim
