#include "imukit/sim/simulator.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "imukit/core/error.hpp"
#include "imukit/core/isa.hpp"
#include "imukit/core/so3.hpp"

namespace imukit::sim {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr int64_t kEndless = std::numeric_limits<int64_t>::max() / 4;

struct FramePosition {
  int64_t frame = 0;  // floor of the position in frames
  double frac = 0.0;  // in [0, 1)
};

// Position of time t (ns) on the frame grid of a motion at rate_hz. Integer arithmetic for a
// whole-number rate keeps it exact however late t is; otherwise the 64-bit long double mantissa.
// (Called per sample: the whole-number test is a cast, not a libm modf call.)
//
// A time within 1 ns of a frame is on that frame (frac 0). Frame times are whole ns
// (sample_time), a third of a ns off the exact frame at 30, 60 or 120 Hz, and times counted from
// another frame (a PPDA window's) are off by up to 1 ns more: read exactly, such a time fell just
// before or after its frame, into the neighbouring interval's cubic, whose acceleration differs
// from the frame's by the spline's own error (0.01-0.02 m/s^2 on the bundled walk: PPDA identity
// windows were not the plain simulation; found 2026-11-27), and off the on-frame path.
inline FramePosition frame_position(TimeNs t, double rate_hz) {
  if (rate_hz >= 1.0 && rate_hz <= 1e6 && t >= 0) {
    const auto whole = static_cast<int64_t>(rate_hz);
    int64_t num = 0;
    if (static_cast<double>(whole) == rate_hz && !__builtin_mul_overflow(t, whole, &num)) {
      const int64_t frame = num / kNsPerSecond, rest = num % kNsPerSecond;  // rest: ns x Hz
      if (rest <= whole) return {frame, 0.0};
      if (kNsPerSecond - rest <= whole) return {frame + 1, 0.0};
      return {frame, static_cast<double>(rest) * 1e-9};
    }
  }
  const long double u = static_cast<long double>(t) * static_cast<long double>(rate_hz) / 1e9L;
  const long double nearest = std::round(u);
  if (std::abs(u - nearest) * 1e9L <= static_cast<long double>(rate_hz))
    return {static_cast<int64_t>(nearest), 0.0};
  const long double fl = std::floor(u);
  return {static_cast<int64_t>(fl), static_cast<double>(u - fl)};
}

// The position of t in a motion of N frames, with the last frame as the end of the last
// interval ({N - 2, 1}). Frame times are whole ns (sample_time), rounded up for about half the
// frames at 30, 60 or 120 Hz: a sample at the last frame's time lies a few ns past the exact
// frame, so that time counts as the last frame too (else the motion's last sample was dropped).
// nullopt past the end.
inline std::optional<FramePosition> position_in_motion(TimeNs t, double rate_hz, int64_t N) {
  FramePosition fp = frame_position(t, rate_hz);
  if (fp.frame < N - 1) return fp;
  if (fp.frame == N - 1 && (fp.frac == 0.0 || t <= sample_time(0, N - 1, rate_hz)))
    return FramePosition{N - 2, 1.0};
  return std::nullopt;
}

// exp(psi(t)) and its body-frame angular velocity and acceleration, given psi and its first
// two time derivatives. With x = psi.psi, exp(psi) = (C(x), S(x) psi), C = cos(sqrt(x)/2),
// S = sin(sqrt(x)/2)/sqrt(x); w = 2 Im(e* de/dt), dw/dt = 2 Im(e* d2e/dt2) (the real part of
// de*/dt de/dt has no imaginary part). S and its x-derivatives are entire functions of x: a
// series for x < 1 avoids the cancellation of the closed forms near 0.
struct ExpDerivatives {
  Quaterniond e;
  Vector3d w_body;
  Vector3d dw_body;
};

ExpDerivatives exp_with_derivatives(const Vector3d& psi, const Vector3d& dpsi,
                                    const Vector3d& ddpsi) {
  const double x = psi.squaredNorm();
  const double dx = 2.0 * psi.dot(dpsi);
  const double ddx = 2.0 * (dpsi.squaredNorm() + psi.dot(ddpsi));
  double S, S1, S2, C;
  if (x < 1.0) {
    // S(x) = sum_k a_k x^k, a_k = (-1)^k / (2^(2k+1) (2k+1)!); 12 terms reach 1e-30 at x = 1.
    double a = 0.5;  // a_0
    double xk = 1.0;
    S = 0.0;
    S1 = 0.0;
    S2 = 0.0;
    double xk1 = 0.0, xk2 = 0.0;  // x^(k-1), x^(k-2)
    for (int k = 0; k < 12; ++k) {
      S += a * xk;
      if (k >= 1) S1 += k * a * xk1;
      if (k >= 2) S2 += k * (k - 1) * a * xk2;
      xk2 = xk1;
      xk1 = xk;
      xk *= x;
      a *= -1.0 / (4.0 * (2 * k + 2) * (2 * k + 3));
    }
    C = std::cos(0.5 * std::sqrt(x));
  } else {
    const double r = std::sqrt(x);
    C = std::cos(0.5 * r);
    S = std::sin(0.5 * r) / r;
    S1 = (0.5 * C - S) / (2.0 * x);
    S2 = (-S / 8.0 - 3.0 * S1) / (2.0 * x);
  }
  const double C1 = -0.25 * S;
  const double C2 = -0.25 * S1;
  const double ew = C;
  const Vector3d ev = S * psi;
  const double dew = C1 * dx;
  const Vector3d dev = S1 * dx * psi + S * dpsi;
  const double ddew = C2 * dx * dx + C1 * ddx;
  const Vector3d ddev = (S2 * dx * dx + S1 * ddx) * psi + 2.0 * S1 * dx * dpsi + S * ddpsi;
  ExpDerivatives out;
  out.e = Quaterniond(ew, ev.x(), ev.y(), ev.z());
  out.w_body = 2.0 * (ew * dev - dew * ev - ev.cross(dev));
  out.dw_body = 2.0 * (ew * ddev - ddew * ev - ev.cross(ddev));
  return out;
}

// q v q* for a unit quaternion, inlined (v + 2 w (u x v) + 2 u x (u x v)): the hot loops rotate
// a dozen vectors per frame and Eigen's out-of-line version was a quarter of the run time.
[[gnu::always_inline]] inline Vector3d rotate(const Quaterniond& q, const Vector3d& v) {
  const double ux = q.x(), uy = q.y(), uz = q.z(), w = q.w();
  const double tx = 2.0 * (uy * v.z() - uz * v.y());
  const double ty = 2.0 * (uz * v.x() - ux * v.z());
  const double tz = 2.0 * (ux * v.y() - uy * v.x());
  return Vector3d(v.x() + w * tx + (uy * tz - uz * ty), v.y() + w * ty + (uz * tx - ux * tz),
                  v.z() + w * tz + (ux * ty - uy * tx));
}
// Hamilton product a b, inlined for the forward-kinematics loop. The vector part is summed as
// (a.w b.v + b.w a.v) + (a.v x b.v) so that q* q has an exactly zero vector part: a body at rest
// then reads an angular rate of exactly 0.
[[gnu::always_inline]] inline Quaterniond multiply(const Quaterniond& a, const Quaterniond& b) {
  return Quaterniond(a.w() * b.w() - a.x() * b.x() - a.y() * b.y() - a.z() * b.z(),
                     (a.w() * b.x() + a.x() * b.w()) + (a.y() * b.z() - a.z() * b.y()),
                     (a.w() * b.y() + a.y() * b.w()) + (a.z() * b.x() - a.x() * b.z()),
                     (a.w() * b.z() + a.z() * b.w()) + (a.x() * b.y() - a.y() * b.x()));
}
[[gnu::always_inline]] inline Vector3d rotate_inverse(const Quaterniond& q, const Vector3d& v) {
  return rotate(Quaterniond(q.w(), -q.x(), -q.y(), -q.z()), v);
}
// rotate() on plain doubles, for the structure-of-arrays loops.
[[gnu::always_inline]] inline void rotate_into(double w, double ux, double uy, double uz, double vx,
                                               double vy, double vz, double& ox, double& oy,
                                               double& oz) {
  const double tx = 2.0 * (uy * vz - uz * vy);
  const double ty = 2.0 * (uz * vx - ux * vz);
  const double tz = 2.0 * (ux * vy - uy * vx);
  ox = vx + w * tx + (uy * tz - uz * ty);
  oy = vy + w * ty + (uz * tx - ux * tz);
  oz = vz + w * tz + (ux * ty - uy * tx);
}

// Lagrange basis on nodes tau (frames relative to the interval start), value, first and second
// derivative at u.
struct LagrangeWeights {
  int n = 0;
  std::array<double, 4> w{}, dw{}, ddw{};
};

LagrangeWeights lagrange(const std::array<double, 4>& tau, int n, double u) {
  LagrangeWeights L;
  L.n = n;
  for (int m = 0; m < n; ++m) {
    // Coefficients of prod_{k != m} (u - tau_k) / (tau_m - tau_k), lowest degree first.
    std::array<double, 4> c{1.0, 0.0, 0.0, 0.0};
    double denom = 1.0;
    int deg = 0;
    for (int k = 0; k < n; ++k) {
      if (k == m) continue;
      denom *= tau[static_cast<std::size_t>(m)] - tau[static_cast<std::size_t>(k)];
      for (int d = deg + 1; d >= 1; --d) {
        c[static_cast<std::size_t>(d)] =
            c[static_cast<std::size_t>(d - 1)] -
            tau[static_cast<std::size_t>(k)] * c[static_cast<std::size_t>(d)];
      }
      c[0] = -tau[static_cast<std::size_t>(k)] * c[0];
      ++deg;
    }
    const double v = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
    const double d1 = c[1] + u * (2.0 * c[2] + 3.0 * u * c[3]);
    const double d2 = 2.0 * c[2] + 6.0 * u * c[3];
    L.w[static_cast<std::size_t>(m)] = v / denom;
    L.dw[static_cast<std::size_t>(m)] = d1 / denom;
    L.ddw[static_cast<std::size_t>(m)] = d2 / denom;
  }
  return L;
}

// The frames the spline's cubic on interval [fi, fi + 1] of an N-frame motion goes through:
// fi-1 .. fi+2, shifted inwards at the motion's ends (3 frames when it has only 3), and their
// positions relative to fi.
struct SplineStencil {
  int64_t s0 = 0;
  int n = 0;
  std::array<double, 4> tau{};
};
SplineStencil spline_stencil(int64_t fi, int64_t N) {
  int64_t s0 = std::max<int64_t>(0, fi - 1);
  int64_t s1 = std::min<int64_t>(N - 1, fi + 2);
  if (s1 - s0 < 3 && N >= 4) {
    if (s0 == 0) s1 = 3;
    if (s1 == N - 1) s0 = N - 4;
  }
  SplineStencil st;
  st.s0 = s0;
  st.n = static_cast<int>(s1 - s0 + 1);
  for (int m = 0; m < st.n; ++m)
    st.tau[static_cast<std::size_t>(m)] = static_cast<double>(s0 + m - fi);
  return st;
}

// The rotation vector equivalent to phi (phi + 2 pi k phi/|phi|) nearest to ref. log() returns
// angles up to pi; chart coordinates of frames two or three steps away from the chart's centre
// can legitimately exceed pi (fast spins at low frame rates), so they are unwrapped against the
// linear extrapolation of their nearer neighbours.
Vector3d unwrap_near(const Vector3d& phi, const Vector3d& ref) {
  // Within pi of ref, no other equivalent (2 pi away along the axis) can be nearer: the common
  // case, decided without a square root.
  if ((phi - ref).squaredNorm() <= std::numbers::pi * std::numbers::pi) return phi;
  const double th = phi.norm();
  Vector3d n;
  if (th > 0.0) {
    n = phi / th;
  } else if (ref.norm() > 0.0) {
    n = ref.normalized();
  } else {
    return phi;
  }
  Vector3d best = phi;
  for (const double k : {-2.0, -1.0, 1.0, 2.0}) {
    const Vector3d c = phi + (2.0 * std::numbers::pi * k) * n;
    if ((c - ref).squaredNorm() < (best - ref).squaredNorm()) best = c;
  }
  return best;
}

// log q for a quaternion q = (w, x, y, z) of any norm and sign, when its angle is small
// (|v| < 0.1 |w|, below about 0.2 rad -- the increments between neighbouring frames): with the
// sign made positive, log q = v (2 / w) atan(r) / r, r = |v| / w, and atan(r) / r =
// sum (-r^2)^k / (2k + 1), 9 terms for an error below 1e-18: no atan2, no square root, no branch,
// so loops over frames vectorise. `large` is 1 where the series does not apply and the caller
// takes so3_log instead, else 0 (a double, not a bool, so that it vectorises with the rest).
// q and -q give the same: the sign need not be made positive, because it cancels exactly in
// v (2 / w) (IEEE negation is exact, and r depends on w^2 only).
struct SmallAngleLog {
  double x, y, z;
  double large;
};
[[gnu::always_inline]] inline SmallAngleLog small_angle_log(double qw, double qx, double qy,
                                                            double qz) {
  const double s2 = qx * qx + qy * qy + qz * qz;
  const double inv = 1.0 / qw;
  const double r2 = s2 * (inv * inv);
  double r = 1.0 / 17.0;
  for (int m = 7; m >= 0; --m) r = 1.0 / (2 * m + 1) - r2 * r;
  const double scale = 2.0 * r * inv;
  return {qx * scale, qy * scale, qz * scale, s2 < 0.01 * qw * qw ? 0.0 : 1.0};
}

// log(a^* b), the rotation from a to b in a's axes: by the series when small, else so3_log.
Vector3d relative_log(const Quaterniond& a, const Quaterniond& b) {
  const Quaterniond q = multiply(a.conjugate(), b);
  const SmallAngleLog d = small_angle_log(q.w(), q.x(), q.y(), q.z());
  return d.large == 0.0 ? Vector3d(d.x, d.y, d.z) : so3_log(q);
}

// Intrinsic XYZ Euler angles of a rotation matrix as the reference computes them.
Vector3d reference_euler_xyz(const Matrix3d& R) {
  return Vector3d(std::atan2(-R(1, 2), R(2, 2)), std::asin(std::clamp(R(0, 2), -1.0, 1.0)),
                  std::atan2(-R(0, 1), R(0, 0)));
}

}  // namespace

