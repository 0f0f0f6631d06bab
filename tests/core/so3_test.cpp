#include "imukit/core/so3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "imukit/core/rng.hpp"
#include "support/numbers.hpp"

namespace imukit {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// Results that pass through several roundings (a log, an exp, a product, sin/cos of libm) are
// compared at 8 eps = 1.8e-15. Each use notes the worst error measured over 3e5 random cases
// with g++ 12 and clang 14 (glibc libm); the margin covers other compilers and libms.
constexpr double kCompound = 8.0 * kEps;

Vector3d random_axis(Rng& rng) {
  Vector3d v(rng.normal(), rng.normal(), rng.normal());
  return v / v.norm();
}

Quaterniond random_quaternion(Rng& rng) {
  Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  q.normalize();
  return q;
}

// Largest absolute difference of the coefficients.
double max_diff(const Quaterniond& a, const Quaterniond& b) {
  return (a.coeffs() - b.coeffs()).cwiseAbs().maxCoeff();
}

// Same rotation: equal up to the sign of the quaternion.
double max_diff_up_to_sign(const Quaterniond& a, const Quaterniond& b) {
  return std::min(max_diff(a, b), (a.coeffs() + b.coeffs()).cwiseAbs().maxCoeff());
}

// Angles log-spaced from 1e-12 to pi - 1e-9, plus the series thresholds' neighbourhoods.
std::vector<double> test_angles() {
  std::vector<double> angles;
  for (int k = 0; k <= 120; ++k) angles.push_back(1e-12 * std::pow(10.0, k / 10.0));  // to 1
  for (double a = 1.05; a < kPi - 1e-3; a += 0.05) angles.push_back(a);
  for (double d = 1e-3; d >= 1e-9; d /= 10.0) angles.push_back(kPi - d);
  for (double a : {1e-2, 2e-2, 0.5, 1.0}) {
    angles.push_back(a * (1.0 - 1e-12));
    angles.push_back(a * (1.0 + 1e-12));
  }
  return angles;
}

TEST(So3ExpLog, LogOfExpReturnsTheRotationVector) {
  Rng rng(1);
  const std::vector<double> angles = test_angles();
  double worst = 0.0;
  for (int axis_index = 0; axis_index < 50; ++axis_index) {
    const Vector3d u = random_axis(rng);
    for (double theta : angles) {
      const Vector3d v = theta * u;
      const Vector3d back = so3_log(so3_exp(v));
      const double rel = (back - v).norm() / theta;
      // A few ulp relative at every angle (worst measured over 2000 axes: 1.5 eps), near pi too:
      // atan2(|v|, w) on the canonical sign is well conditioned at both ends, where acos(w)
      // (small angles, w -> 1) or asin(|v|) (near pi, |v| -> 1) would lose half the digits.
      // What is ill-conditioned at pi is the choice between v and -v (the branch cut where w
      // changes sign): a perturbation of eps in w near pi flips the result. So the sweep stops at
      // pi - 1e-9 and the exact-pi tie-break is tested in QAndMinusQHaveTheSameLog.
      ASSERT_LE(rel, 4.0 * kEps) << "theta = " << theta;
      worst = std::max(worst, rel);
    }
  }
  RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(So3ExpLog, ExpOfLogIsTheSameQuaternionUpToSign) {
  Rng rng(2);
  for (int i = 0; i < 10000; ++i) {
    const Quaterniond q = random_quaternion(rng);  // both signs of w
    const Quaterniond back = so3_exp(so3_log(q));
    // Worst measured over 1e6 quaternions: 2.5 eps.
    ASSERT_LE(max_diff(back, canonical(q)), kCompound) << i;
    ASSERT_LE(max_diff_up_to_sign(back, q), kCompound) << i;
  }
}

TEST(So3ExpLog, QAndMinusQHaveTheSameLog) {
  Rng rng(3);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q = random_quaternion(rng);
    Quaterniond minus_q;
    minus_q.coeffs() = -q.coeffs();
    const Vector3d a = so3_log(q);
    const Vector3d b = so3_log(minus_q);
    ASSERT_EQ(a, b);  // bit for bit: both go through the same canonical quaternion
    ASSERT_LE(a.norm(), kPi);
  }
  // Exactly pi (w == 0): the documented tie-break (first non-zero of x, y, z positive) makes the
  // two signs agree too.
  const Quaterniond half_turn(0.0, 0.0, -0.6, 0.8);
  Quaterniond minus_half_turn;
  minus_half_turn.coeffs() = -half_turn.coeffs();
  const Vector3d expected = kPi * Vector3d(0.0, 0.6, -0.8);
  EXPECT_LE((so3_log(half_turn) - expected).norm(), 2.0 * kEps * kPi);
  EXPECT_EQ(so3_log(half_turn), so3_log(minus_half_turn));
}

TEST(So3ExpLog, LogReturnsTheShortestRotation) {
  // exp of 1.5 pi about u is the rotation of 0.5 pi about -u (w = cos(0.75 pi) < 0).
  const Vector3d u = Vector3d(1.0, 2.0, 2.0) / 3.0;
  const Quaterniond q = so3_exp(1.5 * kPi * u);
  EXPECT_LT(q.w(), 0.0);
  EXPECT_LE((so3_log(q) - (-0.5 * kPi) * u).norm(), 4.0 * kEps);
  // Angle 2 pi is the identity; the rounding of |2 pi u| (a few ulp of 2 pi) is all that is left.
  EXPECT_LE(so3_log(so3_exp(2.0 * kPi * u)).norm(), 4.0 * kEps * 2.0 * kPi);
}

TEST(So3ExpLog, SmallAnglesKeepFullRelativeAccuracy) {
  const Vector3d u = Vector3d(2.0, -3.0, 6.0) / 7.0;
  for (double theta : {1e-300, 1e-200, 1e-100, 1e-30, 1e-12, 1e-8, 1e-5, 9.99e-3, 1.001e-2}) {
    const Vector3d v = theta * u;
    const Quaterniond q = so3_exp(v);
    // Reference from the closed form in long double (64-bit mantissa on x86; sin is exact to
    // far below an ulp of double there).
    const long double half = 0.5L * static_cast<long double>(theta);
    const long double factor = std::sin(half) / static_cast<long double>(theta);
    EXPECT_LE(std::abs(static_cast<long double>(q.w()) - std::cos(half)), kEps) << theta;
    for (int k = 0; k < 3; ++k) {
      const long double expected = static_cast<long double>(v[k]) * factor;
      EXPECT_LE(std::abs((static_cast<long double>(q.vec()[k]) - expected) / expected), 2.0L * kEps)
          << theta;
    }
    const Vector3d back = so3_log(q);
    EXPECT_LE((back - v).norm(), 2.0 * kEps * theta) << theta;
  }
  // No NaN and the exact identity at zero.
  const Quaterniond id = so3_exp(Vector3d::Zero());
  EXPECT_EQ(id.w(), 1.0);
  EXPECT_EQ(id.vec(), Vector3d::Zero());
  EXPECT_EQ(so3_log(Quaterniond::Identity()), Vector3d::Zero());
}

TEST(So3ExpLog, LogIsAccurateNearPi) {
  const Vector3d u = Vector3d(1.0, -4.0, 8.0) / 9.0;
  // q = (w, u * sqrt(1 - w^2)) with tiny w: angle = 2 atan2(sqrt(1 - w^2), w) = pi - 2 asin(w).
  for (double w : {1e-3, 1e-6, 1e-9, 1e-12, 1e-15, 1e-300}) {
    const double s = std::sqrt(1.0 - w * w);
    const Quaterniond q(w, s * u.x(), s * u.y(), s * u.z());
    const Vector3d v = so3_log(q);
    const double expected_angle = kPi - 2.0 * std::asin(w);
    // Absolute angle error at most a few ulp of pi: acos(w) would lose ~1e-8 here.
    EXPECT_NEAR(v.norm(), expected_angle, 4.0 * kEps) << w;
    EXPECT_LE((v / v.norm() - u).norm(), 4.0 * kEps) << w;
  }
}

TEST(So3ExpLog, NonUnitQuaternionsAreTreatedAsNormalised) {
  Rng rng(4);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q = random_quaternion(rng);
    for (double scale : {1e-3, 0.5, 2.5, 1e4}) {
      Quaterniond scaled;
      scaled.coeffs() = scale * q.coeffs();
      ASSERT_LE((so3_log(scaled) - so3_log(q)).norm(), 8.0 * kEps) << scale;
    }
  }
}

