#include "imukit/sim/identify.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>

#include "imukit/core/error.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/core/so3.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"
#include "imukit/sim/simulator.hpp"

namespace imukit::sim {
namespace {

constexpr int kMaxSegments = 6;
constexpr double kMinKnotSpacing_s = 0.01;
// The solver and the covariance hold the Jacobian densely: its size (residuals x parameters,
// doubles) is bounded before the problem is built. With --correct the parameters grow with the
// recording (a knot per spacing), so the size grows with its square (80 s at 100 Hz with the
// twist: 506 MB; found in review, 2026-11-27).
constexpr double kMaxDenseJacobianBytes = 2.0 * (1 << 30);
// Step of the central difference that gives the kinematics' time derivative. Inside one frame
// interval the spline's translation is a cubic, so its acceleration is linear in time and the
// central difference of it is exact; the rotational terms are smooth and the O(h^2) error is
// ~1e-8 of their size. Within h of a frame the difference is one-sided, inside the sample's own
// interval (evaluate() below says why).
constexpr TimeNs kTimeStepNs = 100'000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The coarse search tries at most this many clock rates (grid of +-max_clock_rate).
constexpr int kMaxCoarseRates = 401;
constexpr double kMaxCoarseProducts = 1e12;  // the coarse search's samples x lags x rates

// Rows of the per-sample kinematics, all in the joint frame at the sample's motion time:
// specific force of the joint origin (nominal segment lengths), angular rate, angular
// acceleration, gravity's part of the specific force (-R_world_joint^T g), then per identified
// segment the change of that specific force per metre of segment length (the rigid-body point
// acceleration is linear in the offsets).
enum Row { kF = 0, kW = 3, kAlpha = 6, kG = 9, kS = 12 };

// Joint kinematics at shifted sample times, from the spline simulator through its public API:
// a sensor at the joint origin (specific force, rate, orientation) and two at unit offsets along
// x and y, whose difference from the origin is alpha x e + w x (w x e), which gives alpha
// exactly; for each identified segment a pair of sensors on its parent joint gives the
// acceleration per metre of offset.
class KinematicsEvaluator {
 public:
  KinematicsEvaluator(const Body& body, MotionSource& motion, int joint, std::vector<int> segments,
                      const Eigen::Vector3d& gravity)
      : motion_(motion), segments_(std::move(segments)), gravity_(gravity) {
    auto sensor = [&](int j, const Eigen::Vector3d& p, bool gyro, bool orientation) {
      SensorSpec s;
      s.name = std::to_string(specs_.size());  // (no "s" + ...: gcc 12 -Wrestrict false positive)
      s.placement.joint = j;
      s.placement.p_joint_sensor = p;
      s.outputs.accelerometer = true;
      s.outputs.gyroscope = gyro;
      s.outputs.orientation = orientation;
      specs_.push_back(s);
    };
    sensor(joint, Eigen::Vector3d::Zero(), true, true);
    sensor(joint, Eigen::Vector3d::UnitX(), false, false);
    sensor(joint, Eigen::Vector3d::UnitY(), false, false);
    for (int c : segments_) {
      const Eigen::Vector3d& o = body.joint(static_cast<std::size_t>(c)).offset_parent_joint;
      const int p = body.joint(static_cast<std::size_t>(c)).parent;
      sensor(p, Eigen::Vector3d::Zero(), false, true);
      sensor(p, o.normalized(), false, false);
    }
    SimulationOptions so;
    so.method = DerivativeMethod::spline;
    so.gravity_world = gravity;
    sim_ = std::make_unique<Simulator>(body, specs_, so);
  }

  int rows() const { return kS + 3 * static_cast<int>(segments_.size()); }

  // Kinematics at motion times `tau_s` (s, increasing): value and time derivative.
  void evaluate(const std::vector<double>& tau_s, Eigen::MatrixXd& value, Eigen::MatrixXd& rate) {
    const std::size_t n = tau_s.size();
    std::vector<TimeNs> t0(n), tm(n), tp(n);
    for (std::size_t i = 0; i < n; ++i) {
      t0[i] = std::llround(tau_s[i] * 1e9);
      tm[i] = t0[i] - kTimeStepNs;
      tp[i] = t0[i] + kTimeStepNs;
    }
    Eigen::MatrixXd km, kp;
    raw(t0, value);
    raw(tm, km);
    raw(tp, kp);
    const double h = 1e-9 * static_cast<double>(kTimeStepNs);
    rate = (kp - km) / (2.0 * h);
    // Each frame interval has its own cubic: the rate-level terms (w, and the velocity behind
    // f) jump by O(h_frame^3) at a frame. A central difference straddling a frame would turn
    // that jump into a spike, so within h of a frame the difference is one-sided, inside the
    // sample's own interval (exact for the translation's jerk there too).
    const double mrate = motion_.rate_hz();
    for (std::size_t i = 0; i < n; ++i) {
      const double x = static_cast<double>(t0[i]) * 1e-9 * mrate;
      const double into = (x - std::floor(x)) / mrate;  // s since the frame before
      const auto c = static_cast<Eigen::Index>(i);
      if (into < h) {
        rate.col(c) = (kp.col(c) - value.col(c)) / h;
      } else if (1.0 / mrate - into < h) {
        rate.col(c) = (value.col(c) - km.col(c)) / h;
      }
    }
    // The sub-nanosecond remainder, to first order, so the kinematics are smooth in tau.
    for (std::size_t i = 0; i < n; ++i) {
      const double frac = tau_s[i] - static_cast<double>(t0[i]) * 1e-9;
      value.col(static_cast<Eigen::Index>(i)) += rate.col(static_cast<Eigen::Index>(i)) * frac;
    }
  }

 private:
  void raw(const std::vector<TimeNs>& t, Eigen::MatrixXd& k) {
    sim_->evaluate(motion_, t, blocks_);
    const auto n = static_cast<Eigen::Index>(t.size());
    k.resize(rows(), n);
    const SensorBlock& o = blocks_[0];
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d f = o.specific_force.col(i);
      const Eigen::Vector3d w = o.angular_rate.col(i);
      // f(e) - f(0) = alpha x e + w x (w x e): alpha x e_x = (0, az, -ay), alpha x e_y = (-az, 0,
      // ax).
      const Eigen::Vector3d dx =
          blocks_[1].specific_force.col(i) - f - w.cross(w.cross(Eigen::Vector3d::UnitX()));
      const Eigen::Vector3d dy =
          blocks_[2].specific_force.col(i) - f - w.cross(w.cross(Eigen::Vector3d::UnitY()));
      const Eigen::Vector3d alpha(dy.z(), -dx.z(), 0.5 * (dx.y() - dy.x()));
      k.block<3, 1>(kF, i) = f;
      k.block<3, 1>(kW, i) = w;
      k.block<3, 1>(kAlpha, i) = alpha;
      k.block<3, 1>(kG, i) =
          -(o.q_world_sensor[static_cast<std::size_t>(i)].conjugate() * gravity_);
      for (std::size_t s = 0; s < segments_.size(); ++s) {
        const SensorBlock& a = blocks_[3 + 2 * s];
        const SensorBlock& b = blocks_[4 + 2 * s];
        const Eigen::Quaterniond q_joint_parent =
            o.q_world_sensor[static_cast<std::size_t>(i)].conjugate() *
            a.q_world_sensor[static_cast<std::size_t>(i)];
        k.block<3, 1>(kS + 3 * static_cast<Eigen::Index>(s), i) =
            q_joint_parent * (b.specific_force.col(i) - a.specific_force.col(i));
      }
    }
  }