std::string_view to_string(DerivativeMethod method) {
  switch (method) {
    case DerivativeMethod::fd:
      return "fd";
    case DerivativeMethod::spline:
      return "spline";
    case DerivativeMethod::reference:
      return "reference";
  }
  return "?";
}

DerivativeMethod parse_derivative_method(std::string_view name) {
  if (name == "fd") return DerivativeMethod::fd;
  if (name == "spline") return DerivativeMethod::spline;
  if (name == "reference") return DerivativeMethod::reference;
  throw Error("unknown derivative method '" + std::string(name) + "' (fd, spline or reference)");
}

SimulationPlan compile_plan(const Body& body, const std::vector<SensorSpec>& sensors) {
  SimulationPlan plan;
  std::vector<char> used(body.size(), 0);
  std::vector<char> rate(body.size(), 0);
  for (const SensorSpec& s : sensors) {
    const int j = s.placement.joint;
    if (j < 0 || static_cast<std::size_t>(j) >= body.size()) {
      throw Error("sensor " + s.name + ": placement joint " + std::to_string(j) +
                  " is not a joint of the body");
    }
    for (int k : body.chain(j)) used[static_cast<std::size_t>(k)] = 1;
    if (s.outputs.gyroscope) rate[static_cast<std::size_t>(j)] = 1;
    plan.needs_position |= s.outputs.accelerometer;
    plan.needs_rotation |= s.outputs.gyroscope || s.outputs.orientation || s.outputs.magnetometer;
  }
  std::vector<int> where(body.size(), -1);
  for (std::size_t j = 0; j < body.size(); ++j) {
    if (!used[j]) continue;
    where[j] = static_cast<int>(plan.joints.size());
    plan.joints.push_back(static_cast<int>(j));
    const int p = body.joint(j).parent;
    plan.parent.push_back(p < 0 ? -1 : where[static_cast<std::size_t>(p)]);
    plan.needs_rate.push_back(rate[j]);
  }
  for (const SensorSpec& s : sensors) {
    plan.sensor_joint.push_back(where[static_cast<std::size_t>(s.placement.joint)]);
  }
  return plan;
}

namespace {

// ---- Kernels -----------------------------------------------------------------------------------
//
// The loops over frames (fd, reference) and over samples (the spline on frames) in
// structure-of-arrays form, so that they vectorise. Each is built for the baseline, AVX2 and
// AVX-512 (IMUKIT_ISA_VARIANTS, core/isa.hpp) and calls nothing out of line: everything it uses
// is inlined into each variant, so no call crosses from AVX code into SSE code (the 12x of issue
// 17 on Intel). What needs a libm or Eigen call (so3_log for the rare large angle, the frames at
// the motion's ends, orientation outputs) runs between kernel calls, in ordinary code.
//
// The kernels take every array as a separate __restrict pointer: gcc 12 does not vectorise these
// loops when the arrays are offsets of one local pointer.

// log(a^* b) lane by lane (see small_angle_log): out x, y, z and the flag `large`.
[[gnu::always_inline]] inline void relative_log_lanes(
    const double* __restrict aw, const double* __restrict ax, const double* __restrict ay,
    const double* __restrict az, const double* __restrict bw, const double* __restrict bx,
    const double* __restrict by, const double* __restrict bz, double* __restrict px,
    double* __restrict py, double* __restrict pz, double* __restrict large, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    // a^* b, as multiply(a.conjugate(), b).
    const double cw = aw[i], cx = -ax[i], cy = -ay[i], cz = -az[i];
    const SmallAngleLog d = small_angle_log(cw * bw[i] - cx * bx[i] - cy * by[i] - cz * bz[i],
                                            (cw * bx[i] + cx * bw[i]) + (cy * bz[i] - cz * by[i]),
                                            (cw * by[i] + cy * bw[i]) + (cz * bx[i] - cx * bz[i]),
                                            (cw * bz[i] + cz * bw[i]) + (cx * by[i] - cy * bx[i]));
    px[i] = d.x;
    py[i] = d.y;
    pz[i] = d.z;
    large[i] = d.large;
  }
}

// Lane i of the quaternion rows at q (w x y z, R doubles apart) normalised into the rows at dst.
[[gnu::always_inline]] inline void normalize_lane(const double* __restrict q,
                                                  double* __restrict dst, std::size_t R,
                                                  std::size_t i) {
  const double w = q[i], x = q[R + i], y = q[2 * R + i], z = q[3 * R + i];
  const double inv = 1.0 / std::sqrt(w * w + x * x + y * y + z * z);
  dst[i] = w * inv;
  dst[R + i] = x * inv;
  dst[2 * R + i] = y * inv;
  dst[3 * R + i] = z * inv;
}

// Two independent relative logs per lane, log(a^* b) into p and log(c^* d) into q, each as
// relative_log_lanes has it (the same bits): in one loop the two series' dependency chains
// overlap, where one after the other each waits on its own multiply-subtract chain.
// Also c normalised into cn (as normalize_lanes), its square root and division overlapping the
// series too. Each quaternion argument points at its w row, with x, y, z `R` doubles apart
// after it; each log output at its x row, with y and z after it the same way, and its flag row
// apart.
[[gnu::always_inline]] inline void relative_log_pairs(
    const double* __restrict a, const double* __restrict b, const double* __restrict c,
    const double* __restrict d, double* __restrict p, double* __restrict pf, double* __restrict q,
    double* __restrict qf, double* __restrict cn, std::size_t R, std::size_t n) {
  const auto log_of = [R](const double* __restrict u, const double* __restrict v, std::size_t i) {
    const double cw = u[i], cx = -u[R + i], cy = -u[2 * R + i], cz = -u[3 * R + i];
    const double bw = v[i], bx = v[R + i], by = v[2 * R + i], bz = v[3 * R + i];
    return small_angle_log(
        cw * bw - cx * bx - cy * by - cz * bz, (cw * bx + cx * bw) + (cy * bz - cz * by),
        (cw * by + cy * bw) + (cz * bx - cx * bz), (cw * bz + cz * bw) + (cx * by - cy * bx));
  };
  for (std::size_t i = 0; i < n; ++i) {
    const SmallAngleLog e = log_of(a, b, i);
    const SmallAngleLog f = log_of(c, d, i);
    p[i] = e.x;
    p[R + i] = e.y;
    p[2 * R + i] = e.z;
    pf[i] = e.large;
    q[i] = f.x;
    q[R + i] = f.y;
    q[2 * R + i] = f.z;
    qf[i] = f.large;
    normalize_lane(c, cn, R, i);
  }
}

// 1 if some of n flags (0 or 1) is set, else 0: an integer OR of their bits, which vectorises
// (a floating-point max or sum would have to run in order).
[[gnu::always_inline]] inline double any_flag(const double* __restrict flags, std::size_t n) {
  uint64_t any = 0;
  for (std::size_t i = 0; i < n; ++i) any |= std::bit_cast<uint64_t>(flags[i]);
  return any != 0 ? 1.0 : 0.0;
}

// fd's SO(3) increments d[f] = log(q[f]^* q[f+1]) for f in [first, first + n) of a joint whose
// world rotations are the arrays w, x, y, z `frames` apart from q; into inc (x, y, z and the
// flag, `frames` apart). Returns 1 if some increment needs so3_log.
[[gnu::always_inline]] inline double increments_kernel(const double* q, std::size_t frames,
                                                       std::size_t first, std::size_t n,
                                                       double* inc) {
  const double* W = q + first;
  const double* X = W + frames;
  const double* Y = W + 2 * frames;
  const double* Z = W + 3 * frames;
  double* D = inc + first;
  relative_log_lanes(W, X, Y, Z, W + 1, X + 1, Y + 1, Z + 1, D, D + frames, D + 2 * frames,
                     D + 3 * frames, n);
  return any_flag(D + 3 * frames, n);
}
IMUKIT_ISA_VARIANTS(double, increments, increments_kernel,
                    (const double* q, std::size_t frames, std::size_t first, std::size_t n,
                     double* inc),
                    (q, frames, first, n, inc))

// Forward kinematics of the grid methods over every loaded frame: joint by joint over tiles of
// frames (the same formulas as multiply() and rotate(), so the same bits as a quaternion at a
// time); only the sensor joints' world rotations and positions are kept.
struct ForwardKinematicsArgs {
  std::size_t joints = 0;
  std::size_t frames = 0;
  // Per plan joint: its local rotation at the first loaded frame (x, y, z, w as Eigen stores
  // them), the next frame `stride` doubles on.
  const double* const* rotations = nullptr;
  std::size_t stride = 4;
  const double* translation = nullptr;  // root translation, x y z per frame
  const int* parent = nullptr;          // per plan joint
  const double* offsets = nullptr;      // per plan joint, x y z from its parent
  const char* offset_is_zero = nullptr;
  const int* kept = nullptr;  // per plan joint: its slot in `pose`, or -1
  bool positions = false;
  double* tile = nullptr;  // scratch: 7 arrays of kFkTile per plan joint
  double* pose = nullptr;  // per kept slot: w, x, y, z, px, py, pz arrays of `frames`
};
constexpr std::size_t kFkTile = 256;

[[gnu::always_inline]] inline void forward_kinematics_kernel(const ForwardKinematicsArgs& a) {
  constexpr std::size_t T = kFkTile;
  const std::size_t F = a.frames;
  const std::size_t stride = a.stride;
  for (std::size_t f0 = 0; f0 < F; f0 += T) {
    const std::size_t n = std::min(T, F - f0);
    for (std::size_t k = 0; k < a.joints; ++k) {
      double* base = a.tile + k * 7 * T;
      double* __restrict qw_ = base;
      double* __restrict qx_ = base + T;
      double* __restrict qy_ = base + 2 * T;
      double* __restrict qz_ = base + 3 * T;
      double* __restrict px_ = base + 4 * T;
      double* __restrict py_ = base + 5 * T;
      double* __restrict pz_ = base + 6 * T;
      const double* __restrict src = a.rotations[k] + f0 * stride;
      if (f0 + n < F) {
        // The next tile of this joint's rotations: fetched while this tile is computed (the
        // motion streams from memory; waiting for it was a fifth of the time).
        const auto* next = reinterpret_cast<const char*>(src + n * stride);
        const std::size_t bytes = std::min(T, F - f0 - n) * stride * sizeof(double);
        for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(next + b);
      }
      const int p = a.parent[k];
      if (p < 0) {
        for (std::size_t i = 0; i < n; ++i) {
          qx_[i] = src[i * stride];
          qy_[i] = src[i * stride + 1];
          qz_[i] = src[i * stride + 2];
          qw_[i] = src[i * stride + 3];
        }
        if (a.positions) {
          const double* __restrict tr = a.translation + 3 * f0;
          for (std::size_t i = 0; i < n; ++i) {
            px_[i] = tr[3 * i];
            py_[i] = tr[3 * i + 1];
            pz_[i] = tr[3 * i + 2];
          }
        }
      } else {
        const double* pbase = a.tile + static_cast<std::size_t>(p) * 7 * T;
        const double* __restrict aw = pbase;
        const double* __restrict ax = pbase + T;
        const double* __restrict ay = pbase + 2 * T;
        const double* __restrict az = pbase + 3 * T;
        const double* __restrict apx = pbase + 4 * T;
        const double* __restrict apy = pbase + 5 * T;
        const double* __restrict apz = pbase + 6 * T;
        for (std::size_t i = 0; i < n; ++i) {
          const double bx = src[i * stride], by = src[i * stride + 1], bz = src[i * stride + 2],
                       bw = src[i * stride + 3];
          qw_[i] = aw[i] * bw - ax[i] * bx - ay[i] * by - az[i] * bz;
          qx_[i] = (aw[i] * bx + ax[i] * bw) + (ay[i] * bz - az[i] * by);
          qy_[i] = (aw[i] * by + ay[i] * bw) + (az[i] * bx - ax[i] * bz);
          qz_[i] = (aw[i] * bz + az[i] * bw) + (ax[i] * by - ay[i] * bx);
        }
        if (a.positions && a.offset_is_zero[k] != 0) {
          // A joint at its parent's origin: rotating a zero offset adds exactly nothing.
          for (std::size_t i = 0; i < n; ++i) {
            px_[i] = apx[i];
            py_[i] = apy[i];
            pz_[i] = apz[i];
          }
        } else if (a.positions) {
          const double vx = a.offsets[3 * k], vy = a.offsets[3 * k + 1], vz = a.offsets[3 * k + 2];
          for (std::size_t i = 0; i < n; ++i) {
            double ox, oy, oz;
            rotate_into(aw[i], ax[i], ay[i], az[i], vx, vy, vz, ox, oy, oz);
            px_[i] = apx[i] + ox;
            py_[i] = apy[i] + oy;
            pz_[i] = apz[i] + oz;
          }
        }
      }
      if (a.kept[k] >= 0) {
        double* out = a.pose + static_cast<std::size_t>(a.kept[k]) * 7 * F + f0;
        const std::size_t arrays = a.positions ? 7 : 4;
        for (std::size_t r = 0; r < arrays; ++r) {
          double* __restrict dst = out + r * F;
          const double* __restrict from = base + r * T;
          for (std::size_t i = 0; i < n; ++i) dst[i] = from[i];
        }
      }
    }
  }
}
IMUKIT_ISA_VARIANTS(void, forward_kinematics, forward_kinematics_kernel,
                    (const ForwardKinematicsArgs& a), (a))

// A sensor's position p_world_j + R_world_j p_j_s on loaded frames [first, first + n), from its
// joint's pose arrays (`frames` apart), into 3 arrays `frames` apart.
[[gnu::always_inline]] inline void sensor_position_lanes(
    const double* __restrict W, const double* __restrict X, const double* __restrict Y,
    const double* __restrict Z, const double* __restrict PX, const double* __restrict PY,
    const double* __restrict PZ, double rx, double ry, double rz, double* __restrict ox,
    double* __restrict oy, double* __restrict oz, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    double vx, vy, vz;
    rotate_into(W[i], X[i], Y[i], Z[i], rx, ry, rz, vx, vy, vz);
    ox[i] = PX[i] + vx;
    oy[i] = PY[i] + vy;
    oz[i] = PZ[i] + vz;
  }
}
[[gnu::always_inline]] inline void sensor_positions_kernel(const double* pose, std::size_t frames,
                                                           const double* p_js, std::size_t first,
                                                           std::size_t n, double* out) {
  const double* q = pose + first;
  double* o = out + first;
  sensor_position_lanes(q, q + frames, q + 2 * frames, q + 3 * frames, q + 4 * frames,
                        q + 5 * frames, q + 6 * frames, p_js[0], p_js[1], p_js[2], o, o + frames,
                        o + 2 * frames, n);
}
IMUKIT_ISA_VARIANTS(void, sensor_positions, sensor_positions_kernel,
                    (const double* pose, std::size_t frames, const double* p_js, std::size_t first,
                     std::size_t n, double* out),
                    (pose, frames, p_js, first, n, out))