// Found in review: at |q| = 1e-160 so3_log of a 90 degree turn was off by 3e-6, at 1e-200 it
// asserted, and angular_distance asserted at 1e-150 (squared norms underflowed). Every scale a
// double holds gives the exact results to within 1e-15 relative.
TEST(So3ExpLog, EveryScaleFrom1em300To1e300GivesTheExactResult) {
  const double h = std::sqrt(0.5);
  const Quaterniond x90(h, h, 0.0, 0.0);                  // 90 degrees about x
  const Quaterniond z60(std::sqrt(0.75), 0.0, 0.0, 0.5);  // 60 degrees about z
  const auto scaled = [](const Quaterniond& q, double s) {
    Quaterniond out;
    out.coeffs() = s * q.coeffs();
    return out;
  };
  const auto near = [](double got, double exact) {
    return std::abs(got - exact) <= 1e-15 * std::abs(exact);
  };
  for (int e = -300; e <= 300; e += 5) {
    const double s = std::pow(10.0, e);
    const Vector3d log = so3_log(scaled(x90, s));
    EXPECT_TRUE(near(log.x(), kPi / 2) && log.y() == 0.0 && log.z() == 0.0)
        << "1e" << e << ": " << log.transpose();
    // cos(angle / 2) = x90 . z60.
    EXPECT_TRUE(near(angular_distance(scaled(x90, s), scaled(z60, 1.0 / s)),
                     2.0 * std::acos(h * std::sqrt(0.75))))
        << "1e" << e;
    EXPECT_LE(angular_distance(scaled(x90, s), scaled(x90, -s)), 1e-15) << "1e" << e;
    const Quaterniond half = scale_rotation(scaled(x90, s), 0.5);  // 45 degrees about x
    EXPECT_TRUE(near(half.w(), std::cos(kPi / 8)) && near(half.x(), std::sin(kPi / 8)))
        << "1e" << e;
    const Quaterniond mid = slerp(scaled(Quaterniond::Identity(), s), scaled(x90, s), 0.5);
    EXPECT_TRUE(near(mid.w(), std::cos(kPi / 8)) && near(mid.x(), std::sin(kPi / 8))) << "1e" << e;
  }
  // The extremes of the range: the smallest subnormal and the largest double.
  const Vector3d tiny = so3_log(scaled(x90, std::numeric_limits<double>::denorm_min() / h));
  const Vector3d huge = so3_log(scaled(x90, std::numeric_limits<double>::max()));
  EXPECT_TRUE(near(tiny.x(), kPi / 2)) << tiny.x();
  EXPECT_TRUE(near(huge.x(), kPi / 2)) << huge.x();
}