  MotionSource& motion_;
  std::vector<int> segments_;
  Eigen::Vector3d gravity_;
  std::vector<SensorSpec> specs_;
  std::unique_ptr<Simulator> sim_;
  std::vector<SensorBlock> blocks_;
};

// Uniform cubic B-spline weights of the four control points of a segment at u in [0, 1], and
// their first and second derivatives in u.
std::array<double, 12> bspline_weights(double u) {
  const double u2 = u * u, u3 = u2 * u, v = 1.0 - u;
  return {v * v * v / 6.0,
          (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
          (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
          u3 / 6.0,
          -0.5 * v * v,
          (3.0 * u2 - 4.0 * u) / 2.0,
          (-3.0 * u2 + 2.0 * u + 1.0) / 2.0,
          0.5 * u2,
          v,
          3.0 * u - 2.0,
          -3.0 * u + 1.0,
          u};
}

// Where IMU time t falls on a correction spline of `segments` knot intervals: the first control
// point and the weights (value, d/dt, d2/dt2) of it and the next three. Outside [t0, t1] the
// spline is held at its end value.
struct SplineSpot {
  int first = 0;
  std::array<double, 12> w{};
};
SplineSpot spline_spot(TimeNs t0, double spacing, int segments, TimeNs t) {
  const double x = to_seconds(t - t0) / spacing;
  SplineSpot s;
  const double xc = std::clamp(x, 0.0, static_cast<double>(segments));
  s.first = std::clamp(static_cast<int>(std::floor(xc)), 0, segments - 1);
  s.w = bspline_weights(xc - s.first);
  const bool held = x < 0.0 || x > static_cast<double>(segments);
  for (int m = 4; m < 12; ++m) {
    auto& w = s.w[static_cast<std::size_t>(m)];
    w = held ? 0.0 : w / (m < 8 ? spacing : spacing * spacing);
  }
  return s;
}

// What the cost functions read: the kinematics at the current time parameters.
struct Context {
  Eigen::MatrixXd value, rate;
  double dt = 0.0, kappa = 0.0;  // the time parameters the kinematics were evaluated at
  std::vector<double> base_s;    // per sample, (t_i - motion_start) s
  std::vector<double> rel_s;     // per sample, (t_i - t_ref) s
  Eigen::Matrix3d R0 = Eigen::Matrix3d::Identity();  // R_joint_sensor = R0 Exp(delta)
  std::vector<double> ell0;                          // nominal segment lengths
  double inv_sigma_a = 1.0, inv_sigma_g = 1.0;
  KinematicsEvaluator* eval = nullptr;
  // Segment correction: its axes and, per sample, where it falls on the spline.
  int dims = 0;
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  std::vector<SplineSpot> spot;

  void update(double new_dt, double new_kappa) {
    std::vector<double> tau(base_s.size());
    for (std::size_t i = 0; i < tau.size(); ++i) tau[i] = base_s[i] + new_dt + new_kappa * rel_s[i];
    eval->evaluate(tau, value, rate);
    dt = new_dt;
    kappa = new_kappa;
  }
};

// The measurement model in the parameters. The time parameters enter through the kinematics:
// K(tau + d) = K(tau) + K'(tau) d, exact in value (d = 0 at the evaluation point, which the
// evaluation callback guarantees) and the chain rule in the derivative.
template <typename T>
T time_shift(const Context& c, int i, const T* dt, const T* kappa) {
  return (dt[0] - c.dt) + (kappa[0] - c.kappa) * c.rel_s[static_cast<std::size_t>(i)];
}

template <typename T>
void kin(const Context& c, int i, int row, const T& shift, T out[3]) {
  for (int k = 0; k < 3; ++k) out[k] = c.value(row + k, i) + c.rate(row + k, i) * shift;
}

// v = R_joint_sensor^T u = Exp(-delta) R0^T u.
template <typename T>
void to_sensor(const Context& c, const T* delta, const T u[3], T v[3]) {
  T w[3];
  for (int r = 0; r < 3; ++r) w[r] = c.R0(0, r) * u[0] + c.R0(1, r) * u[1] + c.R0(2, r) * u[2];
  const T nd[3] = {-delta[0], -delta[1], -delta[2]};
  ceres::AngleAxisRotatePoint(nd, w, v);
}

// The sensor joint's specific force (origin), angular rate and angular acceleration in its frame.
template <typename T>
struct JointState {
  T f[3], w[3], al[3];
};

// The frame turns by Q = Exp(a e) (R_world_joint' = R_world_joint Q): vectors are re-expressed
// by Q^T; the turn's own body rate da e adds to the rate, and since d/dt (Q^T w) = Q^T dw -
// (da e) x (Q^T w), the angular acceleration becomes Q^T alpha - da e x (Q^T w) + dda e.
template <typename T>
void turn_frame(const Eigen::Vector3d& e, const T& a, const T& da, const T& dda, JointState<T>& s) {
  const T back[3] = {-a * e.x(), -a * e.y(), -a * e.z()};
  T f[3], w[3], al[3];
  ceres::AngleAxisRotatePoint(back, s.f, f);
  ceres::AngleAxisRotatePoint(back, s.w, w);
  ceres::AngleAxisRotatePoint(back, s.al, al);
  const T ew[3] = {e.y() * w[2] - e.z() * w[1], e.z() * w[0] - e.x() * w[2],
                   e.x() * w[1] - e.y() * w[0]};
  for (int k = 0; k < 3; ++k) {
    s.f[k] = f[k];
    s.w[k] = w[k] + da * e[k];
    s.al[k] = al[k] - da * ew[k] + dda * e[k];
  }
}

// The joint's kinematics at sample i as the IMU's clock sees them. The IMU clock is the true
// time: with tau = ... + (1 + kappa) t the motion's rates are d/dtau, so the true angular rate is
// (1 + kappa) w_J, the true angular and linear accelerations (1 + kappa)^2 times the motion's,
// while gravity's part of the specific force stays. Then the segment correction (ctrl: the
// sample's four control points, or null).
template <typename T>
void joint_state(const Context& c, int i, const T* dt, const T* kappa, const T* ell, int segments,
                 const T* const* ctrl, JointState<T>& s) {
  const T shift = time_shift(c, i, dt, kappa);
  const T sc = T(1.0) + kappa[0];
  const T sc2 = sc * sc;
  T f[3], g[3];
  kin(c, i, kF, shift, f);
  kin(c, i, kG, shift, g);
  kin(c, i, kW, shift, s.w);
  kin(c, i, kAlpha, shift, s.al);
  for (int q = 0; q < segments; ++q) {
    T S[3];
    kin(c, i, kS + 3 * q, shift, S);
    const T dl = ell[q] - c.ell0[static_cast<std::size_t>(q)];
    for (int k = 0; k < 3; ++k) f[k] += S[k] * dl;
  }
  for (int k = 0; k < 3; ++k) {
    s.f[k] = sc2 * (f[k] - g[k]) + g[k];
    s.w[k] = sc * s.w[k];
    s.al[k] = sc2 * s.al[k];
  }
  if (ctrl == nullptr) return;
  const SplineSpot& sp = c.spot[static_cast<std::size_t>(i)];
  // Q = Exp(a1 e1) Exp(a2 e2) Exp(a0 e0): the tilts first, the twist innermost, so that a
  // constant twist is exactly a turn of the placement about e0 (see the re-centring in identify).
  for (const int d : {1, 2, 0}) {
    if (d >= c.dims) continue;
    T a(0.0), da(0.0), dda(0.0);
    for (std::size_t m = 0; m < 4; ++m) {
      a += sp.w[m] * ctrl[m][d];
      da += sp.w[4 + m] * ctrl[m][d];
      dda += sp.w[8 + m] * ctrl[m][d];
    }
    turn_frame(c.axes.col(d), a, da, dda, s);
  }
}

template <typename T>
void gyro_model(const Context& c, int i, const T* rot, const T* bg, const T* sg, const T* dt,
                const T* kappa, const T* const* ctrl, T out[3]) {
  JointState<T> s;
  joint_state<T>(c, i, dt, kappa, nullptr, 0, ctrl, s);
  T v[3];
  to_sensor(c, rot, s.w, v);
  for (int k = 0; k < 3; ++k) out[k] = (T(1.0) + sg[k]) * v[k] + bg[k];
}

template <typename T>
void accel_model(const Context& c, int i, const T* rot, const T* pos, const T* ba, const T* sa,
                 const T* dt, const T* kappa, const T* ell, int segments, const T* const* ctrl,
                 T out[3]) {
  JointState<T> s;
  joint_state<T>(c, i, dt, kappa, ell, segments, ctrl, s);
  T axp[3], wxp[3], wwxp[3], a[3], v[3];
  ceres::CrossProduct(s.al, pos, axp);
  ceres::CrossProduct(s.w, pos, wxp);
  ceres::CrossProduct(s.w, wxp, wwxp);
  for (int k = 0; k < 3; ++k) a[k] = s.f[k] + axp[k] + wwxp[k];
  to_sensor(c, rot, a, v);
  for (int k = 0; k < 3; ++k) out[k] = (T(1.0) + sa[k]) * v[k] + ba[k];
}

struct GyroCost {
  const Context* c;
  int i;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(const T* rot, const T* bg, const T* sg, const T* dt, const T* kappa, T* r) const {
    T m[3];
    gyro_model<T>(*c, i, rot, bg, sg, dt, kappa, nullptr, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_g;
    return true;
  }
};

struct AccelCost {
  const Context* c;
  int i;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(const T* rot, const T* pos, const T* ba, const T* sa, const T* dt, const T* kappa,
                  T* r) const {
    T m[3];
    accel_model<T>(*c, i, rot, pos, ba, sa, dt, kappa, nullptr, 0, nullptr, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_a;
    return true;
  }
};

// With the segment correction (D angles per control point; the sample's four control points).
template <int D>
struct CorrectedGyroCost {
  const Context* c;
  int i;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(const T* rot, const T* bg, const T* sg, const T* dt, const T* kappa, const T* c0,
                  const T* c1, const T* c2, const T* c3, T* r) const {
    const T* ctrl[4] = {c0, c1, c2, c3};
    T m[3];
    gyro_model<T>(*c, i, rot, bg, sg, dt, kappa, ctrl, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_g;
    return true;
  }
};
template <int D>
struct CorrectedAccelCost {
  const Context* c;
  int i;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(const T* rot, const T* pos, const T* ba, const T* sa, const T* dt, const T* kappa,
                  const T* c0, const T* c1, const T* c2, const T* c3, T* r) const {
    const T* ctrl[4] = {c0, c1, c2, c3};
    T m[3];
    accel_model<T>(*c, i, rot, pos, ba, sa, dt, kappa, nullptr, 0, ctrl, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_a;
    return true;
  }
};

// With segment lengths and/or the segment correction (parameter blocks of run-time size):
// gyro: rot, bg, sg, dt, kappa[, four control points]; accelerometer: rot, pos, ba, sa, dt,
// kappa[, lengths][, four control points].
struct GeneralCost {
  const Context* c;
  int i;
  bool gyro;
  int segments;
  bool corrected;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(T const* const* p, T* r) const {
    T m[3];
    if (gyro) {
      gyro_model<T>(*c, i, p[0], p[1], p[2], p[3], p[4], corrected ? p + 5 : nullptr, m);
      for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_g;
    } else {
      const int next = segments > 0 ? 7 : 6;
      accel_model<T>(*c, i, p[0], p[1], p[2], p[3], p[4], p[5], segments > 0 ? p[6] : nullptr,
                     segments, corrected ? p + next : nullptr, m);
      for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_a;
    }
    return true;
  }
};

struct SegmentPrior {
  int s;
  int segments;
  double nominal, sigma;
  template <typename T>
  bool operator()(T const* const* p, T* r) const {
    r[0] = (p[0][s] - nominal) / sigma;
    return true;
  }
};

// A zero-mean Gaussian prior on a 3-vector (the biases).
struct VectorPrior {
  double inv_sigma;
  template <typename T>
  bool operator()(const T* b, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = b[k] * inv_sigma;
    return true;
  }
};

// Priors of the segment correction: each control point's angles (magnitude), each knot's
// angular acceleration (second difference of neighbouring control points / spacing^2).
template <int D>
struct CorrectionMagnitudePrior {
  std::array<double, 3> inv_sigma;
  template <typename T>
  bool operator()(const T* c, T* r) const {
    for (int d = 0; d < D; ++d) r[d] = c[d] * inv_sigma[static_cast<std::size_t>(d)];
    return true;
  }
};
template <int D>
struct CorrectionSmoothnessPrior {
  double inv;  // 1 / (spacing^2 sigma)
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    for (int d = 0; d < D; ++d) r[d] = (a[d] - 2.0 * b[d] + c[d]) * inv;
    return true;
  }
};

class TimeCallback : public ceres::EvaluationCallback {
 public:
  TimeCallback(Context& c, const double* dt, const double* kappa) : c_(c), dt_(dt), kappa_(kappa) {}
  void PrepareForEvaluation(bool /*jacobians*/, bool new_point) override {
    if (new_point && (*dt_ != c_.dt || *kappa_ != c_.kappa)) c_.update(*dt_, *kappa_);
  }

 private:
  Context& c_;
  const double* dt_;
  const double* kappa_;
};

double robust_sigma(std::vector<double> v) {
  if (v.empty()) return 1.0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return std::max(1.4826 * *mid, 1e-12);  // |r| values: MAD about the (zero) model
}

struct CoarseTiming {
  double offset_s = 0.0;  // at IMU time t_ref_s (s after motion_start)
  double clock_rate = 0.0;
  double t_ref_s = 0.0;
  double peak_r = -2.0;
};

// Coarse timing: Pearson correlation of |w| measured against |w| of the joint, both on a grid
// of the IMU's period, over lags within +-max_offset; parabolic refinement of the peak. With a
// clock-rate range above 1e-3 (streams aligned by duration) also over a grid of clock rates
// fine enough that the drift over half the recording stays within half an IMU period: motion
// time tau = t + lag + rate (t - t_ref), the simulated |w| interpolated linearly.
CoarseTiming coarse_timing(const Body& body, MotionSource& motion, const IdentifyOptions& o,
                           const ImuSeries& imu, double h, double center_s, double half_width_s) {
  const double rate = motion.rate_hz();
  const auto frames = *motion.frame_count();
  const double T = static_cast<double>(frames - 1) / rate;
  const double edge = 2.0 / rate;
  // Motion grid: motion time j h.
  std::vector<TimeNs> times;
  std::vector<int64_t> index;
  for (int64_t j = static_cast<int64_t>(std::ceil(edge / h)); j * h <= T - edge; ++j) {
    const TimeNs tn = std::llround(static_cast<double>(j) * h * 1e9);
    bool bad = false;
    for (const auto& [a, b] : o.invalid_motion) {
      if (tn >= a - from_seconds(3 / rate) && tn <= b + from_seconds(3 / rate)) bad = true;
    }
    if (!bad) {
      times.push_back(tn);
      index.push_back(j);
    }
  }
  if (times.size() < 10)
    throw Error("identify: the motion is too short for the time-offset search");
  const int64_t M = static_cast<int64_t>(std::ceil(T / h)) + 1;
  std::vector<double> sim(static_cast<std::size_t>(M), kNaN);
  {
    SensorSpec s;
    s.name = "rate";
    s.placement.joint = o.joint;
    s.outputs.accelerometer = false;
    SimulationOptions so;
    so.method = DerivativeMethod::spline;
    Simulator simulator(body, {s}, so);
    std::vector<SensorBlock> out;
    simulator.evaluate(motion, times, out);
    for (std::size_t k = 0; k < times.size(); ++k)
      sim[static_cast<std::size_t>(index[k])] =
          out[0].angular_rate.col(static_cast<Eigen::Index>(k)).norm();
  }
  // Measured grid: IMU time motion_start + j h, j from jm0; linear interpolation.
  const double t0 = to_seconds(imu.t.front() - o.motion_start_ns);
  const double t1 = to_seconds(imu.t.back() - o.motion_start_ns);
  const auto jm0 = static_cast<int64_t>(std::ceil(t0 / h));
  const auto jm1 = static_cast<int64_t>(std::floor(t1 / h));
  std::vector<double> meas(static_cast<std::size_t>(std::max<int64_t>(0, jm1 - jm0 + 1)), kNaN);
  std::size_t k = 0;
  for (int64_t j = jm0; j <= jm1; ++j) {
    const TimeNs tn = o.motion_start_ns + std::llround(static_cast<double>(j) * h * 1e9);
    while (k + 2 < imu.t.size() && imu.t[k + 1] <= tn) ++k;
    const double span = static_cast<double>(imu.t[k + 1] - imu.t[k]);
    const double u =
        span > 0 ? std::clamp(static_cast<double>(tn - imu.t[k]) / span, 0.0, 1.0) : 0.0;
    const auto ck = static_cast<Eigen::Index>(k);
    const Eigen::Vector3d g = (1 - u) * imu.gyro.col(ck) + u * imu.gyro.col(ck + 1);
    meas[static_cast<std::size_t>(j - jm0)] = g.norm();  // NaN propagates
  }
  CoarseTiming best;
  best.t_ref_s = 0.5 * static_cast<double>(jm0 + jm1) * h;
  // Clock rates to try: 0 only, unless the range is wide.
  std::vector<double> rates{0.0};
  if (o.clock_rate && o.max_clock_rate > 1e-3) {
    const double span = std::max(h, static_cast<double>(jm1 - jm0) * h);
    const int half = std::min((kMaxCoarseRates - 1) / 2,
                              static_cast<int>(std::ceil(o.max_clock_rate / (h / span))));
    rates.clear();
    for (int q = -half; q <= half; ++q) rates.push_back(o.max_clock_rate * q / half);
  }
  const auto L = static_cast<int64_t>(std::ceil(half_width_s / h));
  const int64_t C = std::llround(center_s / h);  // lags C - L .. C + L
  // Brute force over samples x lags x rates, with no progress to show: bounded before it starts
  // (10 minutes at 100 Hz searched +-3600 s at 401 rates is 1.7e13 products, days; found in
  // review, 2026-11-27). About 8 ns a product on this project's machines: 1e12 is a few hours.
  const double products = static_cast<double>(meas.size()) * static_cast<double>(2 * L + 1) *
                          static_cast<double>(rates.size());
  if (products > kMaxCoarseProducts) {
    throw Error(fmt::format(
        "identify: the time-offset search over +-{:g} s ({} lags) at {} clock rate(s) on {} "
        "samples would take {:.2g} products, more than the {:.0e} allowed (hours): give the "
        "offset (--time-offset) or the motion's start (--motion-start), or narrow "
        "--max-time-offset or --max-clock-rate",
        half_width_s, 2 * L + 1, rates.size(), meas.size(), products, kMaxCoarseProducts));
  }
  std::vector<double> r(static_cast<std::size_t>(2 * L + 1));
  std::vector<double> best_r;
  for (const double kappa : rates) {
    std::fill(r.begin(), r.end(), -2.0);
    for (int64_t lag = C - L; lag <= C + L; ++lag) {
      double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
      for (int64_t j = jm0; j <= jm1; ++j) {
        double y = kNaN;
        if (kappa == 0.0) {
          const int64_t js = j + lag;
          if (js < 0 || js >= M) continue;
          y = sim[static_cast<std::size_t>(js)];
        } else {
          const double x =
              static_cast<double>(j + lag) + kappa * (static_cast<double>(j) - best.t_ref_s / h);
          if (!(x >= 0.0) || x > static_cast<double>(M - 1)) continue;
          const auto js = static_cast<int64_t>(x);
          const double u = x - static_cast<double>(js);
          const double ya = sim[static_cast<std::size_t>(js)];
          y = u == 0.0 ? ya
                       : (1 - u) * ya + u * sim[static_cast<std::size_t>(std::min(js + 1, M - 1))];
        }
        const double xm = meas[static_cast<std::size_t>(j - jm0)];
        if (!std::isfinite(xm) || !std::isfinite(y)) continue;
        n += 1;
        sx += xm;
        sy += y;
        sxx += xm * xm;
        syy += y * y;
        sxy += xm * y;
      }
      if (n < 10) continue;
      const double vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
      if (vx > 0 && vy > 0)
        r[static_cast<std::size_t>(lag - C + L)] = (sxy - sx * sy / n) / std::sqrt(vx * vy);
    }
    const auto at = static_cast<int64_t>(std::max_element(r.begin(), r.end()) - r.begin());
    if (r[static_cast<std::size_t>(at)] <= best.peak_r) continue;
    double frac = 0.0;
    if (at > 0 && at < 2 * L) {
      const double a = r[static_cast<std::size_t>(at - 1)], b = r[static_cast<std::size_t>(at)],
                   c = r[static_cast<std::size_t>(at + 1)];
      const double den = a - 2 * b + c;
      if (den < 0) frac = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
    }
    best.peak_r = r[static_cast<std::size_t>(at)];
    best.offset_s = (static_cast<double>(at - L + C) + frac) * h;
    best.clock_rate = kappa;
  }
  if (best.peak_r < -1.0) {  // no lag had 10 samples of both (or any variation in them)
    throw Error(fmt::format(
        "identify: the IMU recording and the motion do not overlap by 10 samples at any time "
        "offset within {:g} +- {:g} s, or one of them does not move (a still recording leaves "
        "the offset unobservable); check the motion's start",
        center_s, half_width_s));
  }
  return best;
}

// Wahba's problem: R minimising sum w |u - R v|^2 (u in the joint frame, v in the sensor frame).
Eigen::Matrix3d wahba(const Eigen::Matrix3d& B) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

struct Params {
  std::array<double, 3> rot{}, pos{}, ba{}, bg{}, sa{}, sg{};
  double dt = 0.0, kappa = 0.0;
  std::vector<double> ell;
  std::vector<double> ctrl;  // control points of the correction, dims per knot
};

struct Predicted {
  Eigen::Matrix3Xd accel, gyro;
};

// correction: false gives the model without it (the "before" figures).
Predicted predict(const Context& c, const Params& p, bool correction = true) {
  const auto n = static_cast<Eigen::Index>(c.base_s.size());
  Predicted out{Eigen::Matrix3Xd(3, n), Eigen::Matrix3Xd(3, n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const int ii = static_cast<int>(i);
    const double* ctrl[4] = {nullptr, nullptr, nullptr, nullptr};
    const bool corrected = correction && c.dims > 0;
    if (corrected) {
      const int f = c.spot[static_cast<std::size_t>(i)].first;
      for (int m = 0; m < 4; ++m)
        ctrl[m] = p.ctrl.data() + static_cast<std::size_t>((f + m) * c.dims);
    }
    double a[3], g[3];
    accel_model(c, ii, p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt, &p.kappa,
                p.ell.data(), static_cast<int>(p.ell.size()), corrected ? ctrl : nullptr, a);
    gyro_model(c, ii, p.rot.data(), p.bg.data(), p.sg.data(), &p.dt, &p.kappa,
               corrected ? ctrl : nullptr, g);
    out.accel.col(i) = Eigen::Vector3d(a[0], a[1], a[2]);
    out.gyro.col(i) = Eigen::Vector3d(g[0], g[1], g[2]);
  }
  return out;
}

double rms(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return std::sqrt((a - b).squaredNorm() /
                   static_cast<double>(std::max<Eigen::Index>(1, a.size())));
}

AxisFidelity axis_fidelity(const Eigen::Matrix3Xd& measured, const Eigen::Matrix3Xd& simulated) {
  AxisFidelity f;
  const auto n = static_cast<double>(measured.cols());
  for (int k = 0; k < 3; ++k) {
    const Eigen::ArrayXd x = measured.row(k).transpose().array();
    const Eigen::ArrayXd y = simulated.row(k).transpose().array();
    f.rmse[k] = n > 0 ? std::sqrt((x - y).square().sum() / n) : kNaN;
    const Eigen::ArrayXd dx = x - x.mean(), dy = y - y.mean();
    const double den = std::sqrt(dx.square().sum() * dy.square().sum());
    f.correlation[k] = den > 0.0 ? (dx * dy).sum() / den : kNaN;
  }
  return f;
}

}  // namespace

std::string_view to_string(SegmentCorrection c) {
  switch (c) {
    case SegmentCorrection::none:
      return "none";
    case SegmentCorrection::twist:
      return "twist";
    case SegmentCorrection::rotation:
      return "rotation";
  }
  return "none";
}

SegmentCorrection parse_segment_correction(std::string_view name) {
  if (name == "none") return SegmentCorrection::none;
  if (name == "twist") return SegmentCorrection::twist;
  if (name == "rotation") return SegmentCorrection::rotation;
  throw Error(fmt::format("unknown segment correction '{}' (none, twist or rotation)", name));
}

TimeNs CorrectionSpline::t1_ns() const {
  const auto segments = static_cast<double>(std::max<Eigen::Index>(1, control.cols() - 3));
  return t0_ns + from_seconds(segments * knot_spacing_s);
}

namespace {
Eigen::Vector3d spline_row(const CorrectionSpline& c, TimeNs t, int derivative) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (c.dims == 0 || c.control.cols() < 4) return v;
  const SplineSpot s =
      spline_spot(c.t0_ns, c.knot_spacing_s, static_cast<int>(c.control.cols()) - 3, t);
  for (int d = 0; d < c.dims; ++d) {
    for (int m = 0; m < 4; ++m)
      v[d] += s.w[static_cast<std::size_t>(4 * derivative + m)] * c.control(d, s.first + m);
  }
  return v;
}
}  // namespace

Eigen::Vector3d CorrectionSpline::angles(TimeNs t) const { return spline_row(*this, t, 0); }
Eigen::Vector3d CorrectionSpline::rates(TimeNs t) const { return spline_row(*this, t, 1); }
Eigen::Vector3d CorrectionSpline::accelerations(TimeNs t) const { return spline_row(*this, t, 2); }

Eigen::Quaterniond CorrectionSpline::rotation(TimeNs t) const {
  const Eigen::Vector3d a = angles(t);
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (const int d : {1, 2, 0}) {
    if (d < dims) q = q * so3_exp(a[d] * axes.col(d));
  }
  return q.normalized();
}

Fidelity fidelity(const Eigen::Matrix3Xd& measured_accel, const Eigen::Matrix3Xd& measured_gyro,
                  const Eigen::Matrix3Xd& simulated_accel, const Eigen::Matrix3Xd& simulated_gyro) {
  if (measured_accel.cols() != simulated_accel.cols() ||
      measured_gyro.cols() != simulated_gyro.cols() ||
      measured_accel.cols() != measured_gyro.cols())
    throw Error("fidelity: measured and simulated signals differ in length");
  // Eigen's mean of no values asserts, which ends the process (found in review, from Python).
  if (measured_accel.cols() == 0) throw Error("fidelity: no samples");
  Fidelity f;
  f.accel = axis_fidelity(measured_accel, simulated_accel);
  f.gyro = axis_fidelity(measured_gyro, simulated_gyro);
  f.samples = measured_accel.cols();
  return f;
}

namespace {

int correction_dims(SegmentCorrection c) {
  return c == SegmentCorrection::none ? 0 : c == SegmentCorrection::twist ? 1 : 3;
}

// The sensor's chain must be finite everywhere (else the kinematics would be NaN somewhere in the
// middle of the fit): read it in chunks and name the first bad frame.
void require_finite_chain(const Body& body, MotionSource& motion, const std::vector<int>& chain) {
  const int64_t frames = *motion.frame_count();
  MotionChunk chunk;
  constexpr int64_t kChunk = 4096;
  for (int64_t f0 = 0; f0 < frames; f0 += kChunk) {
    const int64_t count = std::min(kChunk, frames - f0);
    motion.read(f0, count, chain, chunk);
    for (int64_t f = 0; f < count; ++f) {
      if (!chunk.root_translation.col(f).allFinite())
        throw Error(fmt::format("identify: the motion's root translation at frame {} is not finite",
                                f0 + f));
      for (std::size_t k = 0; k < chain.size(); ++k) {
        if (!chunk.rotation(f, k).coeffs().allFinite())
          throw Error(
              fmt::format("identify: the motion's rotation of joint '{}' at frame {} is non-finite",
                          body.joint(static_cast<std::size_t>(chain[k])).name, f0 + f));
      }
    }
  }
}

// The arguments' checks, in the order of their messages. Returns the nominal lengths of the
// segments to identify.
std::vector<double> check_inputs(const Body& body, MotionSource& motion, const ImuSeries& imu,
                                 const IdentifyOptions& o) {
  require_simulatable(motion, "identify");
  if (!motion.frame_count()) throw Error("identify: the motion must have a finite length");
  if (o.joint < 0 || static_cast<std::size_t>(o.joint) >= body.size())
    throw Error("identify: no joint chosen (or index out of range)");
  if (!imu.has_accel() || !imu.has_gyro())
    throw Error("identify: the IMU recording needs accelerometer and gyroscope channels");
  if (imu.size() < 50) throw Error("identify: the IMU recording has fewer than 50 samples");
  imu.validate();
  if (o.segments.size() > static_cast<std::size_t>(kMaxSegments))
    throw Error(fmt::format("identify: at most {} segment lengths", kMaxSegments));
  const std::vector<int> chain = body.chain(o.joint);
  std::vector<double> ell0;
  for (std::size_t k = 0; k < o.segments.size(); ++k) {
    const int s = o.segments[k];
    // The same joint twice gave two parameters of one sensitivity, each half the change (found
    // in review, 2026-11-27).
    if (std::find(o.segments.begin(), o.segments.begin() + static_cast<std::ptrdiff_t>(k), s) !=
        o.segments.begin() + static_cast<std::ptrdiff_t>(k)) {
      throw Error(fmt::format("identify: segment joint '{}' is listed twice",
                              body.joint(static_cast<std::size_t>(s)).name));
    }
    if (std::find(chain.begin() + 1, chain.end(), s) == chain.end())
      throw Error(
          fmt::format("identify: segment joint '{}' is not on the sensor's chain below the root",
                      s >= 0 && static_cast<std::size_t>(s) < body.size()
                          ? body.joint(static_cast<std::size_t>(s)).name
                          : "?"));
    const double l = body.joint(static_cast<std::size_t>(s)).offset_parent_joint.norm();
    if (!(l > 1e-6)) throw Error("identify: a segment to identify has zero length");
    ell0.push_back(l);
  }
  if (!(o.huber_sigmas > 0) || !(o.max_time_offset_s >= 0) || !(o.segment_prior > 0))
    throw Error(
        "identify: huber_sigmas, segment_prior must be positive, max_time_offset_s non-negative");
  // Offsets become ns (int64): beyond a day they are not an offset but a wrong clock.
  if (!(o.given_offset_search_s >= 0.0 && o.given_offset_search_s <= 86400.0))
    throw Error("identify: given_offset_search_s must be from 0 to 86400 s");
  if (!(std::abs(o.time_offset_init_s) <= 86400.0) || !(o.max_time_offset_s <= 86400.0))
    throw Error("identify: time offsets must be finite and within a day (86400 s)");
  if (!(o.accel_bias_prior_mps2 >= 0) || !(o.gyro_bias_prior_radps >= 0))
    throw Error("identify: the bias priors must be non-negative (0: none)");
  if (!(o.function_tolerance > 0 && o.function_tolerance < 1))
    throw Error(fmt::format("identify: function_tolerance must be in (0, 1), got {}",
                            o.function_tolerance));
  if (!(o.max_clock_rate >= 0 && o.max_clock_rate <= 0.5))
    throw Error(
        fmt::format("identify: max_clock_rate must be in [0, 0.5], got {}", o.max_clock_rate));
  // Bounds of zero width made Ceres refuse the problem at once, and the start was reported as
  // the fit (found in review, 2026-11-27).
  if (o.clock_rate && o.max_clock_rate == 0.0)
    throw Error(
        "identify: the clock rate is estimated within +-0: hold it fixed instead (no "
        "clock_rate), or give max_clock_rate > 0");
  // A NaN start reached the solver, and the observability analysis aborted the process (found
  // in review, 2026-11-27).
  if (!o.init.p_joint_sensor.allFinite() || !o.init.q_joint_sensor.coeffs().allFinite() ||
      !(o.init.q_joint_sensor.norm() > 1e-9))
    throw Error(
        "identify: the initial placement must be finite (position and a non-zero "
        "quaternion)");
  if (correction_dims(o.correction) > 0) {
    // The command's floor for every caller: 1e-4 s asked Python for 19,000 knots on 2 s
    // (bad_alloc; found in review, 2026-11-27).
    if (!(o.correction_knot_spacing_s >= kMinKnotSpacing_s &&
          std::isfinite(o.correction_knot_spacing_s)))
      throw Error(
          fmt::format("identify: the correction's knot spacing must be at least {} s, got {}",
                      kMinKnotSpacing_s, o.correction_knot_spacing_s));
    if (!(o.twist_prior_rad > 0) || !(o.tilt_prior_rad > 0) ||
        !(o.correction_smoothness_radps2 > 0))
      throw Error("identify: the correction's knot spacing and priors must be positive and finite");
    if (body.segment_end(o.joint).norm() < 1e-6) {
      throw Error(fmt::format(
          "identify: joint '{}' has no segment (no child or end site): no long axis to correct "
          "the twist about",
          body.joint(static_cast<std::size_t>(o.joint)).name));
    }
  }
  if (*motion.frame_count() < 8) throw Error("identify: the motion needs at least 8 frames");
  require_finite_chain(body, motion, chain);
  return ell0;
}

// The coarse timing: the |w| cross-correlation's when the offset is searched, else the given
// offset at clock rate 0.
CoarseTiming initial_timing(const Body& body, MotionSource& motion, const ImuSeries& imu,
                            const IdentifyOptions& o, double h_imu) {
  CoarseTiming coarse;
  coarse.offset_s = o.time_offset_init_s;
  if (o.time_offset && !o.coarse_time_offset && o.given_offset_search_s > 0.0) {
    // A given start is searched around too: on motion-capture jitter the fine fit's cost has
    // minima about a frame apart, and a start 10 ms off stopped in one of them, "converged"
    // (0.033 s for 0.0417, gyro rms 0.22 rad/s against 0.003; review, 2026-11-27). Where
    // nothing correlates near it, the start stays as given.
    try {
      const CoarseTiming near =
          coarse_timing(body, motion, o, imu, h_imu, o.time_offset_init_s, o.given_offset_search_s);
      if (near.peak_r >= 0.3) coarse = near;
    } catch (const Error&) {
      // Too little overlap to correlate near the start: the fine fit starts there, as asked.
    }
  } else if (o.time_offset && o.coarse_time_offset) {
    coarse = coarse_timing(body, motion, o, imu, h_imu, 0.0, o.max_time_offset_s);
    if (coarse.peak_r < 0.3) {
      throw Error(fmt::format(
          "identify: the time offset is unobservable: measured and simulated angular-rate "
          "magnitudes do "
          "not correlate within +-{} s (best r = {:.2f}); give the offset and hold it fixed",
          o.max_time_offset_s, coarse.peak_r));
    }
  }
  return coarse;
}

struct ClockRange {
  double lo = 0.0, hi = 0.0;
};

// The range the fine fit may move the clock rate in: around the coarse grid's value (two grid
// steps) when it searched, else the whole bound.
ClockRange clock_rate_range(const IdentifyOptions& o, const ImuSeries& imu, double kappa0,
                            double h_imu) {
  ClockRange r;
  if (o.clock_rate) {
    const bool searched = o.time_offset && o.coarse_time_offset && o.max_clock_rate > 1e-3;
    const double span = to_seconds(imu.t.back() - imu.t.front());
    const double step = searched ? std::max(2.0 * o.max_clock_rate / (kMaxCoarseRates - 1),
                                            h_imu / std::max(span, h_imu))
                                 : o.max_clock_rate;
    r.lo = std::max(-o.max_clock_rate, kappa0 - 2.0 * step);
    r.hi = std::min(o.max_clock_rate, kappa0 + 2.0 * step);
  }
  return r;
}

// The motion times a sample may be read at: the fit's range of offsets and clock rates. Only
// the fit's range selects samples: it also took offset 0 and rate 0 (for the "before" figures),
// which refused a given offset larger than the motion's slack and dropped 22 % of the samples
// of an ordinary one (found in review, 2026-11-27); the "before" figures now use the samples
// inside the motion at offset 0 (inside()).
struct Reach {
  double window = 0.0;  // the fit moves the offset within +-window of the coarse one, s
  double edge = 0.0;    // a sample's reach keeps this far from the motion's ends, s
  double T = 0.0;       // the motion's length, s
  ClockRange kappa;
  void operator()(double b, double rel, double dt_c, double& lo, double& hi) const {
    lo = b + dt_c - window + std::min(kappa.lo * rel, kappa.hi * rel);
    hi = b + dt_c + window + std::max(kappa.lo * rel, kappa.hi * rel);
  }
  bool inside(double lo, double hi) const { return lo >= edge && hi <= T - edge; }
};

// The first pass: with the coarse offset (referred to the coarse step's reference time), the
// span of the samples inside the motion; its middle becomes t_ref.
TimeNs reference_time(const ImuSeries& imu, const IdentifyOptions& o, const CoarseTiming& coarse,
                      const Reach& reach) {
  TimeNs first = 0, last = 0;
  bool any = false;
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const double b = to_seconds(imu.t[i] - o.motion_start_ns);
    double lo = 0, hi = 0;
    reach(b, b - coarse.t_ref_s, coarse.offset_s, lo, hi);
    if (reach.inside(lo, hi)) {
      if (!any) first = imu.t[i];
      last = imu.t[i];
      any = true;
    }
  }
  if (!any) {
    // With the spans and the offset, so that a wrong --motion-start or offset shows (found in
    // review, 2026-11-27: the message named nothing).
    throw Error(fmt::format(
        "identify: no IMU sample lies inside the motion: the IMU spans {:.3f} to {:.3f} s from "
        "motion frame 0's time, and at the time offset {:+.3f} s it reads the motion's {:.3f} s "
        "from {:.3f} to {:.3f} s (give the motion's start or the offset)",
        to_seconds(imu.t.front() - o.motion_start_ns), to_seconds(imu.t.back() - o.motion_start_ns),
        coarse.offset_s, reach.T, to_seconds(imu.t.front() - o.motion_start_ns) + coarse.offset_s,
        to_seconds(imu.t.back() - o.motion_start_ns) + coarse.offset_s));
  }
  return first + (last - first) / 2;
}

// The second pass: the finite samples whose reach (from the coarse offset dt0 at t_ref) stays
// inside the motion and clear of the invalid intervals. Their times from motion_start and from
// t_ref go to the context.
std::vector<std::size_t> select_samples(const ImuSeries& imu, const IdentifyOptions& o,
                                        const Reach& reach, TimeNs t_ref_ns, double dt0,
                                        double mrate, Context& ctx) {
  std::vector<std::size_t> used;
  const TimeNs guard = from_seconds(3.0 / mrate);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const double b = to_seconds(imu.t[i] - o.motion_start_ns);
    const double rel = to_seconds(imu.t[i] - t_ref_ns);
    double lo = 0, hi = 0;
    reach(b, rel, dt0, lo, hi);
    bool ok = reach.inside(lo, hi) && imu.accel.col(static_cast<Eigen::Index>(i)).allFinite() &&
              imu.gyro.col(static_cast<Eigen::Index>(i)).allFinite();
    for (const auto& [ga, gb] : o.invalid_motion) {
      if (ok && from_seconds(hi) >= ga - guard && from_seconds(lo) <= gb + guard) ok = false;
    }
    if (ok) {
      used.push_back(i);
      ctx.base_s.push_back(b);
      ctx.rel_s.push_back(rel);
    }
  }
  return used;
}

// The samples used into the result (times and measurements), with their counts and a warning
// naming the non-finite ones.
void take_samples(const ImuSeries& imu, const std::vector<std::size_t>& used, IdentifyResult& res) {
  res.samples_used = static_cast<int64_t>(used.size());
  res.samples_excluded = static_cast<int64_t>(imu.size() - used.size());
  {
    int64_t nonfinite = 0;
    for (std::size_t i = 0; i < imu.size(); ++i) {
      nonfinite += imu.accel.col(static_cast<Eigen::Index>(i)).allFinite() &&
                           imu.gyro.col(static_cast<Eigen::Index>(i)).allFinite()
                       ? 0
                       : 1;
    }
    if (nonfinite > 0) {
      res.warnings.push_back(fmt::format(
          "{} IMU samples have non-finite values and are left out of the fit", nonfinite));
    }
  }
  if (used.size() < 50) {
    throw Error(
        fmt::format("identify: only {} IMU samples fall inside the motion (outside gaps); need 50",
                    used.size()));
  }
  const auto n = static_cast<Eigen::Index>(used.size());
  res.t.resize(used.size());
  res.accel.resize(3, n);
  res.gyro.resize(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto src = static_cast<Eigen::Index>(used[static_cast<std::size_t>(i)]);
    res.t[static_cast<std::size_t>(i)] = imu.t[static_cast<std::size_t>(src)];
    res.accel.col(i) = imu.accel.col(src);
    res.gyro.col(i) = imu.gyro.col(src);
  }
}

// The segment correction's spline over the whole recording (so the fitted motion has it
// everywhere), knots as close to the asked spacing as divide the span evenly: the result's
// spline (control points zero), each sample's spot on it, the control points to fit. Returns
// the number of knots (0: no correction).
int correction_grid(const Body& body, const ImuSeries& imu, const IdentifyOptions& o, int dims,
                    Context& ctx, Params& p, IdentifyResult& res) {
  if (dims == 0) return 0;
  CorrectionSpline& cs = res.correction;
  cs.dims = dims;
  const Eigen::Matrix3d F = anatomical_frame(body, o.joint);  // L, A, N
  cs.axes = F;
  cs.t0_ns = imu.t.front();
  const double span = to_seconds(imu.t.back() - imu.t.front());
  const int segments =
      std::max(1, static_cast<int>(std::lround(span / o.correction_knot_spacing_s)));
  cs.knot_spacing_s = span / segments;
  const int knots = segments + 3;
  cs.control = Eigen::MatrixXd::Zero(dims, knots);
  ctx.dims = dims;
  ctx.axes = F;
  for (std::size_t i = 0; i < res.t.size(); ++i)
    ctx.spot.push_back(spline_spot(cs.t0_ns, cs.knot_spacing_s, segments, res.t[i]));
  p.ctrl.assign(static_cast<std::size_t>(dims * knots), 0.0);
  return knots;
}

// Gyro vectors dominate when the motion rotates; gravity (in f) settles the rest.
Eigen::Matrix3d wahba_rotation(const Context& ctx, const IdentifyResult& res) {
  Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < res.gyro.cols(); ++i) {
    B += ctx.value.block<3, 1>(kW, i) * res.gyro.col(i).transpose();
    B += 0.01 * ctx.value.block<3, 1>(kF, i) * res.accel.col(i).transpose();
  }
  return wahba(B);
}

// Columns `keep` of m.
Eigen::Matrix3Xd columns(const Eigen::Matrix3Xd& m, const std::vector<Eigen::Index>& keep) {
  Eigen::Matrix3Xd out(3, static_cast<Eigen::Index>(keep.size()));
  for (std::size_t k = 0; k < keep.size(); ++k)
    out.col(static_cast<Eigen::Index>(k)) = m.col(keep[k]);
  return out;
}

// Before: the initial position, no bias, no time offset or rate, no correction; the rotation
// the initial one or, from data, Wahba's at offset 0 (the "before" figures), over the samples
// used that lie inside the motion at offset 0 (the others' columns NaN; with none, NaN
// figures). Then the fit's start: the coarse timing (dt0 at t_ref, kappa0), with Wahba's
// rotation there.
void initial_values(const IdentifyOptions& o, const std::vector<double>& ell0, double dt0,
                    double kappa0, const Reach& reach, Context& ctx, Params& p,
                    IdentifyResult& res) {
  p.pos = {o.init.p_joint_sensor.x(), o.init.p_joint_sensor.y(), o.init.p_joint_sensor.z()};
  p.ell = ell0;
  ctx.R0 = o.init.q_joint_sensor.normalized().toRotationMatrix();
  const bool rotation_from_data = o.rotation && o.init_rotation_from_data;
  {
    Context before = ctx;
    before.base_s.clear();
    before.rel_s.clear();
    std::vector<Eigen::Index> inside;
    for (std::size_t i = 0; i < ctx.base_s.size(); ++i) {
      if (!reach.inside(ctx.base_s[i], ctx.base_s[i])) continue;
      inside.push_back(static_cast<Eigen::Index>(i));
      before.base_s.push_back(ctx.base_s[i]);
      before.rel_s.push_back(ctx.rel_s[i]);
    }
    const auto n = static_cast<Eigen::Index>(ctx.base_s.size());
    res.accel_before.setConstant(3, n, kNaN);
    res.gyro_before.setConstant(3, n, kNaN);
    res.rms_before = {kNaN, kNaN};
    if (!inside.empty()) {
      IdentifyResult measured;
      measured.accel = columns(res.accel, inside);
      measured.gyro = columns(res.gyro, inside);
      before.update(0.0, 0.0);
      if (rotation_from_data) ctx.R0 = before.R0 = wahba_rotation(before, measured);
      const Predicted b = predict(before, p, false);
      for (std::size_t k = 0; k < inside.size(); ++k) {
        res.accel_before.col(inside[k]) = b.accel.col(static_cast<Eigen::Index>(k));
        res.gyro_before.col(inside[k]) = b.gyro.col(static_cast<Eigen::Index>(k));
      }
      res.rms_before = {rms(b.accel, measured.accel), rms(b.gyro, measured.gyro)};
      res.fidelity_before = fidelity(measured.accel, measured.gyro, b.accel, b.gyro);
    } else {
      for (AxisFidelity* f : {&res.fidelity_before.accel, &res.fidelity_before.gyro}) {
        f->rmse.setConstant(kNaN);
        f->correlation.setConstant(kNaN);
      }
      res.fidelity_before.samples = 0;
    }
  }

  p.dt = dt0;
  p.kappa = kappa0;
  ctx.update(dt0, kappa0);
  if (rotation_from_data) ctx.R0 = wahba_rotation(ctx, res);
}

// A parameter block: the sensor's (reported), segment lengths, the correction's control points
// (not reported one by one).
struct Block {
  double* data;
  int size;
  bool free;
  std::string name, unit;
  bool reported;
};

std::vector<Block> parameter_blocks(Params& p, const IdentifyOptions& o, int knots, int dims) {
  const int S = static_cast<int>(o.segments.size());
  std::vector<Block> blocks = {{p.rot.data(), 3, o.rotation, "rotation", "rad", true},
                               {p.pos.data(), 3, o.position, "position", "m", true},
                               {p.ba.data(), 3, o.accel_bias, "accel_bias", "m/s^2", true},
                               {p.bg.data(), 3, o.gyro_bias, "gyro_bias", "rad/s", true},
                               {p.sa.data(), 3, o.accel_scale, "accel_scale", "1", true},
                               {p.sg.data(), 3, o.gyro_scale, "gyro_scale", "1", true},
                               {&p.dt, 1, o.time_offset, "time_offset", "s", true},
                               {&p.kappa, 1, o.clock_rate, "clock_rate", "1", true}};
  if (S > 0) blocks.push_back({p.ell.data(), S, true, "segment_length", "m", true});
  for (int k = 0; k < knots; ++k)
    blocks.push_back({p.ctrl.data() + static_cast<std::size_t>(k * dims), dims, true, "correction",
                      "rad", false});
  return blocks;
}

// Sample i's gyro and accelerometer residual blocks with the correction (S segment lengths,
// dims angles per control point): fixed-size cost functions without lengths, else dynamic ones.
void add_corrected_sample(ceres::Problem& problem, const Context& ctx, Params& p,
                          const IdentifyResult& res, Eigen::Index i, int S, int dims,
                          double huber) {
  const int ii = static_cast<int>(i);
  // The sample's four control points.
  const int f0 = ctx.spot[static_cast<std::size_t>(i)].first;
  std::vector<double*> ctrl;
  for (int m = 0; m < 4; ++m)
    ctrl.push_back(p.ctrl.data() + static_cast<std::size_t>((f0 + m) * dims));
  const Eigen::Vector3d g = res.gyro.col(i), a = res.accel.col(i);
  if (S == 0 && dims == 1) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<CorrectedGyroCost<1>, 3, 3, 3, 3, 1, 1, 1, 1, 1, 1>(
            new CorrectedGyroCost<1>{&ctx, ii, g}),
        new ceres::HuberLoss(huber), p.rot.data(), p.bg.data(), p.sg.data(), &p.dt, &p.kappa,
        ctrl[0], ctrl[1], ctrl[2], ctrl[3]);
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<CorrectedAccelCost<1>, 3, 3, 3, 3, 3, 1, 1, 1, 1, 1, 1>(
            new CorrectedAccelCost<1>{&ctx, ii, a}),
        new ceres::HuberLoss(huber), p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt,
        &p.kappa, ctrl[0], ctrl[1], ctrl[2], ctrl[3]);
    return;
  }
  if (S == 0 && dims == 3) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<CorrectedGyroCost<3>, 3, 3, 3, 3, 1, 1, 3, 3, 3, 3>(
            new CorrectedGyroCost<3>{&ctx, ii, g}),
        new ceres::HuberLoss(huber), p.rot.data(), p.bg.data(), p.sg.data(), &p.dt, &p.kappa,
        ctrl[0], ctrl[1], ctrl[2], ctrl[3]);
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<CorrectedAccelCost<3>, 3, 3, 3, 3, 3, 1, 1, 3, 3, 3, 3>(
            new CorrectedAccelCost<3>{&ctx, ii, a}),
        new ceres::HuberLoss(huber), p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt,
        &p.kappa, ctrl[0], ctrl[1], ctrl[2], ctrl[3]);
    return;
  }
  for (const bool gyro : {true, false}) {
    auto* cf = new ceres::DynamicAutoDiffCostFunction<GeneralCost, 8>(new GeneralCost{
        &ctx, ii, gyro, gyro ? 0 : S, true, gyro ? res.gyro.col(i) : res.accel.col(i)});
    std::vector<double*> ps =
        gyro ? std::vector<double*>{p.rot.data(), p.bg.data(), p.sg.data(), &p.dt, &p.kappa}
             : std::vector<double*>{p.rot.data(), p.pos.data(), p.ba.data(),
                                    p.sa.data(),  &p.dt,        &p.kappa};
    for (int b : gyro ? std::vector<int>{3, 3, 3, 1, 1} : std::vector<int>{3, 3, 3, 3, 1, 1})
      cf->AddParameterBlock(b);
    if (!gyro && S > 0) {
      cf->AddParameterBlock(S);
      ps.push_back(p.ell.data());
    }
    for (double* c : ctrl) {
      cf->AddParameterBlock(dims);
      ps.push_back(c);
    }
    cf->SetNumResiduals(3);
    problem.AddResidualBlock(cf, new ceres::HuberLoss(huber), ps);
  }
}

