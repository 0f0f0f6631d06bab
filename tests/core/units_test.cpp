#include "imukit/core/units.hpp"

#include <gtest/gtest.h>

namespace imukit {
namespace {

TEST(Units, StandardGravityIsTheDefinedValue) {
  // Exact: 9.80665 m/s^2 is a definition, so the double must be the literal's nearest double.
  static_assert(kStandardGravity == 9.80665);
  EXPECT_EQ(kStandardGravityWorld.x(), 0.0);
  EXPECT_EQ(kStandardGravityWorld.y(), 0.0);
  EXPECT_EQ(kStandardGravityWorld.z(), -9.80665);
  EXPECT_EQ(kStandardGravityWorld.norm(), 9.80665);
}

}  // namespace
}  // namespace imukit