// fd on interior frames (the full stencil inside the motion): specific force from the second
// difference of the sensor positions, angular rate from the neighbouring increments, both in
// sensor axes.
struct FdInteriorArgs {
  const double* pose = nullptr;        // the sensor joint's pose arrays (`frames` apart)
  const double* position = nullptr;    // sensor positions (3 arrays); null: no accelerometer
  const double* increments = nullptr;  // the joint's increments (3 arrays); null: no gyroscope
  std::size_t frames = 0;
  std::size_t first = 0, count = 0;  // loaded frames first .. first + count - 1
  double R_sensor_joint[9] = {};     // row-major
  double gravity[3] = {};
  double rate = 0.0;
  double* force = nullptr;  // x y z per frame from `first` on
  double* angular_rate = nullptr;
};

[[gnu::always_inline]] inline void fd_interior_kernel(const FdInteriorArgs& a) {
  const std::size_t F = a.frames;
  const double* M = a.R_sensor_joint;
  // R_sensor_joint v, in the order Eigen's fixed-size product sums (the same bits as before).
  const auto to_sensor = [M](double vx, double vy, double vz, double* __restrict out) {
    out[0] = (M[0] * vx + M[1] * vy) + M[2] * vz;
    out[1] = (M[3] * vx + M[4] * vy) + M[5] * vz;
    out[2] = (M[6] * vx + M[7] * vy) + M[8] * vz;
  };
  if (a.position != nullptr) {
    const double rate2 = a.rate * a.rate;
    const double* __restrict W = a.pose + a.first;
    const double* __restrict X = W + F;
    const double* __restrict Y = W + 2 * F;
    const double* __restrict Z = W + 3 * F;
    const double* __restrict px = a.position + a.first;
    const double* __restrict py = px + F;
    const double* __restrict pz = px + 2 * F;
    // The frames before (interior frames: first >= 1), as pointers of their own: px[i - 1] with
    // an unsigned i = 0 is an overflowing pointer offset (UBSan), whatever the address it gives.
    const double* __restrict px_prev = px - 1;
    const double* __restrict py_prev = py - 1;
    const double* __restrict pz_prev = pz - 1;
    double* __restrict out = a.force;
    for (std::size_t i = 0; i < a.count; ++i) {
      // In differences, so a still point gives exactly 0.
      const double ax = ((px[i + 1] - px[i]) - (px[i] - px_prev[i])) * rate2;
      const double ay = ((py[i + 1] - py[i]) - (py[i] - py_prev[i])) * rate2;
      const double az = ((pz[i + 1] - pz[i]) - (pz[i] - pz_prev[i])) * rate2;
      double vx, vy, vz;  // rotate_inverse(q_world_joint, a - g)
      rotate_into(W[i], -X[i], -Y[i], -Z[i], ax - a.gravity[0], ay - a.gravity[1],
                  az - a.gravity[2], vx, vy, vz);
      to_sensor(vx, vy, vz, out + 3 * i);
    }
  }
  if (a.increments != nullptr) {
    const double half_rate = 0.5 * a.rate;
    const double* __restrict dx = a.increments + a.first;
    const double* __restrict dy = dx + F;
    const double* __restrict dz = dx + 2 * F;
    const double* __restrict dx_prev = dx - 1;
    const double* __restrict dy_prev = dy - 1;
    const double* __restrict dz_prev = dz - 1;
    double* __restrict out = a.angular_rate;
    for (std::size_t i = 0; i < a.count; ++i) {
      to_sensor((dx_prev[i] + dx[i]) * half_rate, (dy_prev[i] + dy[i]) * half_rate,
                (dz_prev[i] + dz[i]) * half_rate, out + 3 * i);
    }
  }
}
IMUKIT_ISA_VARIANTS(void, fd_interior, fd_interior_kernel, (const FdInteriorArgs& a), (a))

// The spline on motion frames, in structure-of-arrays form.
//
// A sample exactly on frame f with the full interior stencil f-1 .. f+2 (every sample of a
// sensor at the motion's rate, or at a whole fraction of it, and every PPDA window) needs no
// exp: there the chart coordinate psi is 0, so a joint's local body rate and acceleration are the
// stencil's derivative weights applied to its three neighbours' chart coordinates log(q_f^* q_m),
// and the chain is propagated with quaternions. Lanes are samples, in tiles: the local rotations
// are gathered per tile, then the kernels below run over plain arrays and vectorise (the
// small-angle log has no branch; the rare larger angles are redone through so3_log between the
// kernels). Same formulas as the per-sample path, so the two agree to rounding; which path a
// sample takes depends only on its own frame position, never on the other samples of the call.
struct OnFrameInputs {
  const SimulationPlan* plan = nullptr;
  const std::vector<Vector3d>* offsets = nullptr;  // per plan joint, from its plan parent
  const std::vector<SensorSpec>* sensors = nullptr;
  // The motion from frame lo on: per plan joint its local rotation at frame lo (x, y, z, w, as
  // Eigen stores them) and the doubles from one frame to the next; the root translation (x, y, z
  // per frame).
  int64_t lo = 0;
  const std::vector<const double*>* rotations = nullptr;
  std::size_t rotation_stride = 4;
  const double* translation = nullptr;
  double rate = 0.0;
  Vector3d gravity_world, magnetic_field_world;
};

constexpr std::size_t kOnFrameTile = 64;
// Per plan joint and tile: world rotation (w x y z), world angular rate and acceleration, joint
// origin acceleration (13 arrays of kOnFrameTile, in this order).
constexpr std::size_t kJointArrays = 13;
// Per tile, rows of kStencilRow values: the local rotations (16 rows: w x y z of the stencil's
// four frames; a tile of consecutive frames uses rows 0-3 for its n + 3 frames), the steps
// log(q_(f-1)^* q_f) and log(q_f^* q_f+1) (rows 16-21; for consecutive frames rows 16-18 hold
// n + 1 steps, each sample's backward step followed by its forward one), log(q_f^* q_f+2) (rows
// 22-24), their flags (25-27), the sensor outputs (specific force, angular rate; 28-33) and the
// local rotation at f normalised (w x y z; 34-37).
constexpr std::size_t kStencilRow = kOnFrameTile + 4;
constexpr std::size_t kStencilArrays = 38;

// n consecutive quaternions as Eigen stores them (x, y, z, w) into the arrays w, x, y, z.
[[gnu::always_inline]] inline void transpose_quaternions(const double* __restrict q,
                                                         double* __restrict w, double* __restrict x,
                                                         double* __restrict y, double* __restrict z,
                                                         std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    w[i] = q[4 * i + 3];
    x[i] = q[4 * i];
    y[i] = q[4 * i + 1];
    z[i] = q[4 * i + 2];
  }
}

// n quaternions (rows w x y z, kStencilRow apart from q) normalised into the rows from dst.
// Here, not in joint_tile: there the square root and division were a sixth of its time, waiting
// at the head of its chain; next to the logarithms' series they overlap.
[[gnu::always_inline]] inline void normalize_lanes(const double* __restrict q,
                                                   double* __restrict dst, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) normalize_lane(q, dst, kStencilRow, i);
}

// One joint's stencil for a tile of n samples on frames fr (frames of the motion; its rotations
// from frame lo on at rot, `stride` doubles apart): the local rotations gathered into rows and
// their logs. `run`: the frames are consecutive. Returns 1 if some log needs so3_log.
[[gnu::always_inline]] inline double stencil_logs_kernel(const double* rot, std::size_t stride,
                                                         int64_t lo, const int64_t* fr,
                                                         std::size_t n, bool run, double* st) {
  constexpr std::size_t R = kStencilRow;
  const auto gather = [&](std::size_t row, std::size_t col, int64_t f) {
    const double* q = rot + static_cast<std::size_t>(f - lo) * stride;
    st[row * R + col] = q[3];
    st[(row + 1) * R + col] = q[0];
    st[(row + 2) * R + col] = q[1];
    st[(row + 3) * R + col] = q[2];
  };
  const auto logs = [&](const double* a, const double* b, std::size_t row, std::size_t m) {
    relative_log_lanes(a, a + R, a + 2 * R, a + 3 * R, b, b + R, b + 2 * R, b + 3 * R, st + row * R,
                       st + (row + 1) * R, st + (row + 2) * R, st + (25 + (row - 16) / 3) * R, m);
  };
  if (run) {
    // A tile of consecutive frames shares its rotations and steps between samples: n + 3
    // frames and n + 1 steps instead of 4 n and 2 n. Consecutive quaternions (an in-memory
    // Motion) are transposed with a fixed stride, which vectorises.
    if (stride == 4) {
      transpose_quaternions(rot + static_cast<std::size_t>(fr[0] - 1 - lo) * 4, st, st + R,
                            st + 2 * R, st + 3 * R, n + 3);
    } else {
      for (std::size_t i = 0; i < n + 3; ++i) gather(0, i, fr[0] - 1 + static_cast<int64_t>(i));
    }
    // The next tile's rotations of this joint, fetched while this tile is computed (the motion
    // streams from memory: waiting for it was a quarter of this kernel's time).
    // (Integer arithmetic: the address may lie past the motion's end; a prefetch never faults.)
    const std::uintptr_t next =
        reinterpret_cast<std::uintptr_t>(rot) +
        static_cast<std::uintptr_t>(fr[0] - lo + static_cast<int64_t>(n) + 2) * stride *
            sizeof(double);
    for (std::size_t b = 0; b < n * stride * sizeof(double); b += 64)
      __builtin_prefetch(reinterpret_cast<const void*>(next + b));
    // The steps from frame f-1 on (n + 1) and f to f+2 (n), the first n of each together.
    relative_log_pairs(st, st + 1, st + 1, st + 3, st + 16 * R, st + 25 * R, st + 22 * R,
                       st + 27 * R, st + 34 * R, R, n);
    const double* last = st + n;  // the last step
    relative_log_lanes(last, last + R, last + 2 * R, last + 3 * R, last + 1, last + 1 + R,
                       last + 1 + 2 * R, last + 1 + 3 * R, st + 16 * R + n, st + 17 * R + n,
                       st + 18 * R + n, st + 25 * R + n, 1);
    const double a = any_flag(st + 25 * R, n + 1), b = any_flag(st + 27 * R, n);
    return a > b ? a : b;
  }
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t m = 0; m < 4; ++m) gather(4 * m, i, fr[i] - 1 + static_cast<int64_t>(m));
  logs(st, st + 4 * R, 16, n);           // f-1 to f
  logs(st + 4 * R, st + 8 * R, 19, n);   // f to f+1
  logs(st + 4 * R, st + 12 * R, 22, n);  // f to f+2
  normalize_lanes(st + 4 * R, st + 34 * R, n);
  double any = 0.0;
  for (std::size_t r = 25; r < 28; ++r) {
    const double v = any_flag(st + r * R, n);
    any = v > any ? v : any;
  }
  return any;
}
IMUKIT_ISA_VARIANTS(double, stencil_logs, stencil_logs_kernel,
                    (const double* rot, std::size_t stride, int64_t lo, const int64_t* fr,
                     std::size_t n, bool run, double* st),
                    (rot, stride, lo, fr, n, run, st))

// One joint's world rotation, angular rate and acceleration and its origin's acceleration over a
// tile, from its stencil's rows and its parent's arrays (pa, kJointArrays; null for the root,
// whose origin acceleration comes from the root translation instead).
// d, e: the derivative weights of the neighbours times rate and rate^2; o: the joint's offset
// in its parent's axes. The chart coordinates are psi_-1 = -back, psi_1 = fwd, psi_2 = fwd2
// (psi_0 = 0 drops out; the sign of back is in the weights d[0], e[0]); each points at 3 rows
// (x, y, z) of kStencilRow, as does lq, the local rotation at f (w, x, y, z).
struct JointTileArgs {
  const double* lq = nullptr;
  const double* back = nullptr;
  const double* fwd = nullptr;
  const double* fwd2 = nullptr;
  const double* pa = nullptr;
  double* jt = nullptr;
  std::size_t n = 0;
  double d[3] = {}, e[3] = {};
  double o[3] = {};
  // Root only: the translation (x y z per frame from frame lo), the tile's frames, and the
  // stencil's second-derivative weights of frames f-1, f+1, f+2.
  const double* translation = nullptr;
  int64_t lo = 0;
  const int64_t* fr = nullptr;
  bool run = false;  // the frames are consecutive
  double ddw[3] = {};
  double rate2 = 0.0;
};