// Sample i's gyro and accelerometer residual blocks without the correction (S segment lengths).
void add_rigid_sample(ceres::Problem& problem, const Context& ctx, Params& p,
                      const IdentifyResult& res, Eigen::Index i, int S, double huber) {
  const int ii = static_cast<int>(i);
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<GyroCost, 3, 3, 3, 3, 1, 1>(
                               new GyroCost{&ctx, ii, res.gyro.col(i)}),
                           new ceres::HuberLoss(huber), p.rot.data(), p.bg.data(), p.sg.data(),
                           &p.dt, &p.kappa);
  if (S == 0) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AccelCost, 3, 3, 3, 3, 3, 1, 1>(
                                 new AccelCost{&ctx, ii, res.accel.col(i)}),
                             new ceres::HuberLoss(huber), p.rot.data(), p.pos.data(), p.ba.data(),
                             p.sa.data(), &p.dt, &p.kappa);
  } else {
    auto* cf = new ceres::DynamicAutoDiffCostFunction<GeneralCost, 8>(
        new GeneralCost{&ctx, ii, false, S, false, res.accel.col(i)});
    for (int b : {3, 3, 3, 3, 1, 1}) cf->AddParameterBlock(b);
    cf->AddParameterBlock(S);
    cf->SetNumResiduals(3);
    problem.AddResidualBlock(
        cf, new ceres::HuberLoss(huber),
        {p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt, &p.kappa, p.ell.data()});
  }
}