TEST(Slerp, EndpointsAreExact) {
  Rng rng(5);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q0 = random_quaternion(rng);
    const Quaterniond q1 = random_quaternion(rng);
    const Quaterniond a = slerp(q0, q1, 0.0);
    const Quaterniond b = slerp(q0, q1, 1.0);
    // Bit for bit: the input at t = 0, the input or its negation (short arc) at t = 1.
    ASSERT_EQ(a.coeffs(), q0.coeffs());
    if (q0.dot(q1) >= 0.0) {
      ASSERT_EQ(b.coeffs(), q1.coeffs());
    } else {
      ASSERT_EQ(b.coeffs(), (-q1.coeffs()).eval());
    }
  }
}

TEST(Slerp, MatchesTheClosedFormOnAKnownPair) {
  // Identity to 120 degrees about z: the midpoint is 60 degrees about z, (cos 30, 0, 0, sin 30).
  const Quaterniond q0 = Quaterniond::Identity();
  const Quaterniond q1(std::cos(kPi / 3.0), 0.0, 0.0, std::sin(kPi / 3.0));
  const Quaterniond mid = slerp(q0, q1, 0.5);
  EXPECT_NEAR(mid.w(), std::sqrt(3.0) / 2.0, 2.0 * kEps);
  EXPECT_NEAR(mid.x(), 0.0, 1e-300);
  EXPECT_NEAR(mid.y(), 0.0, 1e-300);
  EXPECT_NEAR(mid.z(), 0.5, 2.0 * kEps);

  // General pairs against Shoemake's formula (sin((1-t) W) q0 + sin(t W) q1) / sin W, cos W =
  // q0 . q1 >= 0, for angles well away from 0 where that formula is itself accurate.
  Rng rng(6);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q0r = random_quaternion(rng);
    Quaterniond q1r = random_quaternion(rng);
    if (q0r.dot(q1r) < 0.0) q1r.coeffs() = -q1r.coeffs();
    const double omega = std::acos(std::min(1.0, q0r.dot(q1r)));
    if (omega < 0.1) continue;
    for (double t : {0.1, 0.25, 0.5, 0.9}) {
      Quaterniond expected;
      expected.coeffs() =
          (std::sin((1.0 - t) * omega) * q0r.coeffs() + std::sin(t * omega) * q1r.coeffs()) /
          std::sin(omega);
      // Worst measured 3 eps (both sides round).
      ASSERT_LE(max_diff(slerp(q0r, q1r, t), expected), kCompound) << i << " t " << t;
    }
  }
}