template <bool Root>
[[gnu::always_inline]] inline void joint_lanes(
    const double* __restrict lq, const double* __restrict back, const double* __restrict fwd,
    const double* __restrict fwd2, const double* __restrict pa, double* __restrict jt,
    std::size_t n, const double (&d)[3], const double (&e)[3], const double (&o)[3]) {
  constexpr std::size_t T = kOnFrameTile;
  constexpr std::size_t R = kStencilRow;
  const double ox = o[0], oy = o[1], oz = o[2];
  for (std::size_t i = 0; i < n; ++i) {
    const double wbx = (d[0] * back[i] + d[1] * fwd[i]) + d[2] * fwd2[i];
    const double wby = (d[0] * back[R + i] + d[1] * fwd[R + i]) + d[2] * fwd2[R + i];
    const double wbz = (d[0] * back[2 * R + i] + d[1] * fwd[2 * R + i]) + d[2] * fwd2[2 * R + i];
    const double abx = (e[0] * back[i] + e[1] * fwd[i]) + e[2] * fwd2[i];
    const double aby = (e[0] * back[R + i] + e[1] * fwd[R + i]) + e[2] * fwd2[R + i];
    const double abz = (e[0] * back[2 * R + i] + e[1] * fwd[2 * R + i]) + e[2] * fwd2[2 * R + i];
    // The local rotation at f (normalised by stencil_logs).
    const double bw = lq[i], bx = lq[R + i], by = lq[2 * R + i], bz = lq[3 * R + i];
    if constexpr (Root) {
      jt[i] = bw;
      jt[T + i] = bx;
      jt[2 * T + i] = by;
      jt[3 * T + i] = bz;
      rotate_into(bw, bx, by, bz, wbx, wby, wbz, jt[4 * T + i], jt[5 * T + i], jt[6 * T + i]);
      rotate_into(bw, bx, by, bz, abx, aby, abz, jt[7 * T + i], jt[8 * T + i], jt[9 * T + i]);
      continue;
    }
    const double aw = pa[i], ax = pa[T + i], ay = pa[2 * T + i], az = pa[3 * T + i];
    const double pwx = pa[4 * T + i], pwy = pa[5 * T + i], pwz = pa[6 * T + i];
    const double pdx = pa[7 * T + i], pdy = pa[8 * T + i], pdz = pa[9 * T + i];
    // World rotation: parent * local (multiply(), spelled out).
    const double kw = aw * bw - ax * bx - ay * by - az * bz;
    const double kx = (aw * bx + ax * bw) + (ay * bz - az * by);
    const double ky = (aw * by + ay * bw) + (az * bx - ax * bz);
    const double kz = (aw * bz + az * bw) + (ax * by - ay * bx);
    double wlx, wly, wlz, alx, aly, alz, owx, owy, owz;
    rotate_into(kw, kx, ky, kz, wbx, wby, wbz, wlx, wly, wlz);
    rotate_into(kw, kx, ky, kz, abx, aby, abz, alx, aly, alz);
    rotate_into(aw, ax, ay, az, ox, oy, oz, owx, owy, owz);
    jt[i] = kw;
    jt[T + i] = kx;
    jt[2 * T + i] = ky;
    jt[3 * T + i] = kz;
    // w = w_p + w_l; dw = dw_p + w_p x w_l + R a_b; a = a_p + dw_p x o + w_p x (w_p x o).
    jt[4 * T + i] = pwx + wlx;
    jt[5 * T + i] = pwy + wly;
    jt[6 * T + i] = pwz + wlz;
    jt[7 * T + i] = (pdx + (pwy * wlz - pwz * wly)) + alx;
    jt[8 * T + i] = (pdy + (pwz * wlx - pwx * wlz)) + aly;
    jt[9 * T + i] = (pdz + (pwx * wly - pwy * wlx)) + alz;
    const double cx = pwy * owz - pwz * owy, cy = pwz * owx - pwx * owz, cz = pwx * owy - pwy * owx;
    jt[10 * T + i] = (pa[10 * T + i] + (pdy * owz - pdz * owy)) + (pwy * cz - pwz * cy);
    jt[11 * T + i] = (pa[11 * T + i] + (pdz * owx - pdx * owz)) + (pwz * cx - pwx * cz);
    jt[12 * T + i] = (pa[12 * T + i] + (pdx * owy - pdy * owx)) + (pwx * cy - pwy * cx);
  }
}

[[gnu::always_inline]] inline void joint_tile_kernel(const JointTileArgs& a) {
  if (a.pa != nullptr) {
    joint_lanes<false>(a.lq, a.back, a.fwd, a.fwd2, a.pa, a.jt, a.n, a.d, a.e, a.o);
    return;
  }
  joint_lanes<true>(a.lq, a.back, a.fwd, a.fwd2, nullptr, a.jt, a.n, a.d, a.e, a.o);
  // The root translation's second derivative, in differences from frame f (a still root stays
  // exactly still).
  constexpr std::size_t T = kOnFrameTile;
  const auto second_derivative = [&](const double* __restrict t0, std::size_t i) {
    for (int c = 0; c < 3; ++c) {
      const double v = (a.ddw[0] * (t0[c - 3] - t0[c]) + a.ddw[1] * (t0[c + 3] - t0[c])) +
                       a.ddw[2] * (t0[c + 6] - t0[c]);
      a.jt[(10 + static_cast<std::size_t>(c)) * T + i] = v * a.rate2;
    }
  };
  if (a.run) {
    // Consecutive frames: a fixed stride, which vectorises.
    const double* t0 = a.translation + 3 * (a.fr[0] - a.lo);
    for (std::size_t i = 0; i < a.n; ++i) second_derivative(t0 + 3 * i, i);
    return;
  }
  for (std::size_t i = 0; i < a.n; ++i) second_derivative(a.translation + 3 * (a.fr[i] - a.lo), i);
}
IMUKIT_ISA_VARIANTS(void, joint_tile, joint_tile_kernel, (const JointTileArgs& a), (a))

// A sensor's specific force and angular rate over a tile (into so: 6 arrays) from its joint's
// arrays, copied to the samples' columns of the outputs (x y z per sample; null: not wanted).
struct SensorTileArgs {
  const double* jt = nullptr;
  double* so = nullptr;
  std::size_t n = 0;
  double q_js[4] = {};  // w x y z
  double p_js[3] = {};
  double gravity[3] = {};
  const std::size_t* samples = nullptr;
  double* force = nullptr;
  double* angular_rate = nullptr;
};

[[gnu::always_inline]] inline void sensor_lanes(const double* __restrict jt, double* __restrict so,
                                                std::size_t n, const double (&q_js)[4],
                                                const double (&p_js)[3], const double (&g)[3]) {
  constexpr std::size_t T = kOnFrameTile;
  const double sw = q_js[0], sx = q_js[1], sy = q_js[2], sz = q_js[3];
  const double rx = p_js[0], ry = p_js[1], rz = p_js[2];
  const double gx = g[0], gy = g[1], gz = g[2];
  for (std::size_t i = 0; i < n; ++i) {
    const double kw = jt[i], kx = jt[T + i], ky = jt[2 * T + i], kz = jt[3 * T + i];
    const double wx = jt[4 * T + i], wy = jt[5 * T + i], wz = jt[6 * T + i];
    const double dx = jt[7 * T + i], dy = jt[8 * T + i], dz = jt[9 * T + i];
    // q_world_sensor = q_world_joint q_joint_sensor, then its inverse rotates world vectors.
    const double qw = kw * sw - kx * sx - ky * sy - kz * sz;
    const double qx = -((kw * sx + kx * sw) + (ky * sz - kz * sy));
    const double qy = -((kw * sy + ky * sw) + (kz * sx - kx * sz));
    const double qz = -((kw * sz + kz * sw) + (kx * sy - ky * sx));
    double px, py, pz;
    rotate_into(kw, kx, ky, kz, rx, ry, rz, px, py, pz);
    // a + dw x r + w x (w x r) - g.
    const double cx = wy * pz - wz * py, cy = wz * px - wx * pz, cz = wx * py - wy * px;
    const double fx = ((jt[10 * T + i] + (dy * pz - dz * py)) + (wy * cz - wz * cy)) - gx;
    const double fy = ((jt[11 * T + i] + (dz * px - dx * pz)) + (wz * cx - wx * cz)) - gy;
    const double fz = ((jt[12 * T + i] + (dx * py - dy * px)) + (wx * cy - wy * cx)) - gz;
    rotate_into(qw, qx, qy, qz, fx, fy, fz, so[i], so[T + i], so[2 * T + i]);
    rotate_into(qw, qx, qy, qz, wx, wy, wz, so[3 * T + i], so[4 * T + i], so[5 * T + i]);
  }
}

// n samples of x, y, z arrays interleaved into dst (x y z per sample).
[[gnu::always_inline]] inline void interleave3(const double* __restrict x,
                                               const double* __restrict y,
                                               const double* __restrict z, double* __restrict dst,
                                               std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    dst[3 * i] = x[i];
    dst[3 * i + 1] = y[i];
    dst[3 * i + 2] = z[i];
  }
}

[[gnu::always_inline]] inline void sensor_tile_kernel(const SensorTileArgs& a) {
  constexpr std::size_t T = kOnFrameTile;
  sensor_lanes(a.jt, a.so, a.n, a.q_js, a.p_js, a.gravity);
  const double* so = a.so;
  if (a.samples[a.n - 1] - a.samples[0] == a.n - 1) {  // consecutive columns
    const std::size_t c0 = 3 * a.samples[0];
    if (a.force != nullptr) interleave3(so, so + T, so + 2 * T, a.force + c0, a.n);
    if (a.angular_rate != nullptr)
      interleave3(so + 3 * T, so + 4 * T, so + 5 * T, a.angular_rate + c0, a.n);
    return;
  }
  for (std::size_t i = 0; i < a.n; ++i) {
    const std::size_t col = a.samples[i];
    for (std::size_t x = 0; x < 3; ++x) {
      if (a.force != nullptr) a.force[3 * col + x] = so[x * T + i];
      if (a.angular_rate != nullptr) a.angular_rate[3 * col + x] = so[(3 + x) * T + i];
    }
  }
}
IMUKIT_ISA_VARIANTS(void, sensor_tile, sensor_tile_kernel, (const SensorTileArgs& a), (a))

void spline_on_frames(const OnFrameInputs& in, std::span<const std::size_t> samples,
                      std::span<const int64_t> frames, std::vector<double>& scratch,
                      std::vector<SensorBlock>& out) {
  constexpr std::size_t T = kOnFrameTile;
  const SimulationPlan& plan = *in.plan;
  const std::size_t J = plan.joints.size();
  const double rate = in.rate, rate2 = rate * rate;
  // The stencil's derivative weights at u = 0 (nodes -1, 0, 1, 2), as the per-sample path has
  // them; node 0 (psi = 0) drops out.
  const LagrangeWeights L = lagrange({-1.0, 0.0, 1.0, 2.0}, 4, 0.0);
  JointTileArgs ja;
  // psi_-1 is minus the backward step, so its weights change sign (exactly).
  ja.d[0] = -(L.dw[0] * rate), ja.d[1] = L.dw[2] * rate, ja.d[2] = L.dw[3] * rate;
  ja.e[0] = -(L.ddw[0] * rate2), ja.e[1] = L.ddw[2] * rate2, ja.e[2] = L.ddw[3] * rate2;
  ja.ddw[0] = L.ddw[0], ja.ddw[1] = L.ddw[2], ja.ddw[2] = L.ddw[3];
  ja.rate2 = rate2;
  ja.translation = in.translation;
  ja.lo = in.lo;
  constexpr std::size_t R = kStencilRow;
  scratch.resize(J * kJointArrays * T + kStencilArrays * R);
  double* const st = scratch.data() + J * kJointArrays * T;
  const auto joint_arrays = [&](std::size_t k) { return scratch.data() + k * kJointArrays * T; };
  const auto quat = [&](std::size_t row, std::size_t col) {
    return Quaterniond(st[row * R + col], st[(row + 1) * R + col], st[(row + 2) * R + col],
                       st[(row + 3) * R + col]);
  };
  const auto put = [&](std::size_t row, std::size_t col, const Vector3d& v) {
    for (std::size_t x = 0; x < 3; ++x) st[(row + x) * R + col] = v[static_cast<Eigen::Index>(x)];
  };
  for (std::size_t t0 = 0; t0 < samples.size(); t0 += T) {
    const std::size_t n = std::min(T, samples.size() - t0);
    const int64_t* fr = frames.data() + t0;
    // Consecutive frames, each one after the last (a repeated time repeats its frame: its
    // first and last frames alone cannot tell).
    bool run = true;
    for (std::size_t i = 1; i < n && run; ++i) run = fr[i] - fr[i - 1] == 1;
    for (std::size_t k = 0; k < J; ++k) {
      const double large =
          stencil_logs((*in.rotations)[k], in.rotation_stride, in.lo, fr, n, run, st);
      if (run) {
        for (std::size_t i = 0; i < n + 1 && large != 0.0; ++i) {
          if (st[25 * R + i] != 0.0) put(16, i, relative_log(quat(0, i), quat(0, i + 1)));
        }
        for (std::size_t i = 0; i < n && large != 0.0; ++i) {
          // The two-step log needs unwrapping when its series did not apply, and also when its
          // first step is large: two steps near pi make a two-step rotation near 2 pi, which
          // the series takes for a small one and returns wrapped (found in review: 3.1 rad per
          // frame read 414.7 rad/s at 100 Hz instead of 310).
          if (st[27 * R + i] == 0.0 && st[25 * R + i + 1] == 0.0) continue;
          const Vector3d fw(st[16 * R + i + 1], st[17 * R + i + 1], st[18 * R + i + 1]);
          put(22, i, unwrap_near(relative_log(quat(0, i + 1), quat(0, i + 3)), 2.0 * fw));
        }
        ja.lq = st + 34 * R;
        ja.back = st + 16 * R;
        ja.fwd = st + 16 * R + 1;
      } else {
        for (std::size_t i = 0; i < n && large != 0.0; ++i) {
          if (st[25 * R + i] + st[26 * R + i] + st[27 * R + i] == 0.0) continue;
          put(16, i, relative_log(quat(0, i), quat(4, i)));
          const Vector3d fw = relative_log(quat(4, i), quat(8, i));
          put(19, i, fw);
          put(22, i, unwrap_near(relative_log(quat(4, i), quat(12, i)), 2.0 * fw));
        }
        ja.lq = st + 34 * R;
        ja.back = st + 16 * R;
        ja.fwd = st + 19 * R;
      }
      ja.fwd2 = st + 22 * R;
      const int p = plan.parent[k];
      ja.pa = p < 0 ? nullptr : joint_arrays(static_cast<std::size_t>(p));
      ja.jt = joint_arrays(k);
      ja.n = n;
      ja.fr = fr;
      ja.run = run;
      const Vector3d& o = (*in.offsets)[k];
      ja.o[0] = o.x(), ja.o[1] = o.y(), ja.o[2] = o.z();
      joint_tile(ja);
    }
    // The sensors: computed into the tile and copied to the samples' columns.
    SensorTileArgs sa;
    sa.so = st + 28 * R;
    sa.n = n;
    sa.samples = samples.data() + t0;
    for (int c = 0; c < 3; ++c) sa.gravity[c] = in.gravity_world[c];
    for (std::size_t s = 0; s < in.sensors->size(); ++s) {
      const SensorSpec& spec = (*in.sensors)[s];
      const double* jt = joint_arrays(static_cast<std::size_t>(plan.sensor_joint[s]));
      const Quaterniond& q_js = spec.placement.q_joint_sensor;
      sa.jt = jt;
      sa.q_js[0] = q_js.w(), sa.q_js[1] = q_js.x(), sa.q_js[2] = q_js.y(), sa.q_js[3] = q_js.z();
      for (int c = 0; c < 3; ++c) sa.p_js[c] = spec.placement.p_joint_sensor[c];
      sa.force = spec.outputs.accelerometer ? out[s].specific_force.data() : nullptr;
      sa.angular_rate = spec.outputs.gyroscope ? out[s].angular_rate.data() : nullptr;
      sensor_tile(sa);
      if (!spec.outputs.orientation && !spec.outputs.magnetometer) continue;
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t col = samples[t0 + i];
        const Quaterniond q_ws = Quaterniond(jt[i], jt[T + i], jt[2 * T + i], jt[3 * T + i]) *
                                 spec.placement.q_joint_sensor;
        // Orientation outputs are sign-canonical (w >= 0, so3.hpp's canonical()) in every path:
        // the sign came from the input frames (fd, reference) or the rotation matrix (spline),
        // so one sample could be q in one method and -q in another, and an input alternating
        // q / -q alternated the output (found in review, 2026-11-27).
        if (spec.outputs.orientation) out[s].q_world_sensor[col] = canonical(q_ws.normalized());
        if (spec.outputs.magnetometer)
          out[s].magnetic_field.col(static_cast<Eigen::Index>(col)) =
              q_ws.conjugate() * in.magnetic_field_world;
      }
    }
  }
}

