#include "sim/identify.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/so3.hpp"
#include "sim/simulator.hpp"

namespace imukit::sim {
namespace {

constexpr int kMaxSegments = 6;
// Step of the central difference that gives the kinematics' time derivative. Inside one frame
// interval the spline's translation is a cubic, so its acceleration is linear in time and the
// central difference of it is exact; the rotational terms are smooth and the O(h^2) error is
// ~1e-8 of their size. Within h of a frame the difference averages the two one-sided slopes.
constexpr TimeNs kTimeStepNs = 100'000;
constexpr double kMaxClockRate = 2e-4;  // bound of the clock-rate parameter (200 ppm)
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Rows of the per-sample kinematics, all in the joint frame at the sample's motion time:
// specific force of the joint origin (nominal segment lengths), angular rate, angular
// acceleration, then per identified segment the change of that specific force per metre of
// segment length (the rigid-body point acceleration is linear in the offsets).
enum Row { kF = 0, kW = 3, kAlpha = 6, kS = 9 };

// Joint kinematics at shifted sample times, from the spline simulator through its public API:
// a sensor at the joint origin (specific force, rate, orientation) and two at unit offsets along
// x and y, whose difference from the origin is alpha x e + w x (w x e), which gives alpha
// exactly; for each identified segment a pair of sensors on its parent joint gives the
// acceleration per metre of offset.
class KinematicsEvaluator {
 public:
  KinematicsEvaluator(const Body& body, MotionSource& motion, int joint, std::vector<int> segments,
                      const Eigen::Vector3d& gravity)
      : motion_(motion), segments_(std::move(segments)) {
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
    const bool seg = !segments_.empty();
    sensor(joint, Eigen::Vector3d::Zero(), true, seg);
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
  std::vector<SensorSpec> specs_;
  std::unique_ptr<Simulator> sim_;
  std::vector<SensorBlock> blocks_;
};

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

template <typename T>
void gyro_model(const Context& c, int i, const T* rot, const T* bg, const T* sg, const T* dt,
                const T* kappa, T out[3]) {
  const T shift = time_shift(c, i, dt, kappa);
  T w[3], v[3];
  kin(c, i, kW, shift, w);
  to_sensor(c, rot, w, v);
  for (int k = 0; k < 3; ++k) out[k] = (T(1.0) + sg[k]) * v[k] + bg[k];
}

template <typename T>
void accel_model(const Context& c, int i, const T* rot, const T* pos, const T* ba, const T* sa,
                 const T* dt, const T* kappa, const T* ell, int segments, T out[3]) {
  const T shift = time_shift(c, i, dt, kappa);
  T f[3], w[3], al[3];
  kin(c, i, kF, shift, f);
  kin(c, i, kW, shift, w);
  kin(c, i, kAlpha, shift, al);
  for (int s = 0; s < segments; ++s) {
    T S[3];
    kin(c, i, kS + 3 * s, shift, S);
    const T dl = ell[s] - c.ell0[static_cast<std::size_t>(s)];
    for (int k = 0; k < 3; ++k) f[k] += S[k] * dl;
  }
  T axp[3], wxp[3], wwxp[3], a[3], v[3];
  ceres::CrossProduct(al, pos, axp);
  ceres::CrossProduct(w, pos, wxp);
  ceres::CrossProduct(w, wxp, wwxp);
  for (int k = 0; k < 3; ++k) a[k] = f[k] + axp[k] + wwxp[k];
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
    gyro_model(*c, i, rot, bg, sg, dt, kappa, m);
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
    accel_model<T>(*c, i, rot, pos, ba, sa, dt, kappa, nullptr, 0, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_a;
    return true;
  }
};

// With segment lengths (a parameter block of run-time size).
struct AccelSegmentCost {
  const Context* c;
  int i;
  int segments;
  Eigen::Vector3d meas;
  template <typename T>
  bool operator()(T const* const* p, T* r) const {
    T m[3];
    accel_model<T>(*c, i, p[0], p[1], p[2], p[3], p[4], p[5], p[6], segments, m);
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - meas[k]) * c->inv_sigma_a;
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

// Coarse time offset: Pearson correlation of |w| measured against |w| of the joint, both on a
// grid of the IMU's period, over lags within +-max_offset; parabolic refinement of the peak.
double coarse_offset(const Body& body, MotionSource& motion, const IdentifyOptions& o,
                     const ImuSeries& imu, double h, double* peak_r) {
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
  const auto L = static_cast<int64_t>(std::ceil(o.max_time_offset_s / h));
  std::vector<double> r(static_cast<std::size_t>(2 * L + 1), -2.0);
  for (int64_t lag = -L; lag <= L; ++lag) {
    double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int64_t j = jm0; j <= jm1; ++j) {
      const int64_t js = j + lag;
      if (js < 0 || js >= M) continue;
      const double x = meas[static_cast<std::size_t>(j - jm0)];
      const double y = sim[static_cast<std::size_t>(js)];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      n += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      syy += y * y;
      sxy += x * y;
    }
    if (n < 10) continue;
    const double vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
    if (vx > 0 && vy > 0)
      r[static_cast<std::size_t>(lag + L)] = (sxy - sx * sy / n) / std::sqrt(vx * vy);
  }
  const auto best = static_cast<int64_t>(std::max_element(r.begin(), r.end()) - r.begin());
  *peak_r = r[static_cast<std::size_t>(best)];
  if (*peak_r < -1.0) {  // no lag had 10 samples of both (or any variation in them)
    throw Error(fmt::format(
        "identify: the IMU recording and the motion do not overlap by 10 samples at any time "
        "offset within +-{:g} s (or one of them does not move); check --motion-start",
        o.max_time_offset_s));
  }
  double frac = 0.0;
  if (best > 0 && best < 2 * L) {
    const double a = r[static_cast<std::size_t>(best - 1)], b = r[static_cast<std::size_t>(best)],
                 c = r[static_cast<std::size_t>(best + 1)];
    const double den = a - 2 * b + c;
    if (den < 0) frac = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
  }
  return (static_cast<double>(best - L) + frac) * h;
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
};

struct Predicted {
  Eigen::Matrix3Xd accel, gyro;
};

Predicted predict(const Context& c, const Params& p) {
  const auto n = static_cast<Eigen::Index>(c.base_s.size());
  Predicted out{Eigen::Matrix3Xd(3, n), Eigen::Matrix3Xd(3, n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const int ii = static_cast<int>(i);
    double a[3], g[3];
    accel_model(c, ii, p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt, &p.kappa,
                p.ell.data(), static_cast<int>(p.ell.size()), a);
    gyro_model(c, ii, p.rot.data(), p.bg.data(), p.sg.data(), &p.dt, &p.kappa, g);
    out.accel.col(i) = Eigen::Vector3d(a[0], a[1], a[2]);
    out.gyro.col(i) = Eigen::Vector3d(g[0], g[1], g[2]);
  }
  return out;
}

double rms(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return std::sqrt((a - b).squaredNorm() /
                   static_cast<double>(std::max<Eigen::Index>(1, a.size())));
}

}  // namespace

IdentifyResult identify(const Body& body, MotionSource& motion, const ImuSeries& imu,
                        const IdentifyOptions& o) {
  const auto clock_start = std::chrono::steady_clock::now();
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
  for (int s : o.segments) {
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
  if (!(std::abs(o.time_offset_init_s) <= 86400.0) || !(o.max_time_offset_s <= 86400.0))
    throw Error("identify: time offsets must be finite and within a day (86400 s)");

  const double mrate = motion.rate_hz();
  const int64_t frames = *motion.frame_count();
  const double T = static_cast<double>(frames - 1) / mrate;
  if (frames < 8) throw Error("identify: the motion needs at least 8 frames");
  // IMU period: the median sample spacing.
  std::vector<TimeNs> d(imu.size() - 1);
  for (std::size_t i = 0; i + 1 < imu.size(); ++i) d[i] = imu.t[i + 1] - imu.t[i];
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  const double h_imu = to_seconds(d[d.size() / 2]);
  if (!(h_imu > 0)) throw Error("identify: the IMU time stamps do not increase");

  IdentifyResult res;
  double peak_r = 1.0;
  double dt0 = o.time_offset_init_s;
  if (o.time_offset && o.coarse_time_offset) {
    dt0 = coarse_offset(body, motion, o, imu, h_imu, &peak_r);
    if (peak_r < 0.3) {
      throw Error(fmt::format(
          "identify: the time offset is unobservable: measured and simulated angular-rate "
          "magnitudes do "
          "not correlate within +-{} s (best r = {:.2f}); give the offset and hold it fixed",
          o.max_time_offset_s, peak_r));
    }
  }
  res.coarse_time_offset_s = dt0;

  // The samples used: every time the fine fit may reach (offset window, clock rate) must lie
  // inside the motion and outside the invalid intervals.
  const double window = o.time_offset ? 3.0 * h_imu + 3.0 / mrate : 0.0;
  const double dlo = std::min(0.0, dt0 - window), dhi = std::max(0.0, dt0 + window);
  const double edge = 2.0 / mrate + 2e-9 * static_cast<double>(kTimeStepNs);
  TimeNs first = 0, last = 0;
  bool any = false;
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const double b = to_seconds(imu.t[i] - o.motion_start_ns);
    if (b + dlo >= edge && b + dhi <= T - edge) {
      if (!any) first = imu.t[i];
      last = imu.t[i];
      any = true;
    }
  }
  if (!any) throw Error("identify: the IMU recording does not overlap the motion");
  res.t_ref_ns = first + (last - first) / 2;
  const double kmax = o.clock_rate ? kMaxClockRate : 0.0;
  Context ctx;
  std::vector<std::size_t> used;
  const TimeNs guard = from_seconds(3.0 / mrate);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    const double b = to_seconds(imu.t[i] - o.motion_start_ns);
    const double rel = to_seconds(imu.t[i] - res.t_ref_ns);
    const double lo = b + dlo - kmax * std::abs(rel), hi = b + dhi + kmax * std::abs(rel);
    bool ok = lo >= edge && hi <= T - edge &&
              imu.accel.col(static_cast<Eigen::Index>(i)).allFinite() &&
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
  res.samples_used = static_cast<int64_t>(used.size());
  res.samples_excluded = static_cast<int64_t>(imu.size() - used.size());
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

  KinematicsEvaluator eval(body, motion, o.joint, o.segments, o.gravity_world);
  ctx.eval = &eval;
  ctx.ell0 = ell0;

  // Before: the initial placement, no bias, no time offset.
  Params p;
  p.pos = {o.init.p_joint_sensor.x(), o.init.p_joint_sensor.y(), o.init.p_joint_sensor.z()};
  p.ell = ell0;
  ctx.R0 = o.init.q_joint_sensor.normalized().toRotationMatrix();
  ctx.update(0.0, 0.0);
  {
    const Predicted b = predict(ctx, p);
    res.accel_before = b.accel;
    res.gyro_before = b.gyro;
    res.rms_before = {rms(b.accel, res.accel), rms(b.gyro, res.gyro)};
  }

  p.dt = dt0;
  ctx.update(dt0, 0.0);
  if (o.rotation && o.init_rotation_from_data) {
    // Gyro vectors dominate when the motion rotates; gravity (in f) settles the rest.
    Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      B += ctx.value.block<3, 1>(kW, i) * res.gyro.col(i).transpose();
      B += 0.01 * ctx.value.block<3, 1>(kF, i) * res.accel.col(i).transpose();
    }
    ctx.R0 = wahba(B);
  }

