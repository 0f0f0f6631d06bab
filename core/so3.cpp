#include "imukit/core/so3.hpp"

#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

namespace imukit {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

bool all_finite(const Quaterniond& q) { return q.coeffs().allFinite(); }

// c[0] + c[1] x + c[2] x^2 + ... by Horner's rule.
template <std::size_t N>
double horner(double x, const std::array<double, N>& c) {
  double acc = c[N - 1];
  for (std::size_t i = N - 1; i-- > 0;) acc = acc * x + c[i];
  return acc;
}

// sin(theta / 2) / theta. Below 1e-2 the Taylor series
//   1/2 - theta^2/48 + theta^4/3840 - theta^6/645120 (next term theta^8/185794560)
// is exact to well below one ulp (truncation < 1e-24 relative), and above it the direct quotient
// has no cancellation, so the two branches agree to rounding and there is no jump.
double sin_half_over(double theta) {
  if (theta < 1e-2) {
    const double t2 = theta * theta;
    return 0.5 - t2 * (1.0 / 48.0 - t2 * (1.0 / 3840.0 - t2 * (1.0 / 645120.0)));
  }
  return std::sin(0.5 * theta) / theta;
}

// atan2(n, w) / n for n >= 0, finite also at n == 0 (w > 0). For r = n / w < 1e-2 the series
// atan(r) / r = 1 - r^2/3 + r^4/5 - r^6/7 + r^8/9 (truncation r^10 / 11 < 1e-21) replaces the
// quotient; above it atan2 / n loses nothing. Valid for any sign of w (w <= 0 never takes the
// series branch).
double atan2_over(double n, double w) {
  if (n < 1e-2 * w) {
    const double r = n / w;
    const double r2 = r * r;
    const double atan_r_over_r =
        1.0 - r2 * (1.0 / 3.0 - r2 * (1.0 / 5.0 - r2 * (1.0 / 7.0 - r2 * (1.0 / 9.0))));
    return atan_r_over_r / w;
  }
  return std::atan2(n, w) / n;
}

// True when the sign convention of canonical() asks for negating (w, x, y, z).
bool needs_sign_flip(double w, double x, double y, double z) {
  if (w != 0.0) return w < 0.0;
  if (x != 0.0) return x < 0.0;
  if (y != 0.0) return y < 0.0;
  return z < 0.0;
}

// q times the power of two that brings its largest |component| into [0.5, 1): exact (short of
// components some 2^1074 below the largest, which are below rounding anyway), and afterwards no
// norm or product underflows or overflows, so the header's "any finite non-zero q" holds at any
// scale (found in review: so3_log lost digits at |q| = 1e-160 and asserted at 1e-200,
// angular_distance asserted at 1e-150). The same idea as the quaternion CSV reader's.
Quaterniond rescaled(const Quaterniond& q) {
  assert(all_finite(q) && "quaternion must be finite");
  const double largest = q.coeffs().cwiseAbs().maxCoeff();
  assert(largest > 0.0 && "quaternion must be non-zero");
  int exponent = 0;
  (void)std::frexp(largest, &exponent);
  // Per component: 2^-exponent itself overflows when the largest is subnormal.
  Quaterniond out;
  for (int i = 0; i < 4; ++i) out.coeffs()[i] = std::ldexp(q.coeffs()[i], -exponent);
  return out;
}

// q / |q|, except that a quaternion whose squared norm is within 4 ulp of 1 is returned as given:
// dividing it by its rounded norm would only move its last bits, and keeping it lets slerp return
// its endpoints bit for bit.
Quaterniond unit_or_normalised(const Quaterniond& q) {
  if (std::abs(q.squaredNorm() - 1.0) <= 4.0 * std::numeric_limits<double>::epsilon()) return q;
  Quaterniond out = rescaled(q);
  out.coeffs() /= out.norm();
  return out;
}

// (t - sin t) / t^3 = sum_k (-1)^k t^(2k) / (2k + 3)!. The series (to t^16, truncation
// t^18 / 21! < 2e-20 at t = 1) is used below t = 1; above it the direct form has lost at most
// 6 eps / t^2 relative to cancellation.
double one_minus_sinc_over_t2(double t) {
  if (t < 1.0) {
    // (-1)^k / (2k + 3)!, k = 0 .. 8.
    static constexpr std::array<double, 9> kCoefficients = {1.0 / 6.0,
                                                            -1.0 / 120.0,
                                                            1.0 / 5040.0,
                                                            -1.0 / 362880.0,
                                                            1.0 / 39916800.0,
                                                            -1.0 / 6227020800.0,
                                                            1.0 / 1307674368000.0,
                                                            -1.0 / 355687428096000.0,
                                                            1.0 / 121645100408832000.0};
    return horner(t * t, kCoefficients);
  }
  return (t - std::sin(t)) / (t * t * t);
}

// 1/t^2 - (1 + cos t) / (2 t sin t) = sum_{k>=1} (-1)^(k+1) B_2k t^(2k-2) / (2k)! (Bernoulli
// numbers B_2k; from the series of t/2 cot(t/2)). Radius of convergence 2 pi; below t = 0.5 eight
// terms leave a truncation below 3e-18 relative, and above it the direct form has lost at most
// 12 eps / t^2 relative.
double jr_inverse_coefficient(double t) {
  if (t < 0.5) {
    // |B_2k| / (2k)!, k = 1 .. 8: 1/12, 1/720, 1/30240, 1/1209600, 1/47900160, 691/15!,
    // (7/6)/14!, (3617/510)/16!.
    static constexpr std::array<double, 8> kCoefficients = {
        1.0 / 12.0,          1.0 / 720.0,
        1.0 / 30240.0,       1.0 / 1209600.0,
        1.0 / 47900160.0,    691.0 / 1307674368000.0,
        1.0 / 74724249600.0, 3617.0 / 10670622842880000.0};
    return horner(t * t, kCoefficients);
  }
  return 1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
}

}  // namespace