// ---- evaluate()'s phases ------------------------------------------------------------------------

// The motion frames [lo, hi) an evaluate() call reads (its samples' stencils). An in-memory Motion
// is read in place (a copy was an eighth of fd's run time), other sources through a chunk.
struct MotionWindow {
  const Motion* direct = nullptr;
  const MotionChunk* chunk = nullptr;  // when not direct: frames lo .. hi - 1
  const int* joints = nullptr;         // the plan's joints (body indices)
  std::size_t J = 0;                   // plan joints
  int64_t lo = 0, hi = 0;
  int64_t N = 0;  // the motion's frames (kEndless for an endless source)
  double rate = 0.0;
  const double* translation = nullptr;  // the root translation from frame lo, x y z per frame

  std::size_t frames() const { return static_cast<std::size_t>(hi - lo); }
  // Plan joint k's local rotation at frame f.
  const Quaterniond& q_local(int64_t f, std::size_t k) const {
    return direct != nullptr ? direct->rotation_data(static_cast<std::size_t>(joints[k]))[f]
                             : chunk->rotation(f - lo, k);
  }
  // Plan joint k's local rotations from frame lo on, as Eigen stores them (x, y, z, w); the next
  // frame's are rotation_stride() doubles on.
  const double* rotations(std::size_t k) const {
    return direct != nullptr
               ? direct->rotation_data(static_cast<std::size_t>(joints[k]))[lo].coeffs().data()
               : chunk->rotations[k].coeffs().data();
  }
  std::size_t rotation_stride() const { return direct != nullptr ? 4 : 4 * J; }
  Eigen::Map<const Vector3d> root_translation(int64_t f) const {
    return Eigen::Map<const Vector3d>(translation + 3 * (f - lo));
  }
};

// The frames the grid methods (fd, reference) differentiate.
struct GridFrames {
  int64_t g0 = 0, g1 = 0;  // the samples' frames and the next (interpolation uses i and i + 1)
  int64_t d0 = 0, d1 = 0;  // fd's increments d[d0] .. d[d1]: each interior rate uses d[g-1], d[g]
  bool on_grid = false;    // sample i is at frame g0 + i exactly
};

inline void store3(double* dst, const Vector3d& v) {
  dst[0] = v.x();
  dst[1] = v.y();
  dst[2] = v.z();
}

// out[s] sized for the times: the requested channels one column per time, the others empty.
void size_outputs(const std::vector<SensorSpec>& sensors, std::span<const TimeNs> times,
                  std::vector<SensorBlock>& out) {
  out.resize(sensors.size());
  for (std::size_t s = 0; s < sensors.size(); ++s) {
    const SensorOutputs& o = sensors[s].outputs;
    const auto n = static_cast<Eigen::Index>(times.size());
    out[s].t.assign(times.begin(), times.end());
    out[s].specific_force.resize(3, o.accelerometer ? n : 0);
    out[s].angular_rate.resize(3, o.gyroscope ? n : 0);
    out[s].q_world_sensor.resize(o.orientation ? times.size() : 0);
    out[s].magnetic_field.resize(3, o.magnetometer ? n : 0);
  }
}

// Sample i at frame g0 + i exactly (the last frame counts as the end of the last interval)?
bool samples_on_grid(std::span<const FramePosition> pos, int64_t g0) {
  bool on_grid = true;
  for (std::size_t i = 0; i < pos.size() && on_grid; ++i) {
    const int64_t g = pos[i].frac == 0.0   ? pos[i].frame
                      : pos[i].frac == 1.0 ? pos[i].frame + 1
                                           : -1;
    on_grid = g == g0 + static_cast<int64_t>(i);
  }
  return on_grid;
}

}  // namespace

struct Simulator::Workspace {
  MotionChunk chunk;
  std::vector<FramePosition> pos;  // per sample: its position on the motion's frame grid
  // Grid methods: per sensor joint (kept_slot), world w, x, y, z and position x, y, z arrays over
  // the loaded frames; the forward kinematics' tile scratch and its per-joint source pointers.
  std::vector<double> pose;
  std::vector<double> fk_tile;
  std::vector<const double*> fk_rotations;
  // fd, per rate joint over the loaded frames: SO(3) increments d[f] = log(R[f]^T R[f+1]).
  std::vector<double> increments;  // per rate joint: x, y, z arrays and a too-large flag
  // Grid methods, per sensor: derivative values per grid frame, positions per loaded frame.
  Eigen::Matrix3Xd grid_f, grid_w;
  std::vector<double> sensor_position;  // x, y, z arrays
  std::vector<double> offset_xyz;       // per plan joint, from its plan parent
  std::vector<char> offset_is_zero;     // per plan joint
  std::vector<int> kept_slot;           // per plan joint: its slot in `pose`, or -1
  int kept_joints = 0;
  std::vector<int> rate_slot;  // per plan joint: its index among the rate joints, or -1
  int rate_joints = 0;
  // Spline: per plan joint, the interval whose chart coordinates are cached.
  std::vector<int64_t> chart_interval;
  std::vector<std::array<Vector3d, 4>> chart_psi;
  std::vector<int64_t> step_frame;  // per plan joint: f of the cached step log(q_f^* q_f+1)
  std::vector<Vector3d> step;
  std::vector<char> on_frame;  // per sample: taken by spline_on_frames
  std::vector<std::size_t> on_frame_samples;
  std::vector<int64_t> on_frame_frames;
  std::vector<double> on_frame_scratch;
  std::vector<const double*> on_frame_rotations;
  std::vector<Matrix3d> chart_R;
  std::vector<Matrix3d> R;
  std::vector<Vector3d> a, w, dw;

  // evaluate()'s phases, in order.
  void frame_positions(std::span<const TimeNs> times, double rate, int64_t N);
  void select_on_frame_samples(int64_t N, bool enabled);
  MotionWindow load_window(const Simulator& sim, MotionSource& motion, int64_t N, double rate);
  // spline
  void evaluate_spline(const Simulator& sim, const MotionWindow& mw, std::vector<SensorBlock>& out);
  void run_on_frame_samples(const Simulator& sim, const MotionWindow& mw,
                            std::vector<SensorBlock>& out);
  void update_chart(std::size_t k, int64_t fi, const SplineStencil& st, const MotionWindow& mw);
  void propagate_joint(const Simulator& sim, std::size_t k, const LagrangeWeights& L, double u,
                       int64_t fi, const SplineStencil& st, const MotionWindow& mw);
  void write_spline_sample(const Simulator& sim, std::size_t i,
                           std::vector<SensorBlock>& out) const;
  // fd and reference
  void evaluate_grid(const Simulator& sim, const MotionWindow& mw, std::vector<SensorBlock>& out);
  void grid_forward_kinematics(const Simulator& sim, const MotionWindow& mw);
  void fd_increments(const MotionWindow& mw, const GridFrames& grid);
  void grid_sensor(const Simulator& sim, std::size_t s, const MotionWindow& mw,
                   const GridFrames& grid, std::vector<SensorBlock>& out);
  void fd_grid_values(const Simulator& sim, std::size_t s, const MotionWindow& mw,
                      const GridFrames& grid, int64_t gl, double* gf, double* gw) const;
  void reference_grid_values(const Simulator& sim, std::size_t s, const MotionWindow& mw,
                             const GridFrames& grid, int64_t gl, double* gf, double* gw) const;
  void grid_to_samples(const Simulator& sim, std::size_t s, const MotionWindow& mw,
                       const GridFrames& grid, const double* gf, const double* gw,
                       std::vector<SensorBlock>& out) const;
  // Sensor joint k's pose arrays (`frames` apart), and its world rotation at frame f.
  const double* joint_pose(std::size_t k, std::size_t frames) const {
    return pose.data() + static_cast<std::size_t>(kept_slot[k]) * 7 * frames;
  }
  Quaterniond world_rotation(int64_t f, std::size_t k, const MotionWindow& mw) const {
    const std::size_t Fz = mw.frames();
    const double* q = joint_pose(k, Fz) + (f - mw.lo);
    return Quaterniond(q[0], q[Fz], q[2 * Fz], q[3 * Fz]);
  }
  // fd: rate joint k's increment d[f].
  Vector3d increment(int64_t f, std::size_t k, const MotionWindow& mw,
                     const GridFrames& grid) const {
    assert(f >= grid.d0 && f <= grid.d1 && rate_slot[k] >= 0);
    (void)grid;
    const std::size_t Fz = mw.frames();
    const double* D = increments.data() + static_cast<std::size_t>(rate_slot[k]) * 4 * Fz +
                      static_cast<std::size_t>(f - mw.lo);
    return Vector3d(D[0], D[Fz], D[2 * Fz]);
  }
  // The current sensor's position at frame f (from sensor_position).
  Vector3d sensor_position_at(int64_t f, const MotionWindow& mw) const {
    const std::size_t Fz = mw.frames();
    const double* x = sensor_position.data() + (f - mw.lo);
    return Vector3d(x[0], x[Fz], x[2 * Fz]);
  }
};

Simulator::Simulator(const Body& body, std::vector<SensorSpec> sensors, SimulationOptions options)
    : plan_(compile_plan(body, sensors)),
      sensors_(std::move(sensors)),
      options_(options),
      ws_(std::make_unique<Workspace>()) {
  if (options_.rate_hz != 0.0 && !(std::isfinite(options_.rate_hz) && options_.rate_hz > 0.0)) {
    throw Error("simulation: the sensor rate must be finite and positive");
  }
  if (!options_.gravity_world.allFinite()) throw Error("simulation: gravity must be finite");
  check_chunk_frames(static_cast<double>(options_.chunk_frames), "simulation: chunk_frames");
  for (SensorSpec& s : sensors_) {
    const double n = s.placement.q_joint_sensor.norm();
    if (!std::isfinite(n) || n < 1e-12 || !s.placement.p_joint_sensor.allFinite()) {
      throw Error("sensor " + s.name + ": placement is not finite");
    }
    if (const Vector3d& p = s.placement.p_joint_sensor;
        p.cwiseAbs().maxCoeff() > PlausibilityLimits::max_position_m) {
      throw Error(
          fmt::format("sensor {}: position ({:g} {:g} {:g}) m is beyond {:g} m (not metres?)",
                      s.name, p.x(), p.y(), p.z(), PlausibilityLimits::max_position_m));
    }
    s.placement.q_joint_sensor.coeffs() /= n;
  }
  for (std::size_t k = 0; k < plan_.joints.size(); ++k) {
    ws_->rate_slot.push_back(plan_.needs_rate[k] ? ws_->rate_joints++ : -1);
    const bool sensor_joint = std::find(plan_.sensor_joint.begin(), plan_.sensor_joint.end(),
                                        static_cast<int>(k)) != plan_.sensor_joint.end();
    ws_->kept_slot.push_back(sensor_joint ? ws_->kept_joints++ : -1);
    ws_->offset_is_zero.push_back(
        plan_.parent[k] < 0 ||
        body.joint(static_cast<std::size_t>(plan_.joints[k])).offset_parent_joint.isZero(0.0));
    offsets_.push_back(
        plan_.parent[k] < 0
            ? Vector3d::Zero()
            : body.joint(static_cast<std::size_t>(plan_.joints[k])).offset_parent_joint);
    ws_->offset_xyz.insert(ws_->offset_xyz.end(), offsets_.back().data(),
                           offsets_.back().data() + 3);
  }
}

Simulator::~Simulator() = default;
Simulator::Simulator(Simulator&&) noexcept = default;
Simulator& Simulator::operator=(Simulator&&) noexcept = default;

void check_gravity(const Eigen::Vector3d& gravity_world, const std::string& what) {
  const double g = gravity_world.stableNorm();  // 1e300 reads as itself, not inf
  if (!(g >= GravityLimits::min_m_s2 && g <= GravityLimits::max_m_s2)) {
    std::ostringstream message;
    message << what << ": |g| = " << g << " m/s^2 is outside " << GravityLimits::text;
    throw Error(message.str());
  }
}

void check_chunk_frames(double chunk_frames, const std::string& what) {
  if (!(chunk_frames >= 8 && chunk_frames <= 1e7 && std::floor(chunk_frames) == chunk_frames))
    throw Error(fmt::format("{}: must be a whole number in [8, 1e7], got {}", what, chunk_frames));
}

double sample_rate_hz(const SimulationOptions& options, const MotionSource& motion) {
  // Only 0 means the motion's rate: a negative or NaN rate is passed on, for sample_count to
  // refuse, not replaced.
  return options.rate_hz != 0.0 ? options.rate_hz : motion.rate_hz();
}

