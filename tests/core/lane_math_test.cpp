#include "imukit/core/lane_math.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "imukit/core/rng.hpp"
#include "support/numbers.hpp"

namespace imukit::lane {
namespace {

TEST(LaneMath, RoundSmallIsExactRoundingToNearestEven) {
  EXPECT_EQ(round_small(2.5), 2.0);
  EXPECT_EQ(round_small(3.5), 4.0);
  EXPECT_EQ(round_small(-2.5), -2.0);
  EXPECT_EQ(round_small(-0.4999999999999999), 0.0);
  EXPECT_EQ(round_small(1e15 + 0.75), 1e15 + 1.0);
}

// Against libm over the whole first quadrant, with both arguments scaled over many decades and
// the edges (0, equal arguments, one tiny) included: within 3 eps relative.
TEST(LaneMath, Atan2FirstQuadrantMatchesLibm) {
  Rng rng(5);
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double scale = std::pow(10.0, rng.uniform() * 12.0 - 6.0);
    double y = rng.uniform() * scale, x = rng.uniform() * scale;
    if (i % 7 == 0) y = x;
    if (i % 11 == 0) y = 0.0;
    if (i % 13 == 0) x = 1e-300 * rng.uniform();
    if (x == 0.0 && y == 0.0) continue;
    const double ref = std::atan2(y, x);
    const double got = atan2_first_quadrant(y, x);
    worst = std::max(worst, std::abs(got - ref) / std::max(ref, 1e-300));
    if (ref > 0.0) {
      ASSERT_LE(std::abs(got - ref), 3.0 * kEps * ref) << y << " " << x;
    } else {
      ASSERT_EQ(got, 0.0);
    }
  }
  EXPECT_NEAR(atan2_first_quadrant(1.0, 1.0), std::numbers::pi / 4, kEps);
  EXPECT_EQ(atan2_first_quadrant(1.0, 0.0), std::numbers::pi / 2);
  EXPECT_LE(worst, 3.0 * kEps);
}

// sin and cos within 2e-16 absolute (and the small sines relative) of libm for |x| < 1e4,
// across every quadrant boundary, and exact signs and values at 0.
TEST(LaneMath, SinCosMatchesLibm) {
  Rng rng(6);
  for (int i = 0; i < 200000; ++i) {
    const double x = (rng.uniform() * 2.0 - 1.0) * (i % 2 == 0 ? 8.0 : 1e4);
    const SinCos sc = sincos_small(x);
    ASSERT_NEAR(sc.sin, std::sin(x), 2.5e-16 * std::max(1.0, std::abs(x) * 1e-3)) << x;
    ASSERT_NEAR(sc.cos, std::cos(x), 2.5e-16 * std::max(1.0, std::abs(x) * 1e-3)) << x;
  }
  for (int k = -40; k <= 40; ++k) {
    for (const double d : {-1e-9, 0.0, 1e-9}) {
      const double x = k * std::numbers::pi / 2 + d;
      ASSERT_NEAR(sincos_small(x).sin, std::sin(x), 4e-16) << x;
      ASSERT_NEAR(sincos_small(x).cos, std::cos(x), 4e-16) << x;
    }
  }
  for (const double x : {1e-300, 1e-12, 1e-6, -1e-6, 1e-3}) {
    EXPECT_NEAR(sincos_small(x).sin, std::sin(x), kEps * std::abs(x)) << x;
    EXPECT_NEAR(sincos_small(x).cos, std::cos(x), kEps) << x;
  }
  EXPECT_EQ(sincos_small(0.0).sin, 0.0);
  EXPECT_EQ(sincos_small(0.0).cos, 1.0);
}

}  // namespace
}  // namespace imukit::lane