// Problem: one gyro and one accelerometer residual block per sample.
void add_sample_residuals(ceres::Problem& problem, const Context& ctx, Params& p,
                          const IdentifyResult& res, const IdentifyOptions& o, int dims) {
  const int S = static_cast<int>(o.segments.size());
  const double huber = o.huber_sigmas * std::sqrt(3.0);
  for (Eigen::Index i = 0; i < res.gyro.cols(); ++i) {
    if (dims > 0)
      add_corrected_sample(problem, ctx, p, res, i, S, dims, huber);
    else
      add_rigid_sample(problem, ctx, p, res, i, S, huber);
  }
}

// The segment lengths' priors about their nominal values, the biases' about zero.
void add_priors(ceres::Problem& problem, const IdentifyOptions& o, const std::vector<double>& ell0,
                Params& p) {
  const int S = static_cast<int>(o.segments.size());
  for (int s = 0; s < S; ++s) {
    auto* cf = new ceres::DynamicAutoDiffCostFunction<SegmentPrior, 8>(
        new SegmentPrior{s, S, ell0[static_cast<std::size_t>(s)],
                         o.segment_prior * ell0[static_cast<std::size_t>(s)]});
    cf->AddParameterBlock(S);
    cf->SetNumResiduals(1);
    problem.AddResidualBlock(cf, nullptr, std::vector<double*>{p.ell.data()});
  }
  for (const auto& [sigma, block] : {std::pair{o.accel_bias_prior_mps2, p.ba.data()},
                                     std::pair{o.gyro_bias_prior_radps, p.bg.data()}}) {
    if (sigma > 0.0) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<VectorPrior, 3, 3>(new VectorPrior{1.0 / sigma}), nullptr,
          block);
    }
  }
}