int64_t sample_count(double motion_rate_hz, int64_t frames, double rate) {
  if (frames < 1) return 0;
  // Every rate that reaches the sample clock passes here: within the limits a period fits
  // int64 ns with room to spare (at 1e-10 Hz it overflowed and the search below never ended).
  check_rate(rate, "simulation: the sample rate");
  check_rate(motion_rate_hz, "simulation: the motion's frame rate");
  int64_t n =
      static_cast<int64_t>(std::floor(static_cast<double>(frames - 1) / motion_rate_hz * rate));
  n = std::max<int64_t>(n - 2, 0);
  SampleClock clock(0, rate);
  const auto inside = [&](int64_t k) {
    return position_in_motion(clock(k), motion_rate_hz, frames).has_value();
  };
  // The estimate is a sample or two short of the last sample inside (rounding); the search is
  // bounded all the same, so no input can make it spin.
  for (int step = 0; inside(n + 1); ++step) {
    if (step == 64)
      throw Error("simulation: cannot count the samples at " + std::to_string(rate) + " Hz");
    ++n;
  }
  while (n > 0 && !inside(n)) --n;
  return n + 1;
}

int64_t Simulator::sample_count(const MotionSource& motion, int64_t frames) const {
  return sim::sample_count(motion.rate_hz(), frames, sample_rate_hz(options_, motion));
}

int64_t Simulator::frame_at(TimeNs t, double motion_rate_hz) {
  return frame_position(t, motion_rate_hz).frame;
}

int64_t Simulator::sample_count(const MotionSource& motion, int64_t frames, double rate) const {
  return sim::sample_count(motion.rate_hz(), frames, rate);
}

TimeNs Simulator::sample_time_ns(const MotionSource& motion, int64_t n) const {
  return sample_time(0, n, sample_rate_hz(options_, motion));
}

// Each sample's position on the frame grid, checked: inside the motion, in increasing order.
void Simulator::Workspace::frame_positions(std::span<const TimeNs> times, double rate, int64_t N) {
  pos.resize(times.size());
  for (std::size_t i = 0; i < times.size(); ++i) {
    const std::optional<FramePosition> p = position_in_motion(times[i], rate, N);
    if (times[i] < 0 || !p) {
      throw Error("simulation: time " + std::to_string(times[i]) + " ns is outside the motion (" +
                  std::to_string(N) + " frames at " + std::to_string(rate) + " Hz)");
    }
    pos[i] = *p;
    if (i > 0 && times[i] < times[i - 1]) throw Error("simulation: times must increase");
  }
}

// The spline's samples on frames with the full interior stencil (spline_on_frames; the rest are
// evaluated one by one).
void Simulator::Workspace::select_on_frame_samples(int64_t N, bool enabled) {
  on_frame.assign(pos.size(), 0);
  on_frame_samples.clear();
  on_frame_frames.clear();
  for (std::size_t i = 0; i < pos.size() && enabled; ++i) {
    if (pos[i].frac == 0.0 && pos[i].frame >= 1 && pos[i].frame + 2 <= N - 1) {
      on_frame[i] = 1;
      on_frame_samples.push_back(i);
      on_frame_frames.push_back(pos[i].frame);
    }
  }
}

MotionWindow Simulator::Workspace::load_window(const Simulator& sim, MotionSource& motion,
                                               int64_t N, double rate) {
  MotionWindow mw;
  mw.lo = std::max<int64_t>(0, pos.front().frame - 2);
  mw.hi = std::min<int64_t>(N, pos.back().frame + 4);
  mw.N = N;
  mw.rate = rate;
  mw.joints = sim.plan_.joints.data();
  mw.J = sim.plan_.joints.size();
  mw.direct = dynamic_cast<const Motion*>(&motion);
  if (mw.direct == nullptr) motion.read(mw.lo, mw.hi - mw.lo, sim.plan_.joints, chunk);
  mw.chunk = &chunk;
  mw.translation = mw.direct != nullptr ? mw.direct->translation_data() + 3 * mw.lo
                                        : chunk.root_translation.data();
  return mw;
}

// ---- spline ------------------------------------------------------------------------------------

void Simulator::Workspace::evaluate_spline(const Simulator& sim, const MotionWindow& mw,
                                           std::vector<SensorBlock>& out) {
  const std::size_t J = sim.plan_.joints.size();
  chart_interval.assign(J, -1);
  step_frame.assign(J, -1);
  step.resize(J);
  chart_psi.resize(J);
  chart_R.resize(J);
  R.resize(J);
  a.resize(J);
  w.resize(J);
  dw.resize(J);
  if (!on_frame_samples.empty()) run_on_frame_samples(sim, mw, out);
  // The Lagrange weights of the previous sample, reused while its stencil and position repeat.
  LagrangeWeights last_L;
  double last_u = 0.0;
  std::array<double, 4> last_tau{};
  for (std::size_t i = 0; i < pos.size(); ++i) {
    if (on_frame[i] != 0) continue;
    const int64_t fi = pos[i].frame;
    const SplineStencil st = spline_stencil(fi, mw.N);
    const double u = pos[i].frac;
    if (i == 0 || u != last_u || st.n != last_L.n || st.tau != last_tau) {
      last_L = lagrange(st.tau, st.n, u);
      last_u = u;
      last_tau = st.tau;
    }
    for (std::size_t k = 0; k < J; ++k) {
      if (chart_interval[k] != fi) update_chart(k, fi, st, mw);
      propagate_joint(sim, k, last_L, u, fi, st, mw);
    }
    write_spline_sample(sim, i, out);
  }
}

void Simulator::Workspace::run_on_frame_samples(const Simulator& sim, const MotionWindow& mw,
                                                std::vector<SensorBlock>& out) {
  const std::size_t J = sim.plan_.joints.size();
  OnFrameInputs in;
  in.plan = &sim.plan_;
  in.offsets = &sim.offsets_;
  in.sensors = &sim.sensors_;
  in.lo = mw.lo;
  on_frame_rotations.resize(J);
  for (std::size_t k = 0; k < J; ++k) on_frame_rotations[k] = mw.rotations(k);
  in.rotations = &on_frame_rotations;
  in.rotation_stride = mw.rotation_stride();
  in.translation = mw.translation;
  in.rate = mw.rate;
  in.gravity_world = sim.options_.gravity_world;
  in.magnetic_field_world = sim.options_.magnetic_field_world;
  spline_on_frames(in, on_frame_samples, on_frame_frames, on_frame_scratch, out);
}

// Plan joint k's chart at frame fi: psi_m = log(q_fi^* q_m) over the stencil. The neighbours' are
// the steps d_f = log(q_f^* q_f+1): d_fi forwards and -d_(fi-1) backwards, where d_(fi-1) was the
// previous chart's forward step.
void Simulator::Workspace::update_chart(std::size_t k, int64_t fi, const SplineStencil& st,
                                        const MotionWindow& mw) {
  const int64_t s0 = st.s0;
  const int n = st.n;
  const auto step_at = [&](int64_t f) -> Vector3d {
    if (step_frame[k] == f) return step[k];
    step_frame[k] = f;
    step[k] = relative_log(mw.q_local(f, k), mw.q_local(f + 1, k));
    return step[k];
  };
  auto& psi = chart_psi[k];
  const auto c0 = static_cast<int>(fi - s0);  // the chart centre's stencil index
  for (int m = 0; m < n; ++m) {
    const auto um = static_cast<std::size_t>(m);
    if (m == c0)
      psi[um] = Vector3d::Zero();
    else if (m == c0 - 1)
      psi[um] = -step_at(fi - 1);
    else if (m == c0 + 1)
      psi[um] = step_at(fi);
    else
      psi[um] = relative_log(mw.q_local(fi, k), mw.q_local(s0 + m, k));
  }
  for (int m = c0 + 2; m < n; ++m) {
    const auto u = static_cast<std::size_t>(m);
    psi[u] = unwrap_near(psi[u], 2.0 * psi[u - 1] - psi[u - 2]);
  }
  for (int m = c0 - 2; m >= 0; --m) {
    const auto u = static_cast<std::size_t>(m);
    psi[u] = unwrap_near(psi[u], 2.0 * psi[u + 1] - psi[u + 2]);
  }
  chart_R[k] = mw.q_local(fi, k).normalized().toRotationMatrix();
  chart_interval[k] = fi;
}

// Plan joint k at position u of interval fi: its local rotation and body rate and acceleration
// from the chart's cubic, then its world rotation, rate, acceleration and origin acceleration from
// its parent's (parents come first).
void Simulator::Workspace::propagate_joint(const Simulator& sim, std::size_t k,
                                           const LagrangeWeights& L, double u, int64_t fi,
                                           const SplineStencil& st, const MotionWindow& mw) {
  const int64_t s0 = st.s0;
  const int n = st.n;
  const double rate = mw.rate;
  Vector3d psi = Vector3d::Zero(), dpsi = Vector3d::Zero(), ddpsi = Vector3d::Zero();
  for (int m = 0; m < n; ++m) {
    const Vector3d& y = chart_psi[k][static_cast<std::size_t>(m)];
    if (u != 0.0) psi += L.w[static_cast<std::size_t>(m)] * y;
    dpsi += L.dw[static_cast<std::size_t>(m)] * y;
    ddpsi += L.ddw[static_cast<std::size_t>(m)] * y;
  }
  ExpDerivatives E;
  Matrix3d Rl;
  if (u == 0.0) {
    // On a frame psi = 0: exp is the identity and its body rate and acceleration are dpsi
    // and ddpsi themselves (what exp_with_derivatives returns there, bit for bit).
    E.w_body = dpsi * rate;
    E.dw_body = ddpsi * (rate * rate);
    Rl = chart_R[k];
  } else {
    E = exp_with_derivatives(psi, dpsi * rate, ddpsi * (rate * rate));
    Rl = chart_R[k] * E.e.toRotationMatrix();
  }
  const int p = sim.plan_.parent[k];
  if (p < 0) {
    // Differences from the interval's start frame: the weights of the derivatives sum
    // to 0 only up to rounding, differences make a still root exactly still.
    // (Positions and velocities are not needed: a sensor's acceleration follows from the
    // chain's rates and the root's acceleration.)
    const Vector3d t0 = mw.root_translation(fi);
    Vector3d ta = Vector3d::Zero();
    for (int m = 0; m < n; ++m)
      ta += L.ddw[static_cast<std::size_t>(m)] * (mw.root_translation(s0 + m) - t0);
    R[k] = Rl;
    a[k] = ta * (rate * rate);
    w[k] = Rl * E.w_body;
    dw[k] = Rl * E.dw_body;
  } else {
    const auto pp = static_cast<std::size_t>(p);
    const Vector3d o = R[pp] * sim.offsets_[k];
    R[k] = R[pp] * Rl;
    const Vector3d wl = R[k] * E.w_body;  // the joint's own rate, world axes
    w[k] = w[pp] + wl;
    dw[k] = dw[pp] + w[pp].cross(wl) + R[k] * E.dw_body;
    a[k] = a[pp] + dw[pp].cross(o) + w[pp].cross(w[pp].cross(o));
  }
}

// Sample i of every sensor from its joint's world rotation, rate and accelerations.
void Simulator::Workspace::write_spline_sample(const Simulator& sim, std::size_t i,
                                               std::vector<SensorBlock>& out) const {
  for (std::size_t s = 0; s < sim.sensors_.size(); ++s) {
    const auto k = static_cast<std::size_t>(sim.plan_.sensor_joint[s]);
    const Placement& pl = sim.sensors_[s].placement;
    const SensorOutputs& o = sim.sensors_[s].outputs;
    const Matrix3d Rs = R[k] * pl.q_joint_sensor.toRotationMatrix();
    const auto col = static_cast<Eigen::Index>(i);
    if (o.accelerometer) {
      const Vector3d r = R[k] * pl.p_joint_sensor;
      const Vector3d acc = a[k] + dw[k].cross(r) + w[k].cross(w[k].cross(r));
      out[s].specific_force.col(col) = Rs.transpose() * (acc - sim.options_.gravity_world);
    }
    if (o.gyroscope) out[s].angular_rate.col(col) = Rs.transpose() * w[k];
    if (o.orientation) out[s].q_world_sensor[i] = canonical(Quaterniond(Rs).normalized());
    if (o.magnetometer)
      out[s].magnetic_field.col(col) = Rs.transpose() * sim.options_.magnetic_field_world;
  }
}

// ---- grid methods (fd, reference) --------------------------------------------------------------
//
// Forward kinematics on every loaded frame (kernel forward_kinematics), keeping the sensor joints'
// world rotations and positions per frame as arrays (pose); the SO(3) increments (fd) and the
// interior frames' samples in kernels too; the ends of the motion, the reference method and
// orientation outputs quaternion by quaternion.
void Simulator::Workspace::evaluate_grid(const Simulator& sim, const MotionWindow& mw,
                                         std::vector<SensorBlock>& out) {
  grid_forward_kinematics(sim, mw);
  GridFrames grid;
  grid.g0 = pos.front().frame;
  grid.g1 = std::min<int64_t>(mw.N - 1, pos.back().frame + 1);
  grid.d0 = std::max<int64_t>(mw.lo, grid.g0 - 1);
  grid.d1 = std::min<int64_t>(grid.g1, mw.N - 2);
  if (sim.options_.method == DerivativeMethod::fd) fd_increments(mw, grid);
  grid.on_grid = samples_on_grid(pos, grid.g0);
  for (std::size_t s = 0; s < sim.sensors_.size(); ++s) grid_sensor(sim, s, mw, grid, out);
}

void Simulator::Workspace::grid_forward_kinematics(const Simulator& sim, const MotionWindow& mw) {
  const std::size_t J = sim.plan_.joints.size();
  const std::size_t Fz = mw.frames();
  pose.resize(static_cast<std::size_t>(kept_joints) * 7 * Fz);
  fk_tile.resize(J * 7 * kFkTile);
  fk_rotations.resize(J);
  for (std::size_t k = 0; k < J; ++k) fk_rotations[k] = mw.rotations(k);
  ForwardKinematicsArgs fk;
  fk.joints = J;
  fk.frames = Fz;
  fk.rotations = fk_rotations.data();
  fk.stride = mw.rotation_stride();
  fk.translation = mw.translation;
  fk.parent = sim.plan_.parent.data();
  fk.offsets = offset_xyz.data();
  fk.offset_is_zero = offset_is_zero.data();
  fk.kept = kept_slot.data();
  fk.positions = sim.plan_.needs_position;
  fk.tile = fk_tile.data();
  fk.pose = pose.data();
  forward_kinematics(fk);
}