Matrix3d hat(const Vector3d& v) {
  Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Quaterniond so3_exp(const Vector3d& rotation_vector) {
  assert(rotation_vector.allFinite());
  // |v| may underflow to 0 for |v| < 1e-154; the series then gives v / 2, which is still right.
  const double theta = rotation_vector.norm();
  const Vector3d xyz = rotation_vector * sin_half_over(theta);
  return Quaterniond(std::cos(0.5 * theta), xyz.x(), xyz.y(), xyz.z());
}

Quaterniond canonical(const Quaterniond& q) {
  if (!needs_sign_flip(q.w(), q.x(), q.y(), q.z())) return q;
  Quaterniond out;
  out.coeffs() = -q.coeffs();
  return out;
}

Eigen::Vector3d so3_log(const Quaterniond& q_in) {
  const Quaterniond q = canonical(rescaled(q_in));
  // q = |q| (cos(a/2), u sin(a/2)) with w >= 0, so a/2 = atan2(|xyz|, w) in [0, pi/2] and
  // log = u a = xyz * 2 atan2(n, w) / n: the factor |q| cancels (scale invariance).
  const double n = q.vec().norm();
  return q.vec() * (2.0 * atan2_over(n, q.w()));
}

Quaterniond slerp(const Quaterniond& q0_in, const Quaterniond& q1_in, double t) {
  assert(std::isfinite(t));
  const Quaterniond q0 = unit_or_normalised(q0_in);
  Quaterniond q1 = unit_or_normalised(q1_in);
  // The shorter of the two arcs: q1 and -q1 are the same rotation.
  if (q0.dot(q1) < 0.0) q1.coeffs() = -q1.coeffs();
  if (t == 0.0) return q0;
  if (t == 1.0) return q1;
  // q0^-1 q1 has w = q0 . q1 >= 0, so its log is the short way round.
  const Vector3d delta = so3_log(q0.conjugate() * q1);
  return q0 * so3_exp(t * delta);
}

Quaterniond scale_rotation(const Quaterniond& q, double s) {
  assert(std::isfinite(s));
  // so3_log picks the shortest arc (angle <= pi) before scaling; log(identity) == 0 exactly and
  // exp(0) == identity exactly, so neither s = 0 nor theta = 0 needs a special case.
  return so3_exp(s * so3_log(q));
}

double angular_distance(const Quaterniond& q_a, const Quaterniond& q_b) {
  // Rescaled, the product's components lie within [2^-2, 4] in magnitude, whatever |q_a| |q_b|.
  const Quaterniond rel = rescaled(q_a).conjugate() * rescaled(q_b);
  return 2.0 * std::atan2(rel.vec().norm(), std::abs(rel.w()));
}

Quaterniond rotation_between(const Vector3d& from, const Vector3d& to) {
  assert(from.allFinite() && to.allFinite());
  const double from_norm = from.norm();
  const double to_norm = to.norm();
  assert(from_norm > 0.0 && to_norm > 0.0);
  const Vector3d a = from / from_norm;
  const Vector3d b = to / to_norm;
  // a x b is perpendicular to a in exact arithmetic; its rounding leaves a component along a of
  // about eps, which a rotation by nearly pi turns into an error of 2 eps / |a x b| in the image
  // of a. Projecting it out keeps the image accurate to a few ulp also for nearly opposite
  // directions.
  Vector3d c = a.cross(b);
  c -= c.dot(a) * a;
  const double d = a.dot(b);
  const double n = c.norm();
  if (n == 0.0 && d < 0.0) {
    // Opposite directions: any perpendicular axis works; take the one through the coordinate axis
    // least aligned with `from` so the cross product is well conditioned.
    Eigen::Index i = 0;
    a.cwiseAbs().minCoeff(&i);
    const Vector3d axis = a.cross(Vector3d::Unit(i)).normalized();
    return Quaterniond(0.0, axis.x(), axis.y(), axis.z());
  }
  // Rotation vector: axis c / n times angle atan2(n, d).
  return so3_exp(c * atan2_over(n, d));
}

Matrix3d so3_right_jacobian(const Vector3d& phi) {
  assert(phi.allFinite());
  const double t = phi.norm();
  // (1 - cos t) / t^2 = 2 (sin(t/2) / t)^2: no cancellation, and the series of sin_half_over
  // covers t -> 0.
  const double s = sin_half_over(t);
  const double a = 2.0 * s * s;
  const double b = one_minus_sinc_over_t2(t);
  const Matrix3d k = hat(phi);
  return Matrix3d::Identity() - a * k + b * (k * k);
}

Matrix3d so3_right_jacobian_inverse(const Vector3d& phi) {
  assert(phi.allFinite());
  const double t = phi.norm();
  assert(t < 2.0 * std::numbers::pi && "J_r^-1 is singular at |phi| = 2 pi");
  const Matrix3d k = hat(phi);
  return Matrix3d::Identity() + 0.5 * k + jr_inverse_coefficient(t) * (k * k);
}

}  // namespace imukit