// The correction's priors: each control point's magnitude, each inner knot's smoothness.
void add_correction_priors(ceres::Problem& problem, const IdentifyOptions& o, Params& p, int knots,
                           int dims, double knot_spacing_s) {
  const std::array<double, 3> inv_mag = {1.0 / o.twist_prior_rad, 1.0 / o.tilt_prior_rad,
                                         1.0 / o.tilt_prior_rad};
  const double h2 = knot_spacing_s * knot_spacing_s;
  const double inv_smooth = 1.0 / (h2 * o.correction_smoothness_radps2);
  auto point = [&](int k) { return p.ctrl.data() + static_cast<std::size_t>(k * dims); };
  for (int k = 0; k < knots; ++k) {
    if (dims == 1)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CorrectionMagnitudePrior<1>, 1, 1>(
                                   new CorrectionMagnitudePrior<1>{inv_mag}),
                               nullptr, point(k));
    else
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CorrectionMagnitudePrior<3>, 3, 3>(
                                   new CorrectionMagnitudePrior<3>{inv_mag}),
                               nullptr, point(k));
    if (k == 0 || k + 1 == knots) continue;
    if (dims == 1)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<CorrectionSmoothnessPrior<1>, 1, 1, 1, 1>(
              new CorrectionSmoothnessPrior<1>{inv_smooth}),
          nullptr, point(k - 1), point(k), point(k + 1));
    else
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<CorrectionSmoothnessPrior<3>, 3, 3, 3, 3>(
              new CorrectionSmoothnessPrior<3>{inv_smooth}),
          nullptr, point(k - 1), point(k), point(k + 1));
  }
}