// Close inputs are where a slerp is tempted to fall back to a lerp (the reference's defect 5:
// plain lerp without renormalisation when q0 . q1 > 0.9995, i.e. below 0.063 rad). At 0.06 rad a
// plain lerp is 1.1e-4 short of unit norm at t = 1/2 and a renormalised one (nlerp) is off the
// geodesic by ~4e-7 at t = 1/4, so both fail here; from 1e-10 rad up the result must stay unit and
// on the geodesic.
TEST(Slerp, StaysAccurateForNearlyIdenticalQuaternions) {
  Rng rng(7);
  for (double angle : {1e-10, 1e-6, 1e-3, 0.03, 0.06}) {
    for (int i = 0; i < 1000; ++i) {
      const Quaterniond q0 = random_quaternion(rng);
      const Vector3d u = random_axis(rng);
      const Quaterniond q1 = q0 * so3_exp(angle * u);
      for (double t : {0.25, 0.5, 0.75}) {
        const Quaterniond q = slerp(q0, q1, t);
        ASSERT_NEAR(q.norm(), 1.0, 4.0 * kEps) << angle;  // worst measured 1.5 eps
        // The inputs carry an absolute rounding error of about eps each, so the interpolated
        // rotation can only be known to that level (for 1e-10 rad, a relative 1e-6 of the step).
        // Worst measured 1.5 eps.
        ASSERT_LE(max_diff(q, q0 * so3_exp(t * angle * u)), kCompound) << angle << " " << i;
      }
    }
  }
}

TEST(Slerp, TakesTheShortWayAcrossANegativeDotProduct) {
  Rng rng(8);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q0 = random_quaternion(rng);
    const Vector3d u = random_axis(rng);
    Quaterniond q1 = q0 * so3_exp(0.2 * u);
    q1.coeffs() = -q1.coeffs();  // same rotation, opposite hemisphere
    ASSERT_LT(q0.dot(q1), 0.0);
    const Quaterniond mid = slerp(q0, q1, 0.5);
    ASSERT_LE(max_diff(mid, q0 * so3_exp(0.1 * u)), kCompound);  // worst measured 1 eps
    ASSERT_NEAR(angular_distance(q0, mid), 0.1, 1e-15);
  }
}

TEST(Slerp, ExtrapolatesOutsideZeroOne) {
  const Vector3d u = Vector3d(0.0, 0.6, 0.8);
  const Quaterniond q0 = so3_exp(Vector3d(0.3, -0.2, 0.1));
  const Quaterniond q1 = q0 * so3_exp(0.4 * u);
  // Worst measured over random pairs: 2.75 eps.
  EXPECT_LE(max_diff(slerp(q0, q1, 2.0), q0 * so3_exp(0.8 * u)), kCompound);
  EXPECT_LE(max_diff(slerp(q0, q1, -0.5), q0 * so3_exp(-0.2 * u)), kCompound);
}

