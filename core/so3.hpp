// SO(3) helpers on Eigen::Quaterniond (Hamilton product, active rotation; files store w, x, y, z):
// exponential and logarithm maps, slerp, scaling of a rotation's angle, sign canonicalisation,
// angular distance, the shortest rotation between two directions, and the right Jacobian of
// SO(3) with its inverse.
//
// Accuracy: every function that divides by an angle switches to a Taylor series below a small
// angle where both forms agree to within rounding, so there is no jump at the switch and no
// loss of relative accuracy down to angles of 1e-300. The logarithm uses atan2 on the
// sign-canonical quaternion, which stays accurate near pi (acos of w would lose half the digits).
//
// Non-unit quaternions: so3_log, slerp, scale_rotation and angular_distance depend only on the
// rotation a quaternion represents, so any finite non-zero q is treated as q / |q| (a scaled
// quaternion never scales the result, unlike the reference simulator's defect 3). canonical()
// only fixes the sign and keeps the norm. Non-finite or zero quaternions are contract violations
// and are assert()ed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace imukit {

// The skew-symmetric matrix [v]x with [v]x u = v x u.
Eigen::Matrix3d hat(const Eigen::Vector3d& v);

// exp: rotation vector (axis * angle, rad) -> unit quaternion (cos(angle/2), axis sin(angle/2)).
// Angles beyond pi are allowed (the quaternion then has w < 0; it is not canonicalised).
Eigen::Quaterniond so3_exp(const Eigen::Vector3d& rotation_vector);

// log: quaternion -> rotation vector of the shortest rotation, angle in [0, pi]. q and -q give
// the same result, also at exactly pi (w == 0): there the sign is fixed by canonical(), which
// makes the first non-zero of x, y, z positive. Scale-invariant (see the header comment).
Eigen::Vector3d so3_log(const Eigen::Quaterniond& q);

// The same rotation with the sign chosen so that w > 0, or, when w == 0, the first non-zero of
// x, y, z is positive. The norm is kept as given.
Eigen::Quaterniond canonical(const Eigen::Quaterniond& q);

// Spherical linear interpolation q0 * exp(t * log(q0^-1 q1)) along the shorter arc (q1 is negated
// when q0 . q1 < 0). Exact at the ends: t == 0 returns q0 and t == 1 returns q1 or -q1 bit for bit
// when the inputs are unit to within rounding (|q|^2 within 4 ulp of 1); other inputs are
// normalised first. t outside [0, 1] extrapolates along the same great circle. Accurate for
// nearly identical inputs (the series in exp/log; never a plain lerp).
Eigen::Quaterniond slerp(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1, double t);

// exp(s * log(q)): the same axis with the (shortest-arc) angle multiplied by s. s = 0 and the
// identity give the identity exactly; s = 1 gives canonical(q / |q|) to within rounding.
Eigen::Quaterniond scale_rotation(const Eigen::Quaterniond& q, double s);

// Angle in [0, pi] of the rotation taking q_a to q_b (the angle of q_a^-1 q_b), computed with atan2
// so that small angles keep their relative accuracy.
double angular_distance(const Eigen::Quaterniond& q_a, const Eigen::Quaterniond& q_b);

// The shortest rotation q with q * from parallel to `to` (both non-zero, any length). For opposite
// directions the axis is a fixed choice perpendicular to `from`.
Eigen::Quaterniond rotation_between(const Eigen::Vector3d& from, const Eigen::Vector3d& to);

// Right Jacobian of SO(3): exp(phi + d) ~= exp(phi) exp(J_r(phi) d) for small d,
//   J_r(phi) = I - (1 - cos t)/t^2 [phi]x + (t - sin t)/t^3 [phi]x^2,  t = |phi|.
// The left Jacobian is J_l(phi) = J_r(-phi) = J_r(phi)^T. (Barfoot, State Estimation for Robotics,
// 2017, sec. 7.1.5; Sola et al., A micro Lie theory, 2018, eq. 143.)
Eigen::Matrix3d so3_right_jacobian(const Eigen::Vector3d& phi);

// Inverse of the right Jacobian: log(exp(phi) exp(d)) ~= phi + J_r^-1(phi) d,
//   J_r^-1(phi) = I + 1/2 [phi]x + (1/t^2 - (1 + cos t)/(2 t sin t)) [phi]x^2.
// Defined for |phi| < 2 pi (it is singular at 2 pi); asserted.
Eigen::Matrix3d so3_right_jacobian_inverse(const Eigen::Vector3d& phi);

}  // namespace imukit