// The held blocks, and the bounds of the time offset (+-window about dt0) and the clock rate.
void constrain(ceres::Problem& problem, const std::vector<Block>& blocks, const IdentifyOptions& o,
               Params& p, double dt0, double window, const ClockRange& kappa) {
  for (const Block& b : blocks) {
    if (!b.free) problem.SetParameterBlockConstant(b.data);
  }
  if (o.time_offset) {
    problem.SetParameterLowerBound(&p.dt, 0, dt0 - window);
    problem.SetParameterUpperBound(&p.dt, 0, dt0 + window);
  }
  if (o.clock_rate) {
    problem.SetParameterLowerBound(&p.kappa, 0, kappa.lo);
    problem.SetParameterUpperBound(&p.kappa, 0, kappa.hi);
  }
}

// Residual scale from the current residuals (robust), so the Huber threshold means sigmas.
void reweight(Context& ctx, const Params& p, IdentifyResult& res) {
  const Eigen::Index n = res.accel.cols();
  ctx.update(p.dt, p.kappa);
  const Predicted m = predict(ctx, p);
  std::vector<double> ra, rg;
  ra.reserve(static_cast<std::size_t>(3 * n));
  rg.reserve(static_cast<std::size_t>(3 * n));
  for (Eigen::Index i = 0; i < 3 * n; ++i) {
    ra.push_back(std::abs(m.accel.data()[i] - res.accel.data()[i]));
    rg.push_back(std::abs(m.gyro.data()[i] - res.gyro.data()[i]));
  }
  res.sigma_accel = robust_sigma(std::move(ra));
  res.sigma_gyro = robust_sigma(std::move(rg));
  ctx.inv_sigma_a = 1.0 / res.sigma_accel;
  ctx.inv_sigma_g = 1.0 / res.sigma_gyro;
}

// Two solves, each after reweighting the residuals (p is what the problem's blocks point into).
void solve_robust(ceres::Problem& problem, Context& ctx, Params& p, const IdentifyOptions& o,
                  IdentifyResult& res) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = std::max(1, o.threads);
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  for (int stage = 0; stage < 2; ++stage) {
    reweight(ctx, p, res);
    ceres::Solve(so, &problem, &summary);
    // A solve Ceres refused or that failed gave the start as the "fit", exit 0 (found in
    // review, 2026-11-27).
    if (summary.termination_type == ceres::FAILURE ||
        summary.termination_type == ceres::USER_FAILURE)
      throw Error("identify: the solver failed: " + summary.message);
    // iterations[0] is the initial evaluation; a solve that fails at once has none at all.
    res.iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  }
  res.converged = summary.termination_type == ceres::CONVERGENCE;
  res.solver_summary = summary.BriefReport();
}

// A constant twist and a turn of the placement about the long axis e0 give the same signals
// (the twist is the innermost factor of Q); the weak prior alone splits them arbitrarily.
// Re-centre: the correction's twist averages zero over the samples used, its mean moves into
// the placement (R_joint_sensor and p_joint_sensor turned about e0).
void recentre_twist(Context& ctx, Params& p, int knots, int dims) {
  double mean = 0.0;
  for (const SplineSpot& sp : ctx.spot) {
    for (std::size_t m = 0; m < 4; ++m)
      mean += sp.w[m] * p.ctrl[static_cast<std::size_t>((sp.first + static_cast<int>(m)) * dims)];
  }
  mean /= static_cast<double>(ctx.spot.size());
  for (int k = 0; k < knots; ++k) p.ctrl[static_cast<std::size_t>(k * dims)] -= mean;
  const Eigen::Matrix3d turn = so3_exp(mean * ctx.axes.col(0)).toRotationMatrix();
  ctx.R0 = turn * ctx.R0;  // R_joint_sensor = R0 Exp(delta): delta is kept
  const Eigen::Vector3d pos = turn * Eigen::Vector3d(p.pos[0], p.pos[1], p.pos[2]);
  p.pos = {pos.x(), pos.y(), pos.z()};
}

// The convention recentre_twist reports in, mean twist = 0, as a stiff linear residual
// W sum_k a_k c_k[0] over the control points, added for the covariance only (it is 0 at the
// recentred point). A constant twist and a turn of the placement about the long axis give the
// same signals; without the convention only the twist's magnitude prior told them apart, so the
// rotation's and the position's standard errors were the prior's, twist_prior / sqrt(knots):
// +-0.50 rad for a rotation known to 1e-4 (review, 2026-11-27).
class MeanTwistConvention : public ceres::CostFunction {
 public:
  MeanTwistConvention(std::vector<double> a, int dims) : a_(std::move(a)) {
    for (std::size_t k = 0; k < a_.size(); ++k) mutable_parameter_block_sizes()->push_back(dims);
    set_num_residuals(1);
  }
  bool Evaluate(double const* const* c, double* r, double** jacobians) const override {
    const int dims = parameter_block_sizes()[0];
    r[0] = 0.0;
    for (std::size_t k = 0; k < a_.size(); ++k) r[0] += kWeight * a_[k] * c[k][0];
    if (jacobians != nullptr) {
      for (std::size_t k = 0; k < a_.size(); ++k) {
        if (jacobians[k] == nullptr) continue;
        std::fill(jacobians[k], jacobians[k] + dims, 0.0);
        jacobians[k][0] = kWeight * a_[k];
      }
    }
    return true;
  }

 private:
  static constexpr double kWeight = 1e6;  // the mean twist held to 1e-6 rad
  std::vector<double> a_;
};

void add_mean_twist_convention(ceres::Problem& problem, const Context& ctx, Params& p, int knots,
                               int dims) {
  std::vector<double> a(static_cast<std::size_t>(knots), 0.0);
  for (const SplineSpot& sp : ctx.spot)
    for (std::size_t m = 0; m < 4; ++m)
      a[static_cast<std::size_t>(sp.first + static_cast<int>(m))] += sp.w[m];
  for (double& v : a) v /= static_cast<double>(ctx.spot.size());
  std::vector<double*> blocks;
  for (int k = 0; k < knots; ++k)
    blocks.push_back(p.ctrl.data() + static_cast<std::size_t>(k * dims));
  problem.AddResidualBlock(new MeanTwistConvention(std::move(a), dims), nullptr, blocks);
}

// A parameter's name: the block's, with the axis or the segment's joint.
std::string component_name(const Body& body, const IdentifyOptions& o, const Block& b, int k) {
  const char* axis = "xyz";
  if (b.name == "segment_length")
    return b.name + "." +
           body.joint(static_cast<std::size_t>(o.segments[static_cast<std::size_t>(k)])).name;
  if (b.size == 3 && b.reported) return b.name + "." + axis[k];
  return b.name;
}

struct Observability {
  Eigen::Index columns = 0;        // the free parameters' components
  std::vector<char> unobservable;  // per column
  int null_dims = 0;               // dimension of the (near) null space
};

// J^T J of the free blocks at the current point.
Eigen::MatrixXd normal_matrix(ceres::Problem& problem, const std::vector<double*>& free_blocks,
                              Eigen::Index np) {
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = free_blocks;
  ceres::CRSMatrix J;
  double cost = 0;
  // A failed evaluation left J empty, every column "unobservable" and Eigen's solver on a 0 x 0
  // matrix, which aborts the process (found in review, 2026-11-27: a NaN initial position).
  if (!problem.Evaluate(eo, &cost, nullptr, nullptr, &J) || !std::isfinite(cost))
    throw Error(
        "identify: the model cannot be evaluated at the fit's result (a residual is not "
        "finite)");
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(np, np);
  for (int r = 0; r < J.num_rows; ++r) {
    for (int a = J.rows[static_cast<std::size_t>(r)]; a < J.rows[static_cast<std::size_t>(r) + 1];
         ++a) {
      for (int b = J.rows[static_cast<std::size_t>(r)]; b < J.rows[static_cast<std::size_t>(r) + 1];
           ++b) {
        JtJ(J.cols[static_cast<std::size_t>(a)], J.cols[static_cast<std::size_t>(b)]) +=
            J.values[static_cast<std::size_t>(a)] * J.values[static_cast<std::size_t>(b)];
      }
    }
  }
  return JtJ;
}

// Observability: the Jacobian of the free parameters (the correction's too, so that a
// reported parameter traded against it is seen), columns scaled to unit norm.
Observability observability(ceres::Problem& problem, const std::vector<Block>& blocks,
                            const Body& body, const IdentifyOptions& o) {
  std::vector<double*> free_blocks;
  struct Column {
    std::string name, unit;
    bool reported;
  };
  std::vector<Column> cols;
  for (const Block& b : blocks) {
    if (!b.free) continue;
    free_blocks.push_back(b.data);
    for (int k = 0; k < b.size; ++k)
      cols.push_back({component_name(body, o, b, k), b.unit, b.reported});
  }
  Observability obs;
  const auto np = static_cast<Eigen::Index>(cols.size());
  obs.columns = np;
  obs.unobservable.assign(static_cast<std::size_t>(np), 0);
  if (np == 0) return obs;
  const Eigen::MatrixXd JtJ = normal_matrix(problem, free_blocks, np);
  const Eigen::VectorXd dn = JtJ.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double dmax = dn.maxCoeff();
  std::vector<Eigen::Index> live;
  for (Eigen::Index k = 0; k < np; ++k) {
    if (dn[k] <= 1e-12 * dmax) {
      obs.unobservable[static_cast<std::size_t>(k)] = 1;  // the residuals do not depend on it
      ++obs.null_dims;
    } else {
      live.push_back(k);
    }
  }
  const auto nl = static_cast<Eigen::Index>(live.size());
  if (nl == 0) return obs;  // nothing the residuals depend on: every column said so already
  Eigen::MatrixXd A(nl, nl);
  for (Eigen::Index a = 0; a < nl; ++a)
    for (Eigen::Index b = 0; b < nl; ++b)
      A(a, b) = JtJ(live[static_cast<std::size_t>(a)], live[static_cast<std::size_t>(b)]) /
                (dn[live[static_cast<std::size_t>(a)]] * dn[live[static_cast<std::size_t>(b)]]);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A);
  const double lmax = es.eigenvalues().maxCoeff();
  for (Eigen::Index e = 0; e < nl; ++e) {
    if (es.eigenvalues()[e] >= o.observability_threshold * o.observability_threshold * lmax)
      continue;
    ++obs.null_dims;
    for (Eigen::Index a = 0; a < nl; ++a) {
      if (std::abs(es.eigenvectors()(a, e)) > 0.1)
        obs.unobservable[static_cast<std::size_t>(live[static_cast<std::size_t>(a)])] = 1;
    }
  }
  return obs;
}

// Covariance of the reported free parameters (pseudo-inverse over the observable directions):
// the standard error per column of the free parameters (NaN where none was computed).
Eigen::VectorXd standard_errors(ceres::Problem& problem, const std::vector<Block>& blocks,
                                const Observability& obs, int threads) {
  Eigen::VectorXd stderr_col = Eigen::VectorXd::Constant(obs.columns, kNaN);
  if (obs.columns == 0) return stderr_col;
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = obs.null_dims;
  co.num_threads = std::max(1, threads);
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (const Block& b : blocks)
    if (b.free && b.reported) pairs.emplace_back(b.data, b.data);
  if (cov.Compute(pairs, &problem)) {
    Eigen::Index col = 0;
    for (const Block& b : blocks) {
      if (!b.free) continue;
      if (b.reported) {
        Eigen::MatrixXd C(b.size, b.size);
        cov.GetCovarianceBlock(b.data, b.data, C.data());
        for (int k = 0; k < b.size; ++k) stderr_col[col + k] = std::sqrt(std::max(0.0, C(k, k)));
      }
      col += b.size;
    }
  }
  return stderr_col;
}