TEST(Slerp, NormalisesNonUnitInputs) {
  Rng rng(9);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q0 = random_quaternion(rng);
    const Quaterniond q1 = random_quaternion(rng);
    Quaterniond big, small;
    big.coeffs() = 3.0 * q0.coeffs();
    small.coeffs() = 0.2 * q1.coeffs();
    for (double t : {0.0, 0.3, 1.0}) {
      const Quaterniond q = slerp(big, small, t);
      ASSERT_NEAR(q.norm(), 1.0, 4.0 * kEps);               // worst measured 2 eps
      ASSERT_LE(max_diff(q, slerp(q0, q1, t)), kCompound);  // worst measured 3.5 eps
      // A vector rotated by the result keeps its length (the reference's defect 3 scaled it by
      // |q|^2).
      ASSERT_NEAR((q * Vector3d(1.0, 2.0, 3.0)).norm(), std::sqrt(14.0), 1e-14);
    }
  }
}

TEST(ScaleRotation, OneIsTheIdentityMapAndZeroTheIdentityRotation) {
  Rng rng(10);
  for (int i = 0; i < 1000; ++i) {
    const Quaterniond q = random_quaternion(rng);
    // exp(log(q)): worst measured 2.5 eps.
    ASSERT_LE(max_diff(scale_rotation(q, 1.0), canonical(q)), kCompound);
    const Quaterniond zero = scale_rotation(q, 0.0);
    ASSERT_EQ(zero.w(), 1.0);
    ASSERT_EQ(zero.vec(), Vector3d::Zero());
  }
}

TEST(ScaleRotation, IdentityStaysIdentityForEveryScale) {
  // The reference's theta sin(s theta / 2) / sin(theta / 2) gives 0/0 = NaN here.
  for (double s : {0.0, 0.5, 1.0, 2.0, -3.0, 1e6}) {
    const Quaterniond q = scale_rotation(Quaterniond::Identity(), s);
    EXPECT_EQ(q.w(), 1.0) << s;
    EXPECT_EQ(q.vec(), Vector3d::Zero()) << s;
  }
}

TEST(ScaleRotation, MultipliesTheAngle) {
  Rng rng(11);
  for (int i = 0; i < 1000; ++i) {
    const Vector3d u = random_axis(rng);
    const double theta = 0.01 + 1.5 * rng.uniform();  // (0, pi/2]: 2 theta stays below pi
    const Quaterniond q = so3_exp(theta * u);
    // s = 2: (cos theta, u sin theta) in closed form.
    const Quaterniond doubled(std::cos(theta), u.x() * std::sin(theta), u.y() * std::sin(theta),
                              u.z() * std::sin(theta));
    // Worst measured 4 eps (the closed form rounds too).
    ASSERT_LE(max_diff(scale_rotation(q, 2.0), doubled), kCompound);
    ASSERT_NEAR(angular_distance(Quaterniond::Identity(), scale_rotation(q, 0.3)), 0.3 * theta,
                4.0 * kEps);
  }
  // The shortest arc is chosen before scaling: 1.5 pi about u is -0.5 pi about u, so half of it
  // is -0.25 pi about u (not 0.75 pi).
  const Vector3d u(0.0, 0.0, 1.0);
  const Quaterniond q = so3_exp(1.5 * kPi * u);
  EXPECT_LE(max_diff(scale_rotation(q, 0.5), so3_exp(-0.25 * kPi * u)), kCompound);
}

TEST(ScaleRotation, NonUnitInputGivesAUnitResult) {
  const Quaterniond q = so3_exp(Vector3d(0.4, -0.1, 0.7));
  Quaterniond scaled;
  scaled.coeffs() = 7.0 * q.coeffs();
  const Quaterniond r = scale_rotation(scaled, 0.3);
  EXPECT_NEAR(r.norm(), 1.0, 4.0 * kEps);
  EXPECT_LE(max_diff(r, scale_rotation(q, 0.3)), kCompound);
}