// fd: SO(3) increments d[f] = log(R[f]^T R[f+1]) (the body-frame rotation from frame f to f + 1)
// of every joint that carries a gyroscope, once per joint however many sensors share it, for f in
// [d0, d1]. By the branch-free small-angle series; the rare larger increments (flagged) through
// so3_log afterwards.
void Simulator::Workspace::fd_increments(const MotionWindow& mw, const GridFrames& grid) {
  const std::size_t Fz = mw.frames();
  increments.resize(static_cast<std::size_t>(rate_joints) * 4 * Fz);
  for (std::size_t k = 0; k < mw.J; ++k) {
    if (rate_slot[k] < 0 || grid.d1 < grid.d0) continue;
    double* D = increments.data() + static_cast<std::size_t>(rate_slot[k]) * 4 * Fz;
    const auto first = static_cast<std::size_t>(grid.d0 - mw.lo);
    const auto last = static_cast<std::size_t>(grid.d1 - mw.lo);
    // (Qualified: `increments` here is the member array.)
    if (sim::increments(joint_pose(k, Fz), Fz, first, last - first + 1, D) == 0.0) continue;
    for (std::size_t f = first; f <= last; ++f) {
      if (D[3 * Fz + f] == 0.0) continue;
      const auto ff = static_cast<int64_t>(f) + mw.lo;
      const Vector3d d = relative_log(world_rotation(ff, k, mw), world_rotation(ff + 1, k, mw));
      D[f] = d.x();
      D[Fz + f] = d.y();
      D[2 * Fz + f] = d.z();
    }
  }
}

// Sensor s: its values on the grid frames, then at the samples.
void Simulator::Workspace::grid_sensor(const Simulator& sim, std::size_t s, const MotionWindow& mw,
                                       const GridFrames& grid, std::vector<SensorBlock>& out) {
  const auto k = static_cast<std::size_t>(sim.plan_.sensor_joint[s]);
  const Placement& pl = sim.sensors_[s].placement;
  const SensorOutputs& o = sim.sensors_[s].outputs;
  const auto G = static_cast<Eigen::Index>(grid.g1 - grid.g0 + 1);
  // One sample per frame from g0 on (the sensor at the motion's rate): the grid values are
  // the samples, written in place.
  const bool direct_out = grid.on_grid && !o.orientation && !o.magnetometer;
  // The last frame computed: the last sample's when they are written in place.
  const int64_t gl = direct_out ? grid.g0 + static_cast<int64_t>(pos.size()) - 1 : grid.g1;
  if (!direct_out) {
    grid_f.resize(3, o.accelerometer ? G : 0);
    grid_w.resize(3, o.gyroscope ? G : 0);
  }
  double* gf = direct_out ? out[s].specific_force.data() : grid_f.data();
  double* gw = direct_out ? out[s].angular_rate.data() : grid_w.data();
  // Sensor positions on every loaded frame.
  if (o.accelerometer) {
    const std::size_t Fz = mw.frames();
    sensor_position.resize(3 * Fz);
    sensor_positions(joint_pose(k, Fz), Fz, pl.p_joint_sensor.data(), 0, Fz,
                     sensor_position.data());
  }
  if (sim.options_.method == DerivativeMethod::fd)
    fd_grid_values(sim, s, mw, grid, gl, gf, gw);
  else
    reference_grid_values(sim, s, mw, grid, gl, gf, gw);
  if (!direct_out) grid_to_samples(sim, s, mw, grid, gf, gw, out);
}

// fd on grid frames g0 .. gl: interior frames in the kernel, then the frames at the motion's ends
// (if loaded).
void Simulator::Workspace::fd_grid_values(const Simulator& sim, std::size_t s,
                                          const MotionWindow& mw, const GridFrames& grid,
                                          int64_t gl, double* gf, double* gw) const {
  const auto k = static_cast<std::size_t>(sim.plan_.sensor_joint[s]);
  const Placement& pl = sim.sensors_[s].placement;
  const SensorOutputs& o = sim.sensors_[s].outputs;
  const int64_t N = mw.N, g0 = grid.g0, lo = mw.lo;
  const std::size_t Fz = mw.frames();
  const double rate = mw.rate, rate2 = rate * rate;
  const Vector3d gravity = sim.options_.gravity_world;
  const Matrix3d R_sensor_joint = pl.q_joint_sensor.toRotationMatrix().transpose();
  const auto P = [&](int64_t f) { return sensor_position_at(f, mw); };
  const auto qw = [&](int64_t f, std::size_t j) { return world_rotation(f, j, mw); };
  const auto increment = [&](int64_t f, std::size_t j) { return this->increment(f, j, mw, grid); };
  const int64_t ia = std::max<int64_t>(g0, 1), ib = std::min<int64_t>(gl, N - 2);
  if (ib >= ia) {
    FdInteriorArgs fa;
    fa.pose = joint_pose(k, Fz);
    fa.position = o.accelerometer ? sensor_position.data() : nullptr;
    fa.increments =
        o.gyroscope ? increments.data() + static_cast<std::size_t>(rate_slot[k]) * 4 * Fz : nullptr;
    fa.frames = Fz;
    fa.first = static_cast<std::size_t>(ia - lo);
    fa.count = static_cast<std::size_t>(ib - ia + 1);
    for (int r = 0; r < 3; ++r) {
      for (int cc = 0; cc < 3; ++cc) fa.R_sensor_joint[3 * r + cc] = R_sensor_joint(r, cc);
      fa.gravity[r] = gravity[r];
    }
    fa.rate = rate;
    // An output not requested has no storage (null): no offset into it (UB even unused).
    fa.force = o.accelerometer ? gf + 3 * (ia - g0) : nullptr;
    fa.angular_rate = o.gyroscope ? gw + 3 * (ia - g0) : nullptr;
    fd_interior(fa);
  }
  const int64_t ends[2] = {g0, gl};
  for (int e = 0; e < (gl == g0 ? 1 : 2); ++e) {
    const int64_t g = ends[e];
    if (g > 0 && g < N - 1) continue;
    const auto col = static_cast<std::size_t>(g - g0);
    if (o.accelerometer) {
      Vector3d acc = Vector3d::Zero();
      if (N >= 4) {  // one-sided, second order: (2 p0 - 5 p1 + 4 p2 - p3) / h^2
        const int64_t d = g == 0 ? 1 : -1;
        acc = (2.0 * (P(g) - P(g + d)) - 3.0 * (P(g + d) - P(g + 2 * d)) +
               (P(g + 2 * d) - P(g + 3 * d))) *
              rate2;
      } else if (N == 3) {
        acc = ((P(2) - P(1)) - (P(1) - P(0))) * rate2;
      }
      store3(gf + 3 * col, R_sensor_joint * rotate_inverse(qw(g, k), acc - gravity));
    }
    if (o.gyroscope) {
      Vector3d omega;
      if (N >= 3) {
        // Chart at the end frame: psi_1, psi_2 of the two neighbours inwards,
        // w = (4 psi_1 - psi_2) / (2 h) (one-sided, second order).
        const int64_t d = g == 0 ? 1 : -1;
        const Vector3d psi1 = g == 0 ? increment(g, k) : Vector3d(-increment(g - 1, k));
        const Vector3d psi2 =
            unwrap_near(so3_log(qw(g, k).conjugate() * qw(g + 2 * d, k)), 2.0 * psi1);
        omega = (4.0 * psi1 - psi2) * (0.5 * rate) * static_cast<double>(d);
      } else {
        omega = increment(0, k) * rate;
      }
      store3(gw + 3 * col, R_sensor_joint * omega);
    }
  }
}

// The reference method on grid frames g0 .. gl.
void Simulator::Workspace::reference_grid_values(const Simulator& sim, std::size_t s,
                                                 const MotionWindow& mw, const GridFrames& grid,
                                                 int64_t gl, double* gf, double* gw) const {
  const auto k = static_cast<std::size_t>(sim.plan_.sensor_joint[s]);
  const Placement& pl = sim.sensors_[s].placement;
  const SensorOutputs& o = sim.sensors_[s].outputs;
  const int64_t N = mw.N, g0 = grid.g0;
  const double rate = mw.rate;
  const Vector3d gravity = sim.options_.gravity_world;
  const auto P = [&](int64_t f) { return sensor_position_at(f, mw); };
  const auto qw = [&](int64_t f, std::size_t j) { return world_rotation(f, j, mw); };
  for (int64_t g = g0; g <= gl; ++g) {
    const auto col = static_cast<std::size_t>(g - g0);
    const Quaterniond qs = multiply(qw(g, k), pl.q_joint_sensor);
    if (o.accelerometer) {
      // v = D1(p)/h and a = D1(v)/h with D1 central inside and one-sided at the ends.
      const auto vel = [&](int64_t f) -> Vector3d {
        if (f == 0) return (P(1) - P(0)) * rate;
        if (f == N - 1) return (P(N - 1) - P(N - 2)) * rate;
        return (P(f + 1) - P(f - 1)) * (0.5 * rate);
      };
      Vector3d acc;
      if (g == 0)
        acc = (vel(1) - vel(0)) * rate;
      else if (g == N - 1)
        acc = (vel(N - 1) - vel(N - 2)) * rate;
      else
        acc = (vel(g + 1) - vel(g - 1)) * (0.5 * rate);
      store3(gf + 3 * col, qs.conjugate() * (acc - gravity));
    }
    if (o.gyroscope) {
      const auto qsf = [&](int64_t f) { return multiply(qw(f, k), pl.q_joint_sensor); };
      Vector3d e;
      if (g == 0)
        e = reference_euler_xyz(multiply(qsf(1), qsf(0).conjugate()).toRotationMatrix());
      else if (g == N - 1)
        e = reference_euler_xyz(multiply(qsf(N - 1), qsf(N - 2).conjugate()).toRotationMatrix());
      else
        e = 0.5 *
            reference_euler_xyz(multiply(qsf(g + 1), qsf(g - 1).conjugate()).toRotationMatrix());
      store3(gw + 3 * col, qs.conjugate() * (e * rate));
    }
  }
}

// Samples between frames: linear interpolation of the frame values; the orientation by slerp.
void Simulator::Workspace::grid_to_samples(const Simulator& sim, std::size_t s,
                                           const MotionWindow& mw, const GridFrames& grid,
                                           const double* gf, const double* gw,
                                           std::vector<SensorBlock>& out) const {
  const auto k = static_cast<std::size_t>(sim.plan_.sensor_joint[s]);
  const Placement& pl = sim.sensors_[s].placement;
  const SensorOutputs& o = sim.sensors_[s].outputs;
  const Vector3d& B_world = sim.options_.magnetic_field_world;
  const int64_t g0 = grid.g0;
  const auto qw = [&](int64_t f, std::size_t j) { return world_rotation(f, j, mw); };
  double* of = out[s].specific_force.data();
  double* ow = out[s].angular_rate.data();
  double* om = out[s].magnetic_field.data();
  for (std::size_t i = 0; i < pos.size(); ++i) {
    const auto at = static_cast<std::size_t>(pos[i].frame - g0);
    const double u = pos[i].frac;
    const auto put = [&](double* dst, const double* values) {
      const double* x0 = values + 3 * at;
      if (u == 0.0) {
        dst[0] = x0[0], dst[1] = x0[1], dst[2] = x0[2];
      } else if (u == 1.0) {
        dst[0] = x0[3], dst[1] = x0[4], dst[2] = x0[5];
      } else {
        for (int r = 0; r < 3; ++r) dst[r] = (1.0 - u) * x0[r] + u * x0[r + 3];
      }
    };
    if (o.accelerometer) put(of + 3 * i, gf);
    if (o.gyroscope) put(ow + 3 * i, gw);
    if (o.orientation || o.magnetometer) {
      // Between frames the orientation is the slerp of the frame orientations (fd's linear
      // interpolation, on SO(3)).
      const Quaterniond q0 = qw(pos[i].frame, k) * pl.q_joint_sensor;
      const Quaterniond q_ws =
          u == 0.0 ? q0.normalized()
                   : slerp(q0, qw(pos[i].frame + 1, k) * pl.q_joint_sensor, u).normalized();
      if (o.orientation) out[s].q_world_sensor[i] = canonical(q_ws);
      if (o.magnetometer) store3(om + 3 * i, rotate_inverse(q_ws, B_world));
    }
  }
}

double AntiAliasFilter::kernel(double x) {
  const double r = std::abs(x) / half_width_periods;
  if (!(r < 1.0)) return 0.0;
  const double sinc = x == 0.0 ? 1.0 : std::sin(std::numbers::pi * x) / (std::numbers::pi * x);
  return sinc * std::cyl_bessel_i(0.0, kaiser_beta * std::sqrt(1.0 - r * r)) /
         std::cyl_bessel_i(0.0, kaiser_beta);
}

namespace {

// AntiAliasFilter::kernel (an even function) tabulated on [0, half_width_periods], kPerPeriod
// points per sensor period, linearly interpolated: within 2e-6 of the kernel (its curvature is
// at most pi^2 / 3), where a Bessel function per weight cost a microsecond.
class AntiAliasTable {
 public:
  static constexpr int kPerPeriod = 512;
  AntiAliasTable() {
    const auto n = static_cast<std::size_t>(AntiAliasFilter::half_width_periods * kPerPeriod);
    values_.resize(n + 2, 0.0);  // the last stays 0: the kernel's end
    for (std::size_t i = 0; i <= n; ++i)
      values_[i] = AntiAliasFilter::kernel(static_cast<double>(i) / kPerPeriod);
    end_ = static_cast<double>(n);
  }
  double operator()(double x) const {
    const double p = std::abs(x) * kPerPeriod;
    if (!(p < end_)) return 0.0;
    const auto i = static_cast<std::size_t>(p);
    return values_[i] + (p - static_cast<double>(i)) * (values_[i + 1] - values_[i]);
  }

 private:
  std::vector<double> values_;
  double end_ = 0.0;
};

const AntiAliasTable& anti_alias_table() {
  static const AntiAliasTable table;
  return table;
}

// Frames evaluate_band_limited evaluates at a time: 65536 frames of values, 72 bytes each per
// sensor with every output.
constexpr int64_t kMaxPassFrames = 65536;

}  // namespace

bool Simulator::anti_aliases(const MotionSource& motion) const {
  return options_.anti_alias && sample_rate_hz(options_, motion) < motion.rate_hz();
}