  // Problem: one gyro and one accelerometer residual block per sample.
  TimeCallback callback(ctx, &p.dt, &p.kappa);
  ceres::Problem::Options po;
  po.evaluation_callback = &callback;
  ceres::Problem problem(po);
  const int S = static_cast<int>(o.segments.size());
  std::vector<double*> blocks = {p.rot.data(), p.pos.data(), p.ba.data(), p.bg.data(),
                                 p.sa.data(),  p.sg.data(),  &p.dt,       &p.kappa};
  std::vector<int> sizes = {3, 3, 3, 3, 3, 3, 1, 1};
  const std::vector<bool> free = {o.rotation,    o.position,   o.accel_bias,  o.gyro_bias,
                                  o.accel_scale, o.gyro_scale, o.time_offset, o.clock_rate};
  const std::vector<std::string> block_names = {"rotation",    "position",    "accel_bias",
                                                "gyro_bias",   "accel_scale", "gyro_scale",
                                                "time_offset", "clock_rate"};
  const std::vector<std::string> block_units = {"rad", "m", "m/s^2", "rad/s", "1", "1", "s", "1"};
  const double huber = o.huber_sigmas * std::sqrt(3.0);
  for (Eigen::Index i = 0; i < n; ++i) {
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
      auto* cf = new ceres::DynamicAutoDiffCostFunction<AccelSegmentCost, 8>(
          new AccelSegmentCost{&ctx, ii, S, res.accel.col(i)});
      for (int b : {3, 3, 3, 3, 1, 1}) cf->AddParameterBlock(b);
      cf->AddParameterBlock(S);
      cf->SetNumResiduals(3);
      problem.AddResidualBlock(
          cf, new ceres::HuberLoss(huber),
          {p.rot.data(), p.pos.data(), p.ba.data(), p.sa.data(), &p.dt, &p.kappa, p.ell.data()});
    }
  }
  if (S > 0) {
    blocks.push_back(p.ell.data());
    sizes.push_back(S);
    for (int s = 0; s < S; ++s) {
      auto* cf = new ceres::DynamicAutoDiffCostFunction<SegmentPrior, 8>(
          new SegmentPrior{s, S, ell0[static_cast<std::size_t>(s)],
                           o.segment_prior * ell0[static_cast<std::size_t>(s)]});
      cf->AddParameterBlock(S);
      cf->SetNumResiduals(1);
      problem.AddResidualBlock(cf, nullptr, std::vector<double*>{p.ell.data()});
    }
  }
  std::vector<bool> is_free = free;
  if (S > 0) is_free.push_back(true);
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    if (!is_free[b]) problem.SetParameterBlockConstant(blocks[b]);
  }
  if (o.time_offset) {
    problem.SetParameterLowerBound(&p.dt, 0, dt0 - window);
    problem.SetParameterUpperBound(&p.dt, 0, dt0 + window);
  }
  if (o.clock_rate) {
    problem.SetParameterLowerBound(&p.kappa, 0, -kMaxClockRate);
    problem.SetParameterUpperBound(&p.kappa, 0, kMaxClockRate);
  }