TEST(AngularDistance, IsAccurateForTinyAndHalfTurnAngles) {
  const Quaterniond q0 = so3_exp(Vector3d(0.2, 0.5, -1.0));
  const Vector3d u = Vector3d(3.0, 4.0, 0.0) / 5.0;
  for (double a : {1e-12, 1e-9, 1e-4, 0.5, 3.0, kPi}) {
    const Quaterniond q1 = q0 * so3_exp(a * u);
    // acos(w) would give 0 for a < 2e-8; atan2 keeps the relative accuracy (absolute 4 eps).
    EXPECT_NEAR(angular_distance(q0, q1), a, 4.0 * kEps + 4.0 * kEps * a) << a;
    EXPECT_NEAR(angular_distance(q1, q0), a, 4.0 * kEps + 4.0 * kEps * a) << a;
  }
  // Sign and scale do not matter.
  Quaterniond minus_scaled;
  minus_scaled.coeffs() = -5.0 * q0.coeffs();
  EXPECT_NEAR(angular_distance(q0, minus_scaled), 0.0, 1e-15);
}

TEST(RotationBetween, MapsFromOntoToAlongTheShortestArc) {
  Rng rng(12);
  for (int i = 0; i < 1000; ++i) {
    const Vector3d a = random_axis(rng) * (0.1 + rng.uniform() * 10.0);
    const Vector3d b = random_axis(rng) * (0.1 + rng.uniform() * 10.0);
    const Quaterniond q = rotation_between(a, b);
    ASSERT_NEAR(q.norm(), 1.0, 4.0 * kEps);  // worst measured 1.5 eps
    // Applying a rotation of nearly pi (Eigen's q * v sums terms of size 2) costs up to 8 eps
    // (worst measured over 1e6 pairs); 16 eps leaves room for other compilers' rounding.
    ASSERT_LE((q * a.normalized() - b.normalized()).norm(), 16.0 * kEps);
    const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
    ASSERT_NEAR(angular_distance(Quaterniond::Identity(), q), angle, 4.0 * kEps);
    // The axis is perpendicular to `from` (shortest arc; worst measured 1.3 eps).
    ASSERT_LE(std::abs(q.vec().dot(a.normalized())), 4.0 * kEps);
  }
}

TEST(RotationBetween, StaysAccurateForNearlyOppositeDirections) {
  // b = -a + e p: the axis a x b is tiny and its rounding along a would be amplified by 2 / |a x b|
  // without the projection in rotation_between (up to 80 eps measured before it was added).
  Rng rng(14);
  for (double e : {1e-2, 1e-5, 1e-8, 1e-12}) {
    for (int i = 0; i < 1000; ++i) {
      const Vector3d a = random_axis(rng);
      const Vector3d b = -a + e * random_axis(rng);
      const Quaterniond q = rotation_between(a, b);
      ASSERT_LE((q * a - b.normalized()).norm(), 16.0 * kEps) << e;
    }
  }
}

TEST(RotationBetween, HandlesParallelAndOppositeDirections) {
  const Vector3d a(1.0, 2.0, -2.0);
  const Quaterniond same = rotation_between(a, 3.0 * a);
  EXPECT_EQ(same.w(), 1.0);
  EXPECT_LE(same.vec().norm(), 1e-300);
  for (const Vector3d& from : {a, Vector3d(0.0, 0.0, 1.0), Vector3d(1.0, 0.0, 0.0)}) {
    const Quaterniond flip = rotation_between(from, -from);
    EXPECT_NEAR(angular_distance(Quaterniond::Identity(), flip), kPi, 4.0 * kEps);
    EXPECT_LE((flip * from + from).norm(), 8.0 * kEps * from.norm());
  }
  // A tiny angle keeps its relative accuracy.
  const Vector3d b = so3_exp(Vector3d(0.0, 0.0, 1e-12)) * Vector3d(1.0, 0.0, 0.0);
  const Quaterniond q = rotation_between(Vector3d(1.0, 0.0, 0.0), b);
  EXPECT_NEAR(so3_log(q).z(), 1e-12, 1e-12 * 4.0 * kEps);
}