int64_t Simulator::block_frames(const MotionSource& motion) const {
  if (!anti_aliases(motion)) return options_.chunk_frames;
  const double reach =
      AntiAliasFilter::half_width_periods * motion.rate_hz() / sample_rate_hz(options_, motion);
  return std::max<int64_t>(options_.chunk_frames,
                           static_cast<int64_t>(std::min(4.0 * std::ceil(reach), 1e15)));
}

void Simulator::evaluate(MotionSource& motion, std::span<const TimeNs> times,
                         std::vector<SensorBlock>& out) {
  if (anti_aliases(motion))
    evaluate_band_limited(motion, times, out);
  else
    evaluate_points(motion, times, out);
}

// The values on the frames around the times, and each sample the kernel's weighted mean of them
// (AntiAliasFilter).
void Simulator::evaluate_band_limited(MotionSource& motion, std::span<const TimeNs> times,
                                      std::vector<SensorBlock>& out) {
  require_simulatable(motion, "simulation");
  const int64_t N = motion.frame_count().value_or(kEndless);
  const double motion_rate = motion.rate_hz();
  const double periods_per_frame = sample_rate_hz(options_, motion) / motion_rate;
  const double reach = AntiAliasFilter::half_width_periods / periods_per_frame;  // frames
  size_outputs(sensors_, times, out);
  if (times.empty() || sensors_.empty()) return;
  ws_->frame_positions(times, motion_rate, N);  // the times checked: inside, increasing
  const std::vector<FramePosition> pos = ws_->pos;
  const auto in_frames = [](const FramePosition& p) {
    return static_cast<double>(p.frame) + p.frac;
  };
  // The pose at the sample itself: no filter acts on it.
  if (std::any_of(sensors_.begin(), sensors_.end(),
                  [](const SensorSpec& s) { return s.outputs.orientation; })) {
    evaluate_points(motion, times, frame_blocks_);
    for (std::size_t s = 0; s < sensors_.size(); ++s)
      out[s].q_world_sensor = frame_blocks_[s].q_world_sensor;
  }
  const AntiAliasTable& kernel = anti_alias_table();
  // A sample's weights depend on its position within its frame interval only: taps k (frames
  // from the interval's start) from ceil(frac - reach) to floor(frac + reach), weight
  // kernel((k - frac) f_s / f_m), normalised. Samples at a rational ratio of the rates take a
  // few positions (5 for 50 Hz from 120): their weights are computed once per call. A sensor
  // far slower than the motion has too many taps to keep (24 x 60000 at 1/60 Hz from 1 kHz):
  // its weights are computed tap by tap, with their sum once per sample.
  constexpr std::size_t kMaxKeptTaps = 4096;
  struct Taps {
    int64_t first = 0, last = 0;  // k of the first and last tap
    std::vector<double> weights;  // summing to 1; empty: computed tap by tap
    double inverse_sum = 0.0;     // for taps computed one by one
  };
  std::unordered_map<double, Taps> taps_at;
  const auto taps_for = [&](double frac) -> const Taps& {
    if (const auto it = taps_at.find(frac); it != taps_at.end()) return it->second;
    Taps t;
    t.first = static_cast<int64_t>(std::ceil(frac - reach));
    t.last = static_cast<int64_t>(std::floor(frac + reach));
    const bool keep = static_cast<std::size_t>(t.last - t.first + 1) <= kMaxKeptTaps;
    double sum = 0.0;
    for (int64_t k = t.first; k <= t.last; ++k) {
      const double w = kernel((static_cast<double>(k) - frac) * periods_per_frame);
      if (keep) t.weights.push_back(w);
      sum += w;
    }
    for (double& w : t.weights) w /= sum;
    t.inverse_sum = 1.0 / sum;
    if (taps_at.size() >= 256) taps_at.clear();  // jittered or irrational times: no reuse
    return taps_at.emplace(frac, std::move(t)).first->second;
  };
  // The filtered channels are sums over the taps, frame chunk after frame chunk: the frames are
  // evaluated once each, at most kMaxPassFrames at a time, so memory does not grow with the block
  // nor with how much slower than the motion the sensor is. Each sample adds its taps in frame
  // order whatever the chunks, so its value does not depend on them.
  for (std::size_t s = 0; s < sensors_.size(); ++s) {
    out[s].specific_force.setZero();
    out[s].angular_rate.setZero();
    out[s].magnetic_field.setZero();
  }
  const auto clamped = [N](double f) {
    return static_cast<int64_t>(std::clamp(f, 0.0, static_cast<double>(N - 1)));
  };
  const int64_t lo = clamped(std::floor(in_frames(pos.front()) - reach));
  const int64_t hi = clamped(std::ceil(in_frames(pos.back()) + reach));
  std::size_t done = 0;         // samples before it have all their taps
  std::vector<double> scratch;  // weights of taps not kept
  for (int64_t c0 = lo; c0 <= hi; c0 += kMaxPassFrames) {
    const int64_t c1 = std::min(hi, c0 + kMaxPassFrames - 1);
    frame_times_.resize(static_cast<std::size_t>(c1 - c0 + 1));
    for (int64_t f = c0; f <= c1; ++f)
      frame_times_[static_cast<std::size_t>(f - c0)] = sample_time(0, f, motion_rate);
    evaluate_points(motion, frame_times_, frame_blocks_);
    // The taps this chunk serves: its frames, and past the motion's ends (where the motion holds
    // its first or last frame) the taps beyond them, in the chunk that holds the end frame.
    const int64_t t0 = c0 == 0 ? std::numeric_limits<int64_t>::min() : c0;
    const int64_t t1 = c1 == N - 1 ? std::numeric_limits<int64_t>::max() : c1;
    for (std::size_t i = done; i < times.size(); ++i) {
      const Taps& taps = taps_for(pos[i].frac);
      const int64_t f0 = pos[i].frame + taps.first, f1 = pos[i].frame + taps.last;
      if (f1 < t0) {
        if (i == done) ++done;
        continue;
      }
      if (f0 > t1) break;  // and so are the later samples'
      const int64_t a = std::max(f0, t0), b = std::min(f1, t1);
      // The weights of taps a..b: kept, or computed once here for every channel.
      const double* w = nullptr;
      if (!taps.weights.empty()) {
        w = taps.weights.data() + (a - f0);
      } else {
        scratch.resize(static_cast<std::size_t>(b - a + 1));
        for (int64_t f = a; f <= b; ++f) {
          scratch[static_cast<std::size_t>(f - a)] =
              kernel((static_cast<double>(f - pos[i].frame) - pos[i].frac) * periods_per_frame) *
              taps.inverse_sum;
        }
        w = scratch.data();
      }
      const auto col = static_cast<Eigen::Index>(i);
      const auto add = [&](const Eigen::Matrix3Xd& on_frames, Eigen::Matrix3Xd& samples) {
        if (samples.cols() == 0) return;
        double x = samples(0, col), y = samples(1, col), z = samples(2, col);
        if (a >= c0 && b <= c1) {  // the common case, in one run
          const double* p = on_frames.data() + 3 * (a - c0);
          for (int64_t k = 0; k <= b - a; ++k, p += 3) {
            x += w[k] * p[0];
            y += w[k] * p[1];
            z += w[k] * p[2];
          }
        } else {
          for (int64_t f = a; f <= b; ++f) {
            const double* p = on_frames.data() + 3 * (std::clamp(f, c0, c1) - c0);
            x += w[f - a] * p[0];
            y += w[f - a] * p[1];
            z += w[f - a] * p[2];
          }
        }
        samples.col(col) = Vector3d(x, y, z);
      };
      for (std::size_t s = 0; s < sensors_.size(); ++s) {
        add(frame_blocks_[s].specific_force, out[s].specific_force);
        add(frame_blocks_[s].angular_rate, out[s].angular_rate);
        add(frame_blocks_[s].magnetic_field, out[s].magnetic_field);
      }
    }
  }
}

void Simulator::evaluate_points(MotionSource& motion, std::span<const TimeNs> times,
                                std::vector<SensorBlock>& out) {
  require_simulatable(motion, "simulation");
  Workspace& ws = *ws_;
  const int64_t N = motion.frame_count().value_or(kEndless);
  const double rate = motion.rate_hz();
  size_outputs(sensors_, times, out);
  if (times.empty() || sensors_.empty()) return;
  ws.frame_positions(times, rate, N);
  const bool spline = options_.method == DerivativeMethod::spline;
  ws.select_on_frame_samples(N, spline && options_.spline_on_frames);
  const MotionWindow mw = ws.load_window(*this, motion, N, rate);
  if (spline)
    ws.evaluate_spline(*this, mw, out);
  else
    ws.evaluate_grid(*this, mw, out);
}

void Simulator::run(MotionSource& motion,
                    const std::function<void(std::size_t sensor, const SensorBlock& block)>& sink,
                    std::optional<int64_t> frame_limit) {
  require_simulatable(motion, "simulation");
  const std::optional<int64_t> count = motion.frame_count();
  const int64_t N = frames_to_simulate(motion, frame_limit, "simulation");
  // A bounded view of the source, so evaluate() sees the limit as the motion's end.
  LimitedMotion limited(motion, N);
  // The wrapper only when it changes something: evaluate() reads an in-memory Motion in place.
  MotionSource& source = count && *count == N ? motion : static_cast<MotionSource&>(limited);
  const int64_t total = sample_count(motion, N);
  const double motion_rate = motion.rate_hz();
  const double rate = sample_rate_hz(options_, motion);
  std::vector<TimeNs> times;
  std::vector<SensorBlock> blocks;
  SampleClock clock(0, rate);
  int64_t n = 0;
  const int64_t block = block_frames(motion);
  int64_t chunk_end = block;
  while (n < total) {
    times.clear();
    while (n < total && times.size() < kMaxBlockSamples) {
      const TimeNs t = clock(n);
      if (frame_position(t, motion_rate).frame >= chunk_end && !times.empty()) break;
      times.push_back(t);
      ++n;
    }
    while (n < total && frame_position(clock(n), motion_rate).frame >= chunk_end)
      chunk_end += block;
    evaluate(source, times, blocks);
    for (std::size_t s = 0; s < blocks.size(); ++s) sink(s, blocks[s]);
  }
}

Motion spline_resample(const Body& body, MotionSource& motion, std::span<const TimeNs> times,
                       double rate_hz) {
  require_simulatable(motion, "spline_resample");
  if (!motion.frame_count()) throw Error("spline_resample: the motion must have a finite length");
  if (!(rate_hz > 0.0 && std::isfinite(rate_hz)))
    throw Error("spline_resample: the new frame rate must be positive");
  if (motion.joint_count() != body.size()) {
    throw Error("spline_resample: the motion has " + std::to_string(motion.joint_count()) +
                " joints, the body " + std::to_string(body.size()));
  }
  const auto F = static_cast<int64_t>(times.size());
  const int64_t N = *motion.frame_count();
  Motion out(rate_hz, body.size(), F);
  if (F == 0) return out;
  // World orientations from the simulator itself (one orientation-only sensor per joint), so the
  // rotations are exactly the spline's; relative ones by q_parent^* q_child.
  std::vector<SensorSpec> specs(body.size());
  for (std::size_t j = 0; j < body.size(); ++j) {
    specs[j].name = std::to_string(j);
    specs[j].placement.joint = static_cast<int>(j);
    specs[j].outputs = {false, false, true, false};
  }
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(body, specs, so);
  std::vector<SensorBlock> blocks;
  sim.evaluate(motion, times, blocks);
  for (std::size_t j = 0; j < body.size(); ++j) {
    const int p = body.joint(j).parent;
    for (int64_t f = 0; f < F; ++f) {
      const auto i = static_cast<std::size_t>(f);
      Quaterniond q = p < 0 ? blocks[j].q_world_sensor[i]
                            : blocks[static_cast<std::size_t>(p)].q_world_sensor[i].conjugate() *
                                  blocks[j].q_world_sensor[i];
      // Keep the sign continuous from frame to frame (the same rotations either way).
      if (f > 0 && q.coeffs().dot(out.rotation(f - 1, j).coeffs()) < 0.0) q.coeffs() *= -1.0;
      out.rotation(f, j) = q.normalized();
    }
  }
  // The root translation: the spline's cubic through the stencil's frames, as evaluate() has it.
  // The frames read are those the stencils use (a time on the last frame is the end of the last
  // interval, whose stencil starts at N - 4, not where its frame number alone would put it).
  const double rate = motion.rate_hz();
  std::vector<FramePosition> positions(static_cast<std::size_t>(F));
  std::vector<SplineStencil> stencils(static_cast<std::size_t>(F));
  int64_t lo = N, hi = 0;
  for (std::size_t f = 0; f < positions.size(); ++f) {
    positions[f] = position_in_motion(times[f], rate, N).value_or(FramePosition{N - 2, 1.0});
    stencils[f] = spline_stencil(positions[f].frame, N);
    lo = std::min(lo, stencils[f].s0);
    hi = std::max(hi, stencils[f].s0 + stencils[f].n);
  }
  MotionChunk chunk;
  const std::array<int, 1> root{0};
  motion.read(lo, hi - lo, root, chunk);
  for (std::size_t f = 0; f < positions.size(); ++f) {
    const SplineStencil& st = stencils[f];
    const LagrangeWeights L = lagrange(st.tau, st.n, positions[f].frac);
    Vector3d p = Vector3d::Zero();
    for (int m = 0; m < st.n; ++m)
      p += L.w[static_cast<std::size_t>(m)] * chunk.root_translation.col(st.s0 + m - lo);
    out.root_translation(static_cast<int64_t>(f)) = p;
  }
  out.validate_and_normalize(&body);
  return out;
}

SimulatedSensorSource::SimulatedSensorSource(const Body& body, const SensorSpec& sensor,
                                             MotionSource& motion, SimulationOptions options)
    : simulator_(body, {sensor}, options), motion_(motion) {}

void SimulatedSensorSource::evaluate(std::span<const TimeNs> times,
                                     Eigen::Matrix3Xd* specific_force,
                                     Eigen::Matrix3Xd* angular_rate) {
  simulator_.evaluate(motion_, times, blocks_);
  if (specific_force != nullptr) *specific_force = blocks_.front().specific_force;
  if (angular_rate != nullptr) *angular_rate = blocks_.front().angular_rate;
}

}  // namespace imukit::sim