// The fitted values into the result: placement, hardware, timing, segment lengths, correction.
void write_estimates(const Context& ctx, const Params& p, const IdentifyOptions& o, int knots,
                     int dims, IdentifyResult& res) {
  const Eigen::Quaterniond dq = so3_exp(Eigen::Vector3d(p.rot[0], p.rot[1], p.rot[2]));
  res.placement.joint = o.joint;
  res.placement.q_joint_sensor = canonical((Eigen::Quaterniond(ctx.R0) * dq).normalized());
  res.placement.p_joint_sensor = Eigen::Vector3d(p.pos[0], p.pos[1], p.pos[2]);
  res.accel_bias = Eigen::Vector3d(p.ba[0], p.ba[1], p.ba[2]);
  res.gyro_bias = Eigen::Vector3d(p.bg[0], p.bg[1], p.bg[2]);
  res.accel_scale = Eigen::Vector3d(p.sa[0], p.sa[1], p.sa[2]);
  res.gyro_scale = Eigen::Vector3d(p.sg[0], p.sg[1], p.sg[2]);
  res.time_offset_s = p.dt;
  res.clock_rate = p.kappa;
  const int S = static_cast<int>(o.segments.size());
  for (int s = 0; s < S; ++s)
    res.segment_lengths.emplace_back(o.segments[static_cast<std::size_t>(s)],
                                     p.ell[static_cast<std::size_t>(s)]);
  if (dims > 0) {
    const auto n = static_cast<Eigen::Index>(res.t.size());
    for (int k = 0; k < knots; ++k)
      for (int dd = 0; dd < dims; ++dd)
        res.correction.control(dd, k) = p.ctrl[static_cast<std::size_t>(k * dims + dd)];
    res.correction_angles.resize(dims, n);
    for (Eigen::Index i = 0; i < n; ++i)
      res.correction_angles.col(i) =
          res.correction.angles(res.t[static_cast<std::size_t>(i)]).head(dims);
  }
}

// One estimate per component of the reported blocks (the rotation as a rotation vector of the
// whole placement); unobservable ones are listed and not reported as values, here and in the
// result's fields.
void report_parameters(const std::vector<Block>& blocks, const Body& body, const IdentifyOptions& o,
                       const Observability& obs, const Eigen::VectorXd& stderr_col,
                       IdentifyResult& res) {
  const Eigen::Vector3d rot_vec = so3_log(res.placement.q_joint_sensor);
  Eigen::Index col = 0;
  for (const Block& b : blocks) {
    if (!b.reported) {
      if (b.free) col += b.size;
      continue;
    }
    for (int k = 0; k < b.size; ++k) {
      ParameterEstimate e;
      e.name = component_name(body, o, b, k);
      e.unit = b.unit;
      e.value = b.name == "rotation" ? rot_vec[k] : b.data[k];
      e.estimated = b.free;
      e.std_error = 0.0;
      if (e.estimated) {
        e.std_error = stderr_col[col];
        if (obs.unobservable[static_cast<std::size_t>(col)]) {
          e.observable = false;
          e.value = kNaN;
          e.std_error = kNaN;
          res.unobservable.push_back(e.name);
        }
        ++col;
      }
      res.parameters.push_back(e);
    }
  }
  // Unobservable components are not reported as values.
  for (const ParameterEstimate& e : res.parameters) {
    if (e.observable) continue;
    const char c = e.name.back();
    const int k = c == 'x' ? 0 : c == 'y' ? 1 : 2;
    if (e.name.rfind("position.", 0) == 0) res.placement.p_joint_sensor[k] = kNaN;
    if (e.name.rfind("rotation.", 0) == 0) res.placement.q_joint_sensor.coeffs().setConstant(kNaN);
    if (e.name.rfind("accel_bias.", 0) == 0) res.accel_bias[k] = kNaN;
    if (e.name.rfind("gyro_bias.", 0) == 0) res.gyro_bias[k] = kNaN;
    if (e.name.rfind("accel_scale.", 0) == 0) res.accel_scale[k] = kNaN;
    if (e.name.rfind("gyro_scale.", 0) == 0) res.gyro_scale[k] = kNaN;
    if (e.name == "time_offset") res.time_offset_s = kNaN;
    if (e.name == "clock_rate") res.clock_rate = kNaN;
  }
}

// Warnings about implausible scales, a clock rate at its bound and a solve that did not converge.
void add_fit_warnings(const IdentifyOptions& o, IdentifyResult& res) {
  for (int k = 0; k < 3; ++k) {
    const char ax = "xyz"[k];
    if (o.accel_scale && std::abs(res.accel_scale[k]) > 0.1) {
      res.warnings.push_back(fmt::format(
          "accel_scale.{} = {:.3f} is implausible: the motion's acceleration is probably noisier "
          "than "
          "the accelerometer (errors in variables shrink the scale); hold accel_scale fixed",
          ax, res.accel_scale[k]));
    }
    if (o.gyro_scale && std::abs(res.gyro_scale[k]) > 0.1) {
      res.warnings.push_back(
          fmt::format("gyro_scale.{} = {:.3f} is implausible: the motion's angular rate is "
                      "probably noisier than "
                      "the gyroscope; hold gyro_scale fixed",
                      ax, res.gyro_scale[k]));
    }
  }
  if (o.clock_rate && std::isfinite(res.clock_rate) &&
      std::abs(res.clock_rate) >= o.max_clock_rate * (1 - 1e-9)) {
    res.warnings.push_back(fmt::format(
        "clock_rate = {:.6g} is at its bound +-{:.6g}: the clock rate may lie beyond it (raise "
        "the maximum clock rate)",
        res.clock_rate, o.max_clock_rate));
  }
  if (!res.converged) res.warnings.push_back("the solver did not converge: " + res.solver_summary);
}

}  // namespace

IdentifyResult identify(const Body& body, MotionSource& motion, const ImuSeries& imu,
                        const IdentifyOptions& o) {
  const auto clock_start = std::chrono::steady_clock::now();
  const std::vector<double> ell0 = check_inputs(body, motion, imu, o);
  const int dims = correction_dims(o.correction);
  const double mrate = motion.rate_hz();
  const int64_t frames = *motion.frame_count();
  // IMU period: the median sample spacing.
  const double h_imu = analyze_sampling(imu.t).median_period_s;
  if (!(h_imu > 0)) throw Error("identify: the IMU time stamps do not increase");

  IdentifyResult res;
  res.motion_start_ns = o.motion_start_ns;
  res.gravity_world = o.gravity_world;
  const CoarseTiming coarse = initial_timing(body, motion, imu, o, h_imu);
  const double kappa0 = coarse.clock_rate;
  res.coarse_clock_rate = kappa0;

  // The samples used: every time the fine fit may reach (offset window, clock-rate range) must
  // lie inside the motion and outside the invalid intervals. The coarse offset is referred to the
  // coarse step's reference time; the first pass finds the samples' span with it, whose middle
  // becomes t_ref.
  Reach reach;
  reach.window = o.time_offset ? 3.0 * h_imu + 3.0 / mrate : 0.0;
  reach.edge = 2.0 / mrate + 2e-9 * static_cast<double>(kTimeStepNs);
  reach.T = static_cast<double>(frames - 1) / mrate;
  reach.kappa = clock_rate_range(o, imu, kappa0, h_imu);
  res.t_ref_ns = reference_time(imu, o, coarse, reach);
  // The coarse offset referred to t_ref.
  const double dt0 =
      coarse.offset_s + kappa0 * (to_seconds(res.t_ref_ns - o.motion_start_ns) - coarse.t_ref_s);
  res.coarse_time_offset_s = dt0;
  Context ctx;
  take_samples(imu, select_samples(imu, o, reach, res.t_ref_ns, dt0, mrate, ctx), res);

  KinematicsEvaluator eval(body, motion, o.joint, o.segments, o.gravity_world);
  ctx.eval = &eval;
  ctx.ell0 = ell0;
  // The parameters the problem's blocks point into (never reallocated once the blocks exist).
  Params p;
  const int knots = correction_grid(body, imu, o, dims, ctx, p, res);
  {
    const double rows = 6.0 * static_cast<double>(res.samples_used);
    const double params =  // the sensor's 20, the segments' and the correction's
        20.0 + static_cast<double>(o.segments.size() + static_cast<std::size_t>(dims * knots));
    const double bytes = rows * params * 8.0;
    if (bytes > kMaxDenseJacobianBytes) {
      throw Error(fmt::format(
          "identify: {} samples and {} parameters ({} knots of the correction) need a {:.1f} GiB "
          "Jacobian, more than the {:.0f} GiB allowed: fit a shorter recording, or space the "
          "correction's knots wider",
          res.samples_used, params, knots, bytes / (1 << 30), kMaxDenseJacobianBytes / (1 << 30)));
    }
  }
  initial_values(o, ell0, dt0, kappa0, reach, ctx, p, res);
  const std::vector<Block> blocks = parameter_blocks(p, o, knots, dims);

  TimeCallback callback(ctx, &p.dt, &p.kappa);
  ceres::Problem::Options po;
  po.evaluation_callback = &callback;
  ceres::Problem problem(po);
  add_sample_residuals(problem, ctx, p, res, o, dims);
  add_priors(problem, o, ell0, p);
  if (dims > 0) add_correction_priors(problem, o, p, knots, dims, res.correction.knot_spacing_s);
  constrain(problem, blocks, o, p, dt0, reach.window, reach.kappa);

  solve_robust(problem, ctx, p, o, res);
  if (dims > 0 && o.rotation && o.position) {
    recentre_twist(ctx, p, knots, dims);
    add_mean_twist_convention(problem, ctx, p, knots, dims);
  }
  ctx.update(p.dt, p.kappa);  // the last evaluation may have been a rejected step

  const Observability obs = observability(problem, blocks, body, o);
  const Eigen::VectorXd stderr_col = standard_errors(problem, blocks, obs, o.threads);

  write_estimates(ctx, p, o, knots, dims, res);
  report_parameters(blocks, body, o, obs, stderr_col, res);
  add_fit_warnings(o, res);
  const Predicted after = predict(ctx, p);
  res.accel_after = after.accel;
  res.gyro_after = after.gyro;
  res.rms_after = {rms(after.accel, res.accel), rms(after.gyro, res.gyro)};
  res.fidelity_after = fidelity(res.accel, res.gyro, after.accel, after.gyro);
  res.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return res;
}

namespace {
nlohmann::json fidelity_json(const Fidelity& f) {
  using nlohmann::json;
  auto num = [](double v) -> json { return std::isfinite(v) ? json(v) : json(nullptr); };
  auto vec = [&](const Eigen::Vector3d& v) {
    return json::array({num(v.x()), num(v.y()), num(v.z())});
  };
  return {{"samples", f.samples},
          {"accel", {{"rmse_mps2", vec(f.accel.rmse)}, {"correlation", vec(f.accel.correlation)}}},
          {"gyro", {{"rmse_radps", vec(f.gyro.rmse)}, {"correlation", vec(f.gyro.correlation)}}}};
}
}  // namespace

std::string placement_json(const IdentifyResult& r, const Body& body) {
  using nlohmann::json;
  auto num = [](double v) -> json { return std::isfinite(v) ? json(v) : json(nullptr); };
  auto vec = [&](const Eigen::Vector3d& v) {
    return json::array({num(v.x()), num(v.y()), num(v.z())});
  };
  const Eigen::Quaterniond& q = r.placement.q_joint_sensor;
  json j;
  j["schema"] = "imukit.placement/1";
  j["sensor"] = {
      {"segment", body.joint(static_cast<std::size_t>(r.placement.joint)).name},
      {"position_m", vec(r.placement.p_joint_sensor)},
      {"rotation",
       {{"quaternion_wxyz", json::array({num(q.w()), num(q.x()), num(q.y()), num(q.z())})}}}};
  j["accelerometer"] = {{"bias_mps2", vec(r.accel_bias)}, {"scale_error", vec(r.accel_scale)}};
  j["gyroscope"] = {{"bias_radps", vec(r.gyro_bias)}, {"scale_error", vec(r.gyro_scale)}};
  j["timing"] = {{"time_offset_s", num(r.time_offset_s)},
                 {"coarse_time_offset_s", num(r.coarse_time_offset_s)},
                 {"clock_rate", num(r.clock_rate)},
                 {"coarse_clock_rate", num(r.coarse_clock_rate)},
                 {"t_ref_ns", r.t_ref_ns},
                 {"motion_start_ns", r.motion_start_ns}};
  json segs = json::array();
  for (const auto& [joint, len] : r.segment_lengths)
    segs.push_back(
        {{"joint", body.joint(static_cast<std::size_t>(joint)).name}, {"length_m", num(len)}});
  j["segments"] = segs;
  j["gravity_world_mps2"] = vec(r.gravity_world);  // the value used (DESIGN.md)
  {
    const CorrectionSpline& c = r.correction;
    json corr = {{"kind", c.dims == 0 ? "none" : c.dims == 1 ? "twist" : "rotation"}};
    if (c.dims > 0) {
      json axes = json::array();
      for (int d = 0; d < c.dims; ++d) axes.push_back(vec(c.axes.col(d)));
      json control = json::array();
      for (int d = 0; d < c.dims; ++d) {
        json row = json::array();
        for (Eigen::Index k = 0; k < c.control.cols(); ++k) row.push_back(num(c.control(d, k)));
        control.push_back(row);
      }
      corr["axes_joint"] = axes;
      corr["t0_ns"] = c.t0_ns;
      corr["knot_spacing_s"] = num(c.knot_spacing_s);
      corr["control_rad"] = control;
      json rms_angle = json::array();
      for (int d = 0; d < c.dims; ++d) {
        const double v = r.correction_angles.cols() > 0
                             ? std::sqrt(r.correction_angles.row(d).squaredNorm() /
                                         static_cast<double>(r.correction_angles.cols()))
                             : kNaN;
        rms_angle.push_back(num(v));
      }
      corr["rms_angle_rad"] = rms_angle;
    }
    j["correction"] = corr;
  }
  json params = json::array();
  for (const ParameterEstimate& e : r.parameters) {
    params.push_back({{"name", e.name},
                      {"unit", e.unit},
                      {"value", num(e.value)},
                      {"std_error", num(e.std_error)},
                      {"estimated", e.estimated},
                      {"observable", e.observable}});
  }
  j["parameters"] = params;
  j["unobservable"] = r.unobservable;
  j["warnings"] = r.warnings;
  j["fit"] = {{"samples_used", r.samples_used},
              {"samples_excluded", r.samples_excluded},
              {"rms_before",
               {{"accel_mps2", num(r.rms_before.accel)}, {"gyro_radps", num(r.rms_before.gyro)}}},
              {"rms_after",
               {{"accel_mps2", num(r.rms_after.accel)}, {"gyro_radps", num(r.rms_after.gyro)}}},
              {"fidelity_before", fidelity_json(r.fidelity_before)},
              {"fidelity_after", fidelity_json(r.fidelity_after)},
              {"sigma_accel_mps2", num(r.sigma_accel)},
              {"sigma_gyro_radps", num(r.sigma_gyro)},
              {"iterations", r.iterations},
              {"converged", r.converged},
              {"seconds", num(r.seconds)}};
  return j.dump(2) + "\n";
}