// The Jacobians against their definitions by central differences (step 1e-6: truncation
// O(h^2) ~ 1e-12, rounding O(eps / h) ~ 2e-10; tolerance 1e-8).
TEST(So3Jacobian, RightJacobianAndInverseMatchFiniteDifferences) {
  Rng rng(13);
  const double h = 1e-6;
  for (int i = 0; i < 200; ++i) {
    const double theta = (i < 20) ? std::pow(10.0, -8.0 + 0.4 * i) : 3.0 * rng.uniform();
    const Vector3d phi = theta * random_axis(rng);
    const Matrix3d jr = so3_right_jacobian(phi);
    const Matrix3d jr_inv = so3_right_jacobian_inverse(phi);
    const Quaterniond q = so3_exp(phi);
    for (int k = 0; k < 3; ++k) {
      const Vector3d e = Vector3d::Unit(k) * h;
      // exp(phi + d) ~= exp(phi) exp(J_r d)  =>  J_r e_k ~= log(exp(phi)^-1 exp(phi + h e_k)) / h.
      const Vector3d fd_jr =
          (so3_log(q.conjugate() * so3_exp(phi + e)) - so3_log(q.conjugate() * so3_exp(phi - e))) /
          (2.0 * h);
      ASSERT_LE((jr.col(k) - fd_jr).norm(), 1e-8) << theta;
      // log(exp(phi) exp(d)) ~= phi + J_r^-1 d.
      const Vector3d fd_inv = (so3_log(q * so3_exp(e)) - so3_log(q * so3_exp(-e))) / (2.0 * h);
      ASSERT_LE((jr_inv.col(k) - fd_inv).norm(), 1e-8) << theta;
    }
    ASSERT_LE((jr * jr_inv - Matrix3d::Identity()).cwiseAbs().maxCoeff(), 8.0 * kEps) << theta;
    // J_l(phi) = J_r(-phi) = J_r(phi)^T, and J_r phi = phi.
    ASSERT_LE((so3_right_jacobian(-phi) - jr.transpose()).cwiseAbs().maxCoeff(), 2.0 * kEps);
    ASSERT_LE((jr * phi - phi).norm(), 4.0 * kEps * (1.0 + theta));
  }
  EXPECT_EQ(so3_right_jacobian(Vector3d::Zero()), Matrix3d::Identity());
  EXPECT_EQ(so3_right_jacobian_inverse(Vector3d::Zero()), Matrix3d::Identity());
}

// The series branches (below 1e-2, 0.5 and 1 rad) against the closed forms in long double, across
// the switch points: the entries agree to 2 ulp of 1, so the switch causes no visible jump.
TEST(So3Jacobian, SeriesAndClosedFormsAgreeAcrossTheSwitchPoints) {
  if constexpr (std::numeric_limits<long double>::digits < 64) {
    GTEST_SKIP() << "needs an extended long double for the reference";
  }
  const Vector3d u = Vector3d(2.0, 3.0, 6.0) / 7.0;
  for (double theta : {1e-3, 9.999e-3, 1.0001e-2, 0.1, 0.4999, 0.5001, 0.9999, 1.0001, 2.0, 3.1}) {
    const Vector3d phi = theta * u;
    const long double t = theta;
    const long double a = (1.0L - std::cos(t)) / (t * t);
    const long double b = (t - std::sin(t)) / (t * t * t);
    const long double c = 1.0L / (t * t) - (1.0L + std::cos(t)) / (2.0L * t * std::sin(t));
    const Matrix3d k = hat(phi);
    const Matrix3d k2 = k * k;
    const Matrix3d jr = so3_right_jacobian(phi);
    const Matrix3d jr_inv = so3_right_jacobian_inverse(phi);
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) {
        const long double id = (r == col) ? 1.0L : 0.0L;
        const long double jr_ref = id - a * k(r, col) + b * k2(r, col);
        const long double inv_ref = id + 0.5L * k(r, col) + c * k2(r, col);
        EXPECT_LE(std::abs(jr(r, col) - jr_ref), 2.0L * kEps) << theta;
        EXPECT_LE(std::abs(jr_inv(r, col) - inv_ref), 2.0L * kEps) << theta;
      }
    }
  }
}

TEST(So3Hat, IsTheCrossProductMatrix) {
  const Vector3d v(1.5, -2.0, 0.25);
  const Vector3d w(-0.5, 4.0, 3.0);
  EXPECT_EQ(hat(v) * w, v.cross(w));
  EXPECT_EQ(hat(v).transpose(), -hat(v));
}

}  // namespace
}  // namespace imukit