  // Residual scale from the current residuals (robust), so the Huber threshold means sigmas.
  auto reweight = [&] {
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
  };
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = std::max(1, o.threads);
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  for (int stage = 0; stage < 2; ++stage) {
    reweight();
    ceres::Solve(so, &problem, &summary);
    // iterations[0] is the initial evaluation; a solve that fails at once has none at all.
    res.iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  }
  res.converged = summary.termination_type == ceres::CONVERGENCE;
  res.solver_summary = summary.BriefReport();
  ctx.update(p.dt, p.kappa);  // the last evaluation may have been a rejected step

  // Observability: the Jacobian of the free parameters, columns scaled to unit norm.
  std::vector<double*> free_blocks;
  std::vector<std::string> col_name, col_unit;
  std::vector<std::pair<std::size_t, int>> col_of;  // (block, component)
  const char* axis = "xyz";
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    if (!is_free[b]) continue;
    free_blocks.push_back(blocks[b]);
    for (int k = 0; k < sizes[b]; ++k) {
      std::string nm = b < block_names.size() ? block_names[b] : "segment_length";
      if (b >= block_names.size())
        nm += "." +
              body.joint(static_cast<std::size_t>(o.segments[static_cast<std::size_t>(k)])).name;
      else if (sizes[b] == 3)
        nm += std::string(".") + axis[k];
      col_name.push_back(nm);
      col_unit.push_back(b < block_units.size() ? block_units[b] : "m");
      col_of.emplace_back(b, k);
    }
  }
  const auto np = static_cast<Eigen::Index>(col_name.size());
  std::vector<char> unobservable(static_cast<std::size_t>(np), 0);
  int null_dims = 0;
  if (np > 0) {
    ceres::Problem::EvaluateOptions eo;
    eo.parameter_blocks = free_blocks;
    ceres::CRSMatrix J;
    double cost = 0;
    problem.Evaluate(eo, &cost, nullptr, nullptr, &J);
    Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(np, np);
    for (int r = 0; r < J.num_rows; ++r) {
      for (int a = J.rows[static_cast<std::size_t>(r)]; a < J.rows[static_cast<std::size_t>(r) + 1];
           ++a) {
        for (int b = J.rows[static_cast<std::size_t>(r)];
             b < J.rows[static_cast<std::size_t>(r) + 1]; ++b) {
          JtJ(J.cols[static_cast<std::size_t>(a)], J.cols[static_cast<std::size_t>(b)]) +=
              J.values[static_cast<std::size_t>(a)] * J.values[static_cast<std::size_t>(b)];
        }
      }
    }
    const Eigen::VectorXd dn = JtJ.diagonal().cwiseMax(0.0).cwiseSqrt();
    const double dmax = dn.maxCoeff();
    std::vector<Eigen::Index> live;
    for (Eigen::Index k = 0; k < np; ++k) {
      if (dn[k] <= 1e-12 * dmax) {
        unobservable[static_cast<std::size_t>(k)] = 1;  // the residuals do not depend on it at all
        ++null_dims;
      } else {
        live.push_back(k);
      }
    }
    const auto nl = static_cast<Eigen::Index>(live.size());
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
      ++null_dims;
      for (Eigen::Index a = 0; a < nl; ++a) {
        if (std::abs(es.eigenvectors()(a, e)) > 0.1)
          unobservable[static_cast<std::size_t>(live[static_cast<std::size_t>(a)])] = 1;
      }
    }
  }

  // Covariance of the free parameters (pseudo-inverse over the observable directions).
  Eigen::VectorXd stderr_col = Eigen::VectorXd::Constant(np, kNaN);
  if (np > 0) {
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    co.null_space_rank = null_dims;
    co.num_threads = std::max(1, o.threads);
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> pairs;
    for (double* b : free_blocks) pairs.emplace_back(b, b);
    if (cov.Compute(pairs, &problem)) {
      Eigen::Index col = 0;
      for (std::size_t fb = 0; fb < free_blocks.size(); ++fb) {
        std::size_t b = 0;
        while (blocks[b] != free_blocks[fb]) ++b;
        Eigen::MatrixXd C(sizes[b], sizes[b]);
        cov.GetCovarianceBlock(free_blocks[fb], free_blocks[fb], C.data());
        for (int k = 0; k < sizes[b]; ++k) stderr_col[col++] = std::sqrt(std::max(0.0, C(k, k)));
      }
    }
  }

  // Result.
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
  for (int s = 0; s < S; ++s)
    res.segment_lengths.emplace_back(o.segments[static_cast<std::size_t>(s)],
                                     p.ell[static_cast<std::size_t>(s)]);
  const Eigen::Vector3d rot_vec = so3_log(res.placement.q_joint_sensor);
  auto value_of = [&](std::size_t b, int k) -> double {
    if (b == 0) return rot_vec[k];
    return blocks[b][k];
  };
  Eigen::Index col = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    for (int k = 0; k < sizes[b]; ++k) {
      ParameterEstimate e;
      e.name =
          b < block_names.size()
              ? block_names[b]
              : "segment_length." +
                    body.joint(static_cast<std::size_t>(o.segments[static_cast<std::size_t>(k)]))
                        .name;
      if (b < block_names.size() && sizes[b] == 3) e.name += std::string(".") + axis[k];
      e.unit = b < block_units.size() ? block_units[b] : "m";
      e.value = value_of(b, k);
      e.estimated = is_free[b];
      e.std_error = 0.0;
      if (e.estimated) {
        e.std_error = stderr_col[col];
        if (unobservable[static_cast<std::size_t>(col)]) {
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
  if (!res.converged) res.warnings.push_back("the solver did not converge: " + res.solver_summary);
  const Predicted after = predict(ctx, p);
  res.accel_after = after.accel;
  res.gyro_after = after.gyro;
  res.rms_after = {rms(after.accel, res.accel), rms(after.gyro, res.gyro)};
  res.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return res;
}

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
                 {"t_ref_ns", r.t_ref_ns}};
  json segs = json::array();
  for (const auto& [joint, len] : r.segment_lengths)
    segs.push_back(
        {{"joint", body.joint(static_cast<std::size_t>(joint)).name}, {"length_m", num(len)}});
  j["segments"] = segs;
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
              {"sigma_accel_mps2", num(r.sigma_accel)},
              {"sigma_gyro_radps", num(r.sigma_gyro)},
              {"iterations", r.iterations},
              {"converged", r.converged},
              {"seconds", num(r.seconds)}};
  return j.dump(2) + "\n";
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