Motion fitted_motion(const Body& body, MotionSource& motion, const IdentifyResult& r,
                     TimeNs first_ns, int64_t frames, double rate_hz) {
  require_simulatable(motion, "fitted_motion");
  if (!motion.frame_count()) throw Error("fitted_motion: the motion must have a finite length");
  if (frames < 2) throw Error("fitted_motion: at least 2 frames are needed");
  check_rate(rate_hz, "fitted_motion: the frame rate");
  if (!std::isfinite(r.time_offset_s) || !std::isfinite(r.clock_rate))
    throw Error("fitted_motion: the time offset or clock rate was not identified");
  const int joint = r.placement.joint;
  if (r.correction.dims > 0 && (joint < 0 || static_cast<std::size_t>(joint) >= body.size()))
    throw Error("fitted_motion: the result's joint is not a joint of the body");
  // Motion time of each new frame (held inside the motion; the spline is read up to its last
  // frame).
  const int64_t last = (*motion.frame_count() - 1) * kNsPerSecond;
  const auto end_ns = static_cast<TimeNs>(std::floor(static_cast<double>(last) / motion.rate_hz()));
  std::vector<TimeNs> tau(static_cast<std::size_t>(frames));
  std::vector<TimeNs> t_imu(static_cast<std::size_t>(frames));
  double first_s = 0.0, last_s = 0.0;
  for (int64_t k = 0; k < frames; ++k) {
    const TimeNs t = first_ns + std::llround(static_cast<double>(k) * 1e9 / rate_hz);
    const double s = to_seconds(t - r.motion_start_ns) + r.time_offset_s +
                     r.clock_rate * to_seconds(t - r.t_ref_ns);
    if (k == 0) first_s = s;
    last_s = s;
    tau[static_cast<std::size_t>(k)] = std::clamp<TimeNs>(std::llround(s * 1e9), 0, end_ns);
    t_imu[static_cast<std::size_t>(k)] = t;
  }
  // Held at the ends beyond the motion, but not wholly outside it: that motion would stand still
  // (a first_ns from another clock, or a result fitted to another recording).
  const double end_s = to_seconds(end_ns);
  if (std::max(first_s, last_s) < 0.0 || std::min(first_s, last_s) > end_s) {
    throw Error(fmt::format(
        "fitted_motion: the {} frames map to motion times {:.3f} s to {:.3f} s, wholly outside "
        "the motion (0 to {:.3f} s): is first_ns on the IMU clock the result was fitted on?",
        frames, first_s, last_s, end_s));
  }
  Motion out = spline_resample(body, motion, tau, rate_hz);
  if (r.correction.dims == 0) return out;
  const std::vector<int> children = body.children(joint);
  for (int64_t k = 0; k < frames; ++k) {
    const Eigen::Quaterniond Q = r.correction.rotation(t_imu[static_cast<std::size_t>(k)]);
    Eigen::Quaterniond& q = out.rotation(k, static_cast<std::size_t>(joint));
    q = (q * Q).normalized();
    for (int c : children) {
      Eigen::Quaterniond& qc = out.rotation(k, static_cast<std::size_t>(c));
      qc = (Q.conjugate() * qc).normalized();
    }
  }
  // Sign continuity after the products (the same rotations).
  for (std::size_t j = 0; j < body.size(); ++j) {
    for (int64_t k = 1; k < frames; ++k) {
      if (out.rotation(k, j).coeffs().dot(out.rotation(k - 1, j).coeffs()) < 0.0)
        out.rotation(k, j).coeffs() *= -1.0;
    }
  }
  return out;
}

FittedSceneClock fitted_scene_clock(std::span<const TimeNs> imu_t) {
  const SamplingStats st = analyze_sampling(imu_t);
  if (st.samples < 2 || !(st.duration > 0))
    throw Error("fitted scene: the IMU's time stamps must advance over at least 2 samples");
  FittedSceneClock c;
  c.first_ns = imu_t.front();
  if (!st.samples_missing()) {
    c.frames = static_cast<int64_t>(st.samples);
    c.rate_hz = measured_rate_hz(imu_t, "fitted scene");
  } else {
    c.rate_hz = 1.0 / st.mean_period_between_gaps_s;
    c.frames = samples_spanning(to_seconds(st.duration), c.rate_hz);
  }
  return c;
}

void write_fitted_scene(const std::string& dir, const Body& body, const Motion& fitted,
                        const IdentifyResult& r, const std::string& sensor_name,
                        const Eigen::Vector3d& gravity_world) {
  using nlohmann::json;
  const Placement& pl = r.placement;
  if (pl.joint < 0 || static_cast<std::size_t>(pl.joint) >= body.size())
    throw Error("write_fitted_scene: the result's joint is not a joint of the body");
  if (!pl.p_joint_sensor.allFinite() || !pl.q_joint_sensor.coeffs().allFinite() ||
      !r.accel_bias.allFinite() || !r.gyro_bias.allFinite() || !r.accel_scale.allFinite() ||
      !r.gyro_scale.allFinite()) {
    std::string names;
    for (const std::string& n : r.unobservable) names += (names.empty() ? "" : ", ") + n;
    throw Error("write_fitted_scene: not every placement and hardware parameter was identified (" +
                names + "); no scene is written");
  }
  // The identified segment lengths, each along its offset's direction: the nominal body made
  // the scene miss the fit (0.96 m/s^2 against the fit's 0.04 with a 25 % longer upper arm;
  // found in review, 2026-11-27).
  Body fitted_body = body;
  for (const auto& [joint, length] : r.segment_lengths) {
    if (joint < 0 || static_cast<std::size_t>(joint) >= body.size() || !(length > 0.0))
      throw Error("write_fitted_scene: a segment length of the result does not fit the body");
    Eigen::Vector3d& offset =
        fitted_body.joint(static_cast<std::size_t>(joint)).offset_parent_joint;
    offset *= length / offset.norm();
  }
  std::filesystem::create_directories(dir);
  const std::filesystem::path d(dir);
  write_quaternion_csv((d / "motion.csv").string(), fitted_body, fitted);
  DeviceProfile hw;
  hw.device = DeviceInfo{"", "", "", sensor_name};
  Calibration ca, cg;
  ca.scale = Eigen::Vector3d::Ones() + r.accel_scale;
  ca.bias = r.accel_bias;
  cg.scale = Eigen::Vector3d::Ones() + r.gyro_scale;
  cg.bias = r.gyro_bias;
  hw.accelerometer = SensorProfile{};
  hw.accelerometer->calibration = ca;
  hw.gyroscope = GyroscopeProfile{};
  hw.gyroscope->calibration = cg;
  const Eigen::Quaterniond& q = pl.q_joint_sensor;
  json sensor = {
      {"name", sensor_name},
      {"segment", body.joint(static_cast<std::size_t>(pl.joint)).name},
      {"position_m", {pl.p_joint_sensor.x(), pl.p_joint_sensor.y(), pl.p_joint_sensor.z()}},
      {"rotation", {{"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}}}},
      {"hardware", json::parse(format_profile(hw))}};
  json scene = {{"schema", "imukit.scene/1"},
                {"body", json::parse(body_json(fitted_body))},
                {"motion", {{"quaternion_csv", "motion.csv"}}},
                {"simulation",
                 {{"method", "spline"},
                  {"rate_hz", fitted.rate_hz()},
                  {"gravity", {gravity_world.x(), gravity_world.y(), gravity_world.z()}}}},
                {"sensors", json::array({sensor})}};
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = (d / name).string();
    std::ofstream f(path);
    if (!f) throw Error(path + ": cannot open for writing");
    f << text;
    if (!f.flush()) throw Error(path + ": write failed");
  };
  write("scene.json", scene.dump(2) + "\n");
  write("placement.json", placement_json(r, body));
}

PoseMotion pose_track_motion(const PoseTrack& track, const std::string& source) {
  const std::size_t n = track.t.size();
  if (track.q_world_body.size() != n || static_cast<std::size_t>(track.p_world_body.cols()) != n)
    throw Error(source + ": pose track columns differ in length");
  auto valid = [&](std::size_t i) {
    return track.q_world_body[i].coeffs().allFinite() &&
           track.p_world_body.col(static_cast<Eigen::Index>(i)).allFinite() &&
           track.q_world_body[i].norm() > 1e-6;
  };
  std::size_t a = 0, b = n;
  while (a < n && !valid(a)) ++a;
  while (b > a && !valid(b - 1)) --b;
  if (b - a < 8)
    throw Error(source + ": the pose track has fewer than 8 rows with a complete pose");
  const TimeNs span = track.t[b - 1] - track.t[a];
  if (span <= 0) throw Error(source + ": pose time stamps do not increase");
  const double period = static_cast<double>(span) / static_cast<double>(b - 1 - a);
  for (std::size_t i = a + 1; i < b; ++i) {
    const double d = static_cast<double>(track.t[i] - track.t[i - 1]);
    if (std::abs(d - period) > 1e-3 * period + 2000.0) {
      throw Error(
          fmt::format("{}: pose row {} is {:.6f} s after the previous one; a pose track must be "
                      "uniformly sampled (period {:.6f} s)",
                      source, i + 1, d * 1e-9, period * 1e-9));
    }
  }
  PoseMotion pm;
  pm.body.add_joint("pose", -1, Eigen::Vector3d::Zero());
  pm.motion = Motion(1e9 / period, 1, static_cast<int64_t>(b - a));
  pm.start_ns = track.t[a];
  std::size_t last_valid = a;
  for (std::size_t i = a; i < b; ++i) {
    const auto f = static_cast<int64_t>(i - a);
    if (valid(i)) {
      pm.motion.rotation(f, 0) = track.q_world_body[i].normalized();
      pm.motion.root_translation(f) = track.p_world_body.col(static_cast<Eigen::Index>(i));
      last_valid = i;
      continue;
    }
    std::size_t next = i;
    while (!valid(next)) ++next;  // b - 1 is valid
    const Eigen::Quaterniond q0 = track.q_world_body[last_valid].normalized();
    const Eigen::Quaterniond q1 = track.q_world_body[next].normalized();
    const Eigen::Vector3d p0 = track.p_world_body.col(static_cast<Eigen::Index>(last_valid));
    const Eigen::Vector3d p1 = track.p_world_body.col(static_cast<Eigen::Index>(next));
    for (std::size_t k = i; k < next; ++k) {
      const double u = static_cast<double>(k - last_valid) / static_cast<double>(next - last_valid);
      pm.motion.rotation(static_cast<int64_t>(k - a), 0) = imukit::slerp(q0, q1, u);
      pm.motion.root_translation(static_cast<int64_t>(k - a)) = (1 - u) * p0 + u * p1;
    }
    pm.gaps.emplace_back(track.t[i] - pm.start_ns, track.t[next - 1] - pm.start_ns);
    pm.missing_rows += static_cast<int64_t>(next - i);
    i = next - 1;
  }
  pm.motion.validate_and_normalize(&pm.body);
  return pm;
}

}  // namespace imukit::sim
