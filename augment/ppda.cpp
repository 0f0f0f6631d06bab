// PPDA: sub-policies applied to the simulation's parameters, then simulated (augment/ppda.hpp).
#include "imukit/augment/ppda.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <map>
#include <set>

#include "imukit/core/error.hpp"
#include "imukit/core/hardware_model.hpp"
#include "imukit/core/isa.hpp"
#include "imukit/core/lane_math.hpp"
#include "imukit/core/parallel.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/time.hpp"

namespace imukit::augment {

using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

// A window's re-timed span needs more motion than the scene has (a speed drawn too fast for a
// short motion): apply() flags the window instead where its caller asks to (too_short).
struct MotionTooShort : Error {
  using Error::Error;
};

// Frames of margin on each side of a window's motion: the spline simulator's stencil reaches
// one frame back and two ahead of an interval, and the source interpolation one more. An
// anti-aliasing simulator reaches further (Impl::margin).
constexpr int64_t kMargin = 3;

// Which joints carry a sensor in one apply() call, and the virtual sensors simulated for them:
// per carrier joint, the origin (accelerometer + gyroscope, identity orientation) and the unit
// points along the joint's x, y, z axes (accelerometer only).
// When the sub-policy keeps every sensor's position (no swap, shift or long-axis turn), the
// carriers are simply the sensors at their positions with identity orientation (fixed = true):
// a quarter of the points, and rotations still follow afterwards.
struct Carriers {
  bool fixed = false;
  std::vector<int> joints;           // body indices
  std::map<int, std::size_t> index;  // body index -> carrier
  std::vector<sim::SensorSpec> specs;
};

Carriers make_carriers(const std::set<int>& joints) {
  Carriers c;
  for (int j : joints) {
    c.index[j] = c.joints.size();
    c.joints.push_back(j);
    for (int k = 0; k < 4; ++k) {
      sim::SensorSpec s;
      s.name = fmt::format("carrier{}.{}", j, k);
      s.placement.joint = j;
      if (k > 0) s.placement.p_joint_sensor[k - 1] = 1.0;
      s.outputs.accelerometer = true;
      s.outputs.gyroscope = k == 0;
      c.specs.push_back(s);
    }
  }
  return c;
}

// 4-point Lagrange weights at x for the nodes s0 .. s0 + 3.
std::array<double, 4> lagrange4(double x, int64_t s0) {
  std::array<double, 4> w{};
  for (int m = 0; m < 4; ++m) {
    double v = 1.0;
    for (int l = 0; l < 4; ++l) {
      if (l != m) v *= (x - static_cast<double>(s0 + l)) / static_cast<double>(m - l);
    }
    w[static_cast<std::size_t>(m)] = v;
  }
  return w;
}

// q_k <- exp(s_k log q_k) for n unit quaternions stored as Eigen keeps them (x, y, z, w), the n
// frames of one joint over a window: the same rotation axis with s_k times the angle. Each
// frame's (shortest-arc) form, sign w >= 0, has the half-angle h = atan2(|v|, w) in [0, pi/2]
// about the axis d = v / |v|; every h + m pi (m whole) about d is the same rotation, and the log
// must follow the motion: of those, each frame takes the half-angle phi nearest the previous
// frame's (projected on its axis), so phi is continuous in time. Shortest arc frame by frame
// made phi jump from pi/2 to -pi/2 wherever the rotation crossed pi, and s phi then jumped by
// (1 - s) pi (a joint near pi under s = 1.3: 290 rad/s where the motion has 1.2). Motions that
// never cross pi keep m = 0 and the shortest-arc bits. Then q' = (cos(s phi), d sin(s phi)); at
// |v| = 0 the axis is arbitrary and the identity stays itself, and near it sin(s phi) / |v| ->
// s / w stays accurate. The hot loop of amplitude augmentation: the first and last passes are
// built from core/lane_math's branch-free functions and vectorise; the middle one, a scalar
// scan, runs only for a joint that leaves the shortest arc in the window. phi, norm, cosine:
// scratch of n doubles each.
// (core's scale_rotation does the same through so3_log and so3_exp, frame by frame.)
[[gnu::always_inline]] inline void scale_angles_kernel(double* __restrict q,
                                                       const double* __restrict s,
                                                       double* __restrict phi,
                                                       double* __restrict norm,
                                                       double* __restrict cosine, std::size_t n) {
  // 1. Each frame's shortest-arc form, in place: |v|, h, and the cosine between neighbouring
  //    frames' axes (0 beside a frame with no axis).
  for (std::size_t i = 0; i < n; ++i) {
    const double sign = q[4 * i + 3] < 0.0 ? -1.0 : 1.0;
    const double x = sign * q[4 * i], y = sign * q[4 * i + 1], z = sign * q[4 * i + 2];
    const double w = sign * q[4 * i + 3];
    q[4 * i] = x;
    q[4 * i + 1] = y;
    q[4 * i + 2] = z;
    q[4 * i + 3] = w;
    norm[i] = __builtin_sqrt(x * x + y * y + z * z);
    phi[i] = lane::atan2_first_quadrant(norm[i], w);
  }
  // Whether any frame would leave the shortest arc were its predecessor on it: if none, by
  // induction every frame stays there (phi = h), and the scan below, a chain of dependent
  // operations, is skipped -- the usual case, a window in which no joint crosses pi.
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kInvPi = 1.0 / kPi;
  int off_arc = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double* a = q + 4 * (i - 1);
    const double* b = q + 4 * i;
    const double den = norm[i - 1] * norm[i];
    const double dot = (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];
    cosine[i] = dot / (den > 0.0 ? den : 1.0);
    off_arc += lane::round_small((phi[i - 1] * cosine[i] - phi[i]) * kInvPi) != 0.0 ? 1 : 0;
  }
  // 2. The continuous half-angle: the candidate h + m pi nearest the previous frame's phi
  //    projected on this frame's axis. A frame exactly at +-identity has no axis of its own:
  //    it keeps the previous frame's (its vector part becomes that unit axis), so a joint that
  //    turns through a whole turn and back does not lose count there.
  bool axis_replaced = false;
  for (std::size_t i = 1; i < n && off_arc > 0; ++i) {
    double c = cosine[i];
    if (axis_replaced) {
      const double* a = q + 4 * (i - 1);
      const double* b = q + 4 * i;
      c = norm[i] > 0.0 ? ((a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]) / norm[i] : 1.0;
      axis_replaced = false;
    }
    if (norm[i] == 0.0) {
      const double m = lane::round_small(phi[i - 1] * kInvPi);
      if (m == 0.0 || norm[i - 1] == 0.0) continue;  // still the identity (or no axis yet)
      phi[i] = kPi * m;
      for (int k = 0; k < 3; ++k) q[4 * i + k] = q[4 * (i - 1) + k] / norm[i - 1];
      norm[i] = 1.0;
      axis_replaced = true;
      continue;
    }
    const double m = lane::round_small((phi[i - 1] * c - phi[i]) * kInvPi);
    phi[i] += kPi * m;
  }
  // 3. q' = (d sin(s phi), cos(s phi)).
  for (std::size_t i = 0; i < n; ++i) {
    const lane::SinCos sc = lane::sincos_small(s[i] * phi[i]);
    const double k = sc.sin / (norm[i] > 0.0 ? norm[i] : 1.0);
    q[4 * i] = k * q[4 * i];
    q[4 * i + 1] = k * q[4 * i + 1];
    q[4 * i + 2] = k * q[4 * i + 2];
    q[4 * i + 3] = sc.cos;
  }
}
// Built for the baseline, AVX2 and AVX-512 (core/isa.hpp): passes 1 and 3 vectorise to the
// machine's width, with the same bits in every variant.
IMUKIT_ISA_VARIANTS(void, scale_angles, scale_angles_kernel,
                    (double* q, const double* s, double* phi, double* norm, double* cosine,
                     std::size_t n),
                    (q, s, phi, norm, cosine, n))

// The window's rotations of one joint: for window frame j, the 4-point Lagrange combination
// (weights w[4j..4j+3]) of the source rotations s0[j] .. s0[j]+3, each sign-aligned with the
// rotation at ref[j], renormalised -- or that rotation itself, bit for bit, where exact[j] is 1.
// Source rotations are `stride` doubles apart (x, y, z, w each); dst holds n of them, packed.
// Each tile first copies every frame's four stencil rotations (contiguous in an in-memory
// Motion: one 128-byte copy) and its reference next to each other, so the arithmetic below
// reads fixed offsets and vectorises.
constexpr std::size_t kInterpolationTile = 64;

// st: per frame 16 doubles (the four stencil rotations), rf: per frame its reference rotation.
[[gnu::always_inline]] inline void interpolate_tile(const double* __restrict st,
                                                    const double* __restrict rf,
                                                    const double* __restrict w,
                                                    const double* __restrict exact,
                                                    double* __restrict dst, std::size_t n) {
  for (std::size_t j = 0; j < n; ++j) {
    const double rx = rf[4 * j], ry = rf[4 * j + 1], rz = rf[4 * j + 2], rw = rf[4 * j + 3];
    double ax = 0.0, ay = 0.0, az = 0.0, aw = 0.0;
    for (std::size_t m = 0; m < 4; ++m) {
      const double* q = st + 16 * j + 4 * m;
      const double dot = q[0] * rx + q[1] * ry + q[2] * rz + q[3] * rw;
      const double c = dot < 0.0 ? -w[4 * j + m] : w[4 * j + m];
      ax += c * q[0];
      ay += c * q[1];
      az += c * q[2];
      aw += c * q[3];
    }
    const double inv = 1.0 / __builtin_sqrt(ax * ax + ay * ay + az * az + aw * aw);
    const bool keep = exact[j] != 0.0;
    dst[4 * j] = keep ? rx : ax * inv;
    dst[4 * j + 1] = keep ? ry : ay * inv;
    dst[4 * j + 2] = keep ? rz : az * inv;
    dst[4 * j + 3] = keep ? rw : aw * inv;
  }
}

[[gnu::always_inline]] inline void interpolate_rotations_kernel(
    const double* src, std::size_t stride, const int64_t* ref, const int64_t* s0, const double* w,
    const double* exact, double* dst, std::size_t n) {
  // Unchanged timing: every frame is a source frame, in order, so the rotations are copied.
  bool copy = true;
  for (std::size_t j = 0; j < n && copy; ++j)
    copy = exact[j] != 0.0 && ref[j] == ref[0] + static_cast<int64_t>(j);
  if (copy) {
    for (std::size_t j = 0; j < n; ++j)
      std::memcpy(dst + 4 * j, src + static_cast<std::size_t>(ref[j]) * stride, 4 * sizeof(double));
    return;
  }
  constexpr std::size_t T = kInterpolationTile;
  double st[16 * T], rf[4 * T];
  for (std::size_t j0 = 0; j0 < n; j0 += T) {
    const std::size_t m = std::min(T, n - j0);
    for (std::size_t j = 0; j < m; ++j) {
      std::memcpy(rf + 4 * j, src + static_cast<std::size_t>(ref[j0 + j]) * stride,
                  4 * sizeof(double));
      const double* q = src + static_cast<std::size_t>(s0[j0 + j]) * stride;
      if (stride == 4) {
        std::memcpy(st + 16 * j, q, 16 * sizeof(double));
      } else {
        for (std::size_t k = 0; k < 4; ++k)
          std::memcpy(st + 16 * j + 4 * k, q + k * stride, 4 * sizeof(double));
      }
    }
    interpolate_tile(st, rf, w + 4 * j0, exact + j0, dst + 4 * j0, m);
  }
}
IMUKIT_ISA_VARIANTS(void, interpolate_rotations, interpolate_rotations_kernel,
                    (const double* src, std::size_t stride, const int64_t* ref, const int64_t* s0,
                     const double* w, const double* exact, double* dst, std::size_t n),
                    (src, stride, ref, s0, w, exact, dst, n))

// A sensor's signals from its carriers' simulated blocks (x y z per sample): the specific force
// at its position, f0 + sum_k p_k (f_k - f0) (affine in the position; force_along[k] null where
// p_k = 0), and the angular rate, both turned into the sensor's axes, plus the drawn biases and
// white noise (6 standard normals per sample, scaled by sigma) when noise is given.
struct SensorSignalArgs {
  std::size_t n = 0;
  const double* force = nullptr;
  const double* force_along[3] = {};
  double offset[3] = {};
  const double* rate = nullptr;
  double R_sensor_joint[9] = {};  // row-major
  const double* noise = nullptr;
  double bias[6] = {};  // accelerometer, gyroscope
  double sigma[2] = {};
  double* f = nullptr;
  double* w = nullptr;
};

[[gnu::always_inline]] inline void sensor_signal_kernel(const SensorSignalArgs& a) {
  const double* M = a.R_sensor_joint;
  const double* __restrict f0 = a.force;
  const double* __restrict rate = a.rate;
  double* __restrict f = a.f;
  double* __restrict w = a.w;
  for (std::size_t i = 0; i < 3 * a.n; ++i) f[i] = f0[i];
  for (int k = 0; k < 3; ++k) {
    const double* __restrict fk = a.force_along[k];
    if (fk == nullptr) continue;
    for (std::size_t i = 0; i < 3 * a.n; ++i) f[i] += a.offset[k] * (fk[i] - f0[i]);
  }
  for (std::size_t i = 0; i < a.n; ++i) {
    const double x = f[3 * i], y = f[3 * i + 1], z = f[3 * i + 2];
    const double u = rate[3 * i], v = rate[3 * i + 1], t = rate[3 * i + 2];
    for (int r = 0; r < 3; ++r) {
      f[3 * i + r] = (M[3 * r] * x + M[3 * r + 1] * y) + M[3 * r + 2] * z;
      w[3 * i + r] = (M[3 * r] * u + M[3 * r + 1] * v) + M[3 * r + 2] * t;
    }
  }
  if (a.noise == nullptr) return;
  const double* __restrict nz = a.noise;
  for (std::size_t i = 0; i < a.n; ++i) {
    for (int k = 0; k < 3; ++k) {
      f[3 * i + k] += a.bias[k] + a.sigma[0] * nz[6 * i + k];
      w[3 * i + k] += a.bias[3 + k] + a.sigma[1] * nz[6 * i + 3 + k];
    }
  }
}
IMUKIT_ISA_VARIANTS(void, sensor_signal, sensor_signal_kernel, (const SensorSignalArgs& a), (a))

// n samples of one sensor (f, w: x y z per sample) into its 6 channels of a batch whose rows are
// `stride` values apart: doubles into out_d, or floats into out_f.
[[gnu::always_inline]] inline void write_channels_kernel(const double* __restrict f,
                                                         const double* __restrict w, std::size_t n,
                                                         std::size_t stride,
                                                         double* __restrict out_d,
                                                         float* __restrict out_f) {
  if (out_d != nullptr) {
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t k = 0; k < 3; ++k) {
        out_d[i * stride + k] = f[3 * i + k];
        out_d[i * stride + 3 + k] = w[3 * i + k];
      }
    }
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < 3; ++k) {
      out_f[i * stride + k] = static_cast<float>(f[3 * i + k]);
      out_f[i * stride + 3 + k] = static_cast<float>(w[3 * i + k]);
    }
  }
}
IMUKIT_ISA_VARIANTS(void, write_channels, write_channels_kernel,
                    (const double* f, const double* w, std::size_t n, std::size_t stride,
                     double* out_d, float* out_f),
                    (f, w, n, stride, out_d, out_f))

// 5b. The kernel's arguments for sensor s at placement pl from its carriers' simulated blocks,
// its signals going to f and w (sized here); hardware errors are added by the caller.
SensorSignalArgs carrier_signals(const Carriers& carriers,
                                 const std::vector<sim::SensorBlock>& blocks, std::size_t s,
                                 const sim::Placement& pl, std::size_t T, Eigen::Matrix3Xd& f,
                                 Eigen::Matrix3Xd& w) {
  const std::size_t cidx = carriers.fixed ? s : carriers.index.at(pl.joint);
  const sim::SensorBlock& b0 = blocks[carriers.fixed ? s : 4 * cidx];
  const Matrix3d R_sensor_joint = pl.q_joint_sensor.normalized().toRotationMatrix().transpose();
  SensorSignalArgs sig;
  sig.n = T;
  sig.force = b0.specific_force.data();
  sig.rate = b0.angular_rate.data();
  for (int k = 0; k < 3 && !carriers.fixed; ++k) {
    const double pk = pl.p_joint_sensor[k];
    if (pk == 0.0) continue;
    sig.offset[k] = pk;
    sig.force_along[k] = blocks[4 * cidx + 1 + static_cast<std::size_t>(k)].specific_force.data();
  }
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) sig.R_sensor_joint[3 * r + k] = R_sensor_joint(r, k);
  f.resize(3, static_cast<Eigen::Index>(T));
  w.resize(3, static_cast<Eigen::Index>(T));
  sig.f = f.data();
  sig.w = w.data();
  return sig;
}

}  // namespace

struct PpdaAugmenter::Impl {
  sim::Body body;
  std::shared_ptr<sim::MotionSource> motion;
  const sim::Motion* direct_motion = nullptr;  // `motion` when it is in memory (read in place)
  int64_t frames = 0;
  double motion_rate = 0.0;
  double rate = 0.0;
  // Frames of the window's motion beyond its samples on each side: kMargin, plus the filter's
  // reach where the simulator anti-aliases (so an identity window's samples are the plain
  // simulation's, edges included).
  int64_t margin = kMargin;
  int64_t samples = 0;
  std::vector<sim::SceneSensor> sensors;
  std::vector<std::string> names;
  PpdaOptions options;
  sim::SimulationOptions sim_options;
  std::vector<int> plan_joints_all;  // joints on the chains of every joint a sensor may use

  // Per-thread state.
  struct Worker {
    std::unique_ptr<sim::Simulator> simulator;
    // The window's motion, by frame count: interior windows all have the same count, identity
    // windows at the motion's ends are cut short there (and off-grid starts may need one more).
    std::map<int64_t, sim::Motion> window_motions;
    sim::MotionChunk chunk;
    std::vector<sim::SensorBlock> blocks;
    std::vector<TimeNs> times;
    std::vector<double> u, x;  // per window frame: output position, source frame position
    std::vector<double> scale;
    std::vector<double> half_angle, axis_norm, axis_cosine;  // scale_angles' scratch
    std::vector<int64_t> ref, s0;  // per window frame (interpolate_rotations)
    std::vector<double> weights, exact;
    Eigen::Matrix3Xd f, w;      // one sensor's signals
    std::vector<double> noise;  // its white-noise draws
    // The amplitude spline is linear in its knot values: column m holds the curve through the
    // unit knot vector e_m at the window frames, so a joint's curve is one matrix-vector product.
    int basis_knots = -1;
    std::vector<double> basis_u;  // the frame positions the basis was evaluated at
    Eigen::MatrixXd basis;        // frames x (K + 2)
  };

  // Frames of a window's motion at speed 1 with `each_side` frames beyond its samples.
  int64_t window_frames(int64_t each_side) const {
    const double span = static_cast<double>(options.window - 1) / rate * motion_rate;
    return static_cast<int64_t>(std::ceil(span - 1e-9)) + 1 + 2 * each_side;
  }

  void simulate_window(const SubPolicy& sub, const Carriers& carriers, int64_t start, Rng& rng,
                       Worker& wk, double* out_d, float* out_f, PpdaWindowLog* log) const;
  // simulate_window's phases.
  struct WindowTiming {
    int64_t first_frame = 0;  // identity speed: the window's first source frame
    int64_t F = 0;            // frames of the window's motion
    int64_t lead = 0;         // other speeds: its frames before the first sample's time
  };
  WindowTiming retime(const SpeedOp& speed, int64_t start, Rng& rng, Worker& wk,
                      PpdaWindowLog* log) const;
  sim::Motion& window_motion(Worker& wk, int64_t F) const;
  void warp_amplitude(const AmplitudeOp& amplitude, Worker& wk, sim::Motion& wm, int64_t F,
                      Rng& rng, PpdaWindowLog* log) const;
  void simulate_carriers(const SpeedOp& speed, int64_t start, const WindowTiming& timing,
                         Worker& wk, sim::Motion& wm) const;
  sim::Placement sensor_placement(std::size_t s, const PlacementOp& op,
                                  const SubjectPlacements* subject, Rng& rng) const;
  void apply_hardware(const HardwareOp& hw, std::size_t s, SensorSignalArgs& sig, Worker& wk,
                      Rng& rng, PpdaWindowLog* log) const;

  // Throws imukit::Error unless a window starting at `start` lies inside the motion's samples.
  void check_start(int64_t start) const;
  // The carriers a sub-policy needs (make_fixed_carriers when it keeps every sensor's position).
  Carriers carriers_for(const SubPolicy& sub) const;
};

PpdaAugmenter::PpdaAugmenter(const sim::Scene& scene, PpdaOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (!scene.motion) throw Error("augment: the scene has no motion");
  m.body = scene.body;
  m.motion = scene.motion;
  m.direct_motion = dynamic_cast<const sim::Motion*>(scene.motion.get());
  m.options = options;
  if (options.window < 2) throw Error("augment: a window needs at least 2 samples");
  const std::optional<int64_t> n = scene.frames ? scene.frames : scene.motion->frame_count();
  if (!n) throw Error("augment: an endless motion needs the scene's frame count");
  m.frames = std::min<int64_t>(*n, scene.motion->frame_count().value_or(*n));
  sim::require_simulatable(*scene.motion, "augment");
  m.motion_rate = scene.motion->rate_hz();
  m.sim_options = scene.options;
  m.sim_options.method = options.method;
  m.rate = sim::sample_rate_hz(scene.options, *scene.motion);
  m.sensors = scene.sensors;
  if (m.sensors.empty()) throw Error("augment: the scene has no sensors");
  std::vector<sim::SensorSpec> specs;
  for (const sim::SceneSensor& s : m.sensors) {
    m.names.push_back(s.spec.name);
    specs.push_back(s.spec);
  }
  const sim::Simulator probe(m.body, specs, m.sim_options);
  m.samples = probe.sample_count(*m.motion, m.frames);
  if (probe.anti_aliases(*m.motion)) {
    m.margin += static_cast<int64_t>(
        std::ceil(sim::AntiAliasFilter::half_width_periods * m.motion_rate / m.rate));
  }
  // In unsigned terms: int64_t(window) of a window above 2^63 was negative and passed (found in
  // review, 2026-11-27). sample_count is never negative.
  if (options.window > static_cast<uint64_t>(m.samples)) {
    throw Error(
        fmt::format("augment: the motion has {} samples at {:g} Hz, fewer than a window of {}",
                    m.samples, m.rate, options.window));
  }
  // The filter's reach beyond kMargin is cut at the motion's ends (retime): not asked for here
  // (review, 2026-11-27: the bundled 2 s walk took windows of 71 samples at 50 Hz, not 96).
  if (m.frames < m.window_frames(kMargin) + 4) {
    throw Error(
        fmt::format("augment: the motion ({} frames) is too short for a window of {} "
                    "samples with its margins",
                    m.frames, options.window));
  }
}

PpdaAugmenter::~PpdaAugmenter() = default;
PpdaAugmenter::PpdaAugmenter(PpdaAugmenter&&) noexcept = default;
PpdaAugmenter& PpdaAugmenter::operator=(PpdaAugmenter&&) noexcept = default;

std::size_t PpdaAugmenter::window() const { return impl_->options.window; }
std::size_t PpdaAugmenter::channels() const { return 6 * impl_->sensors.size(); }
ChannelLayout PpdaAugmenter::layout() const { return ChannelLayout::imu(impl_->names); }
std::vector<std::string> PpdaAugmenter::sensor_names() const { return impl_->names; }
double PpdaAugmenter::rate_hz() const { return impl_->rate; }
int64_t PpdaAugmenter::sample_count() const { return impl_->samples; }

std::vector<int64_t> PpdaAugmenter::window_starts(std::size_t stride) const {
  if (stride == 0) throw Error("augment: the stride must be at least 1 sample");
  std::vector<int64_t> starts;
  const auto w = static_cast<int64_t>(impl_->options.window);
  for (int64_t s = 0; s + w <= impl_->samples; s += static_cast<int64_t>(stride))
    starts.push_back(s);
  return starts;
}

// One window, phase after phase; the draws come in this order: speed, amplitude (joint after
// joint), the subject swap, then per sensor its placement and its hardware.
void PpdaAugmenter::Impl::simulate_window(const SubPolicy& sub, const Carriers& carriers,
                                          int64_t start, Rng& rng, Worker& wk, double* out_d,
                                          float* out_f, PpdaWindowLog* log) const {
  const std::size_t T = options.window;
  if (log != nullptr) *log = PpdaWindowLog{};
  if (log != nullptr) log->start = start;
  const WindowTiming timing = retime(sub.speed, start, rng, wk, log);
  sim::Motion& wm = window_motion(wk, timing.F);
  warp_amplitude(sub.amplitude, wk, wm, timing.F, rng, log);
  simulate_carriers(sub.speed, start, timing, wk, wm);

  // 5. Placement per sensor, then hardware, then the output (ax ay az gx gy gz per sensor).
  const std::size_t S = sensors.size();
  const std::size_t C = 6 * S;
  const SubjectPlacements* subject = nullptr;  // one subject's placements for the whole window
  if (sub.placement.enabled && !sub.placement.swap_subjects.empty())
    subject = &sub.placement.swap_subjects[rng.uniform_index(sub.placement.swap_subjects.size())];
  for (std::size_t s = 0; s < S; ++s) {
    const sim::Placement pl = sensor_placement(s, sub.placement, subject, rng);
    if (log != nullptr) log->placements.push_back(pl);
    SensorSignalArgs sig = carrier_signals(carriers, wk.blocks, s, pl, T, wk.f, wk.w);
    apply_hardware(sub.hardware, s, sig, wk, rng, log);
    write_channels(wk.f.data(), wk.w.data(), T, C, out_d != nullptr ? out_d + 6 * s : nullptr,
                   out_f != nullptr ? out_f + 6 * s : nullptr);
  }
}

// 1. Speed: the source frame position x (wk.x) of each window frame and its output position u
// (wk.u) in samples from the window's first sample.
PpdaAugmenter::Impl::WindowTiming PpdaAugmenter::Impl::retime(const SpeedOp& speed, int64_t start,
                                                              Rng& rng, Worker& wk,
                                                              PpdaWindowLog* log) const {
  const std::size_t T = options.window;
  const double dt = 1.0 / rate;
  const double h = 1.0 / motion_rate;
  int64_t F = window_frames(margin);
  const TimeNs t_start_ns = sample_time(0, start, rate);
  const double t_start = static_cast<double>(t_start_ns) * 1e-9;
  // Identity: the window's motion is the source's own frames first_frame .. first_frame + F - 1,
  // the samples' frames plus the margin each side, cut at the motion's ends -- never moved -- so
  // the simulator sees the same frames around every sample, and the same one-sided stencils and end
  // conditions at the true ends, as when it simulates the whole motion.
  int64_t first_frame = 0;
  if (speed.method == WarpMethod::identity) {
    const TimeNs t_end_ns = sample_time(0, start + static_cast<int64_t>(T) - 1, rate);
    int64_t f1 = sim::Simulator::frame_at(t_end_ns, motion_rate);
    if (sample_time(0, f1, motion_rate) < t_end_ns) ++f1;
    first_frame = std::max<int64_t>(0, sim::Simulator::frame_at(t_start_ns, motion_rate) - margin);
    F = std::min<int64_t>(frames - 1, f1 + margin) - first_frame + 1;
  }
  wk.u.resize(static_cast<std::size_t>(F));
  wk.x.resize(static_cast<std::size_t>(F));
  for (int64_t j = 0; j < F; ++j)
    wk.u[static_cast<std::size_t>(j)] = static_cast<double>(j - margin) * h / dt;
  switch (speed.method) {
    case WarpMethod::identity: {
      const TimeNs t_first = sample_time(0, first_frame, motion_rate);
      for (int64_t j = 0; j < F; ++j) {
        const auto k = static_cast<std::size_t>(j);
        wk.x[k] = static_cast<double>(first_frame + j);
        wk.u[k] =
            (static_cast<double>(t_first - t_start_ns) * 1e-9 + static_cast<double>(j) * h) / dt;
      }
      break;
    }
    case WarpMethod::scaling: {
      const double b = rng.uniform_in(speed.lo, speed.hi);
      if (log != nullptr) log->speed_scale = b;
      const double c = 0.5 * static_cast<double>(T - 1);
      for (int64_t j = 0; j < F; ++j) {
        const auto k = static_cast<std::size_t>(j);
        wk.x[k] = (t_start + (c + b * (wk.u[k] - c)) * dt) * motion_rate;
      }
      break;
    }
    case WarpMethod::warping: {
      std::vector<double> uu(static_cast<std::size_t>(speed.knots + 1));
      for (double& v : uu) v = rng.uniform();
      if (log != nullptr) log->speed_u = uu;
      const Interpolant warp = time_warp_interpolant(uu, speed.ratio, T);
      Eigen::Map<Eigen::RowVectorXd> xm(wk.x.data(), F);
      warp.evaluate(wk.u, xm);
      // The margins beyond the window's samples continue at the end speeds (the tangent lines):
      // the end interval's cubic extrapolated over them is fine for a few knots, but with
      // hundreds of knots an interval is a fraction of a sample and its cubic, read 3 frames
      // out, ran off by hundreds of frames (accelerations of 600 m/s^2, or "needs N frames").
      // The warp maps its first and last anchor to themselves (0 and T - 1).
      const double first = warp.x().front(), last_anchor = warp.x().back();
      const Eigen::MatrixXd& slope = warp.knot_slopes();
      for (int64_t j = 0; j < F; ++j) {
        const double u = wk.u[static_cast<std::size_t>(j)];
        if (u < first) xm[j] = first + slope(0, 0) * (u - first);
        if (u > last_anchor) xm[j] = last_anchor + slope(0, slope.cols() - 1) * (u - last_anchor);
      }
      for (double& v : wk.x) v = (t_start + v * dt) * motion_rate;
      break;
    }
  }
  // Keep a re-timed span inside the motion (a speed-changed window near an end slides inwards;
  // identity spans are inside by construction): the samples' frames and kMargin each side. The
  // anti-aliasing filter's reach beyond them is cut where it passes an end of the motion (the
  // simulator holds the window's end values there, as at the motion's own ends), so a window
  // that fits without it is never refused for it.
  const double last = static_cast<double>(frames - 1);
  const auto reach = static_cast<std::ptrdiff_t>(F > 2 * (margin - kMargin) ? margin - kMargin : 0);
  // The extremes, not the ends: a warp's margins need not be monotonic.
  const auto [x_min, x_max] = std::minmax_element(wk.x.begin() + reach, wk.x.end() - reach);
  const double x0 = *x_min, x1 = *x_max;
  if (x1 - x0 > last) {
    throw MotionTooShort(
        fmt::format("augment: a window of {} samples at this speed needs {:.0f} frames; "
                    "the motion has {}",
                    T, x1 - x0 + 1, frames));
  }
  double shift = 0.0;
  if (x0 < 0.0) shift = -x0;
  if (x1 > last) shift = last - x1;
  if (shift != 0.0)
    for (double& v : wk.x) v += shift;
  std::ptrdiff_t cut_front = 0, cut_back = 0;
  while (cut_front < reach && wk.x[static_cast<std::size_t>(cut_front)] < 0.0) ++cut_front;
  while (cut_back < reach && wk.x[wk.x.size() - 1 - static_cast<std::size_t>(cut_back)] > last)
    ++cut_back;
  for (std::vector<double>* v : {&wk.x, &wk.u}) {
    v->erase(v->end() - cut_back, v->end());
    v->erase(v->begin(), v->begin() + cut_front);
  }
  for (double& v : wk.x) v = std::clamp(v, 0.0, last);
  return {first_frame, F - cut_front - cut_back, margin - cut_front};
}

// 2. The window's motion: plan joints at the source positions, 4-point Lagrange interpolation
// of sign-aligned quaternion components, renormalised (O(h^4) from the geodesic cubic at
// motion rates) -- exact copies where a position falls on a frame.
sim::Motion& PpdaAugmenter::Impl::window_motion(Worker& wk, int64_t F) const {
  const sim::SimulationPlan& plan = wk.simulator->plan();
  const std::size_t J = plan.joints.size();
  const auto [x_min, x_max] = std::minmax_element(wk.x.begin(), wk.x.end());
  auto lo = std::max<int64_t>(0, static_cast<int64_t>(std::floor(*x_min)) - 2);
  auto hi = std::min<int64_t>(frames, static_cast<int64_t>(std::ceil(*x_max)) + 3);
  if (hi - lo < 4) {
    // A window shorter than a frame (sensor rate above the motion's) at either end of the
    // motion: widen to the 4 frames the stencil needs (the constructor asks for more frames).
    lo = std::max<int64_t>(0, hi - 4);
    hi = std::min<int64_t>(frames, lo + 4);
  }
  assert(hi - lo >= 4);
  // Per window frame: the frame at or before x (its rotation is the sign reference), the
  // stencil's first frame, both from lo, the four weights, and 1 where x is a frame itself.
  wk.ref.resize(static_cast<std::size_t>(F));
  wk.s0.resize(static_cast<std::size_t>(F));
  wk.weights.resize(4 * static_cast<std::size_t>(F));
  wk.exact.resize(static_cast<std::size_t>(F));
  for (int64_t j = 0; j < F; ++j) {
    const auto u = static_cast<std::size_t>(j);
    const double x = wk.x[u];
    const double fl = std::floor(x);
    const auto i = static_cast<int64_t>(fl);
    const int64_t s0 = std::clamp<int64_t>(i - 1, lo, hi - 4);
    const std::array<double, 4> w = lagrange4(x, s0);
    wk.ref[u] = i - lo;
    wk.s0[u] = s0 - lo;
    std::copy(w.begin(), w.end(), wk.weights.begin() + static_cast<std::ptrdiff_t>(4 * u));
    wk.exact[u] = x == fl ? 1.0 : 0.0;
  }
  // The source in place when it is an in-memory Motion (joint by joint), else through a chunk.
  std::size_t stride = 4;
  const double* translation = nullptr;
  if (direct_motion != nullptr) {
    translation = direct_motion->translation_data() + 3 * lo;
    // Every joint's span of the motion, requested now: a window is somewhere else in a motion
    // larger than the caches, and waiting for each line as the interpolation reaches it was a
    // third of its time.
    const std::size_t bytes = static_cast<std::size_t>(hi - lo) * 4 * sizeof(double);
    for (std::size_t k = 0; k < J; ++k) {
      const auto* p = reinterpret_cast<const char*>(
          direct_motion->rotation_data(static_cast<std::size_t>(plan.joints[k])) + lo);
      for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(p + b, 0, 2);
    }
  } else {
    motion->read(lo, hi - lo, plan.joints, wk.chunk);
    stride = 4 * J;
    translation = wk.chunk.root_translation.data();
  }
  auto slot = wk.window_motions.find(F);
  if (slot == wk.window_motions.end())
    slot = wk.window_motions.try_emplace(F, motion_rate, body.size(), F).first;
  sim::Motion& wm = slot->second;
  for (std::size_t k = 0; k < J; ++k) {
    const auto joint = static_cast<std::size_t>(plan.joints[k]);
    const double* src = direct_motion != nullptr
                            ? direct_motion->rotation_data(joint)[lo].coeffs().data()
                            : wk.chunk.rotations[k].coeffs().data();
    interpolate_rotations(src, stride, wk.ref.data(), wk.s0.data(), wk.weights.data(),
                          wk.exact.data(), wm.rotation(0, joint).coeffs().data(),
                          static_cast<std::size_t>(F));
  }
  for (int64_t j = 0; j < F; ++j) {
    const auto u = static_cast<std::size_t>(j);
    const auto tr = [&](int64_t f) { return Eigen::Map<const Vector3d>(translation + 3 * f); };
    if (wk.exact[u] != 0.0) {
      wm.root_translation(j) = tr(wk.ref[u]);
      continue;
    }
    Vector3d p = Vector3d::Zero();
    for (int64_t m = 0; m < 4; ++m)
      p += wk.weights[4 * u + static_cast<std::size_t>(m)] * tr(wk.s0[u] + m);
    wm.root_translation(j) = p;
  }
  return wm;
}

// 3. Amplitude: q' = exp(s log q) for the chosen joints' relative rotations.
void PpdaAugmenter::Impl::warp_amplitude(const AmplitudeOp& amplitude, Worker& wk, sim::Motion& wm,
                                         int64_t F, Rng& rng, PpdaWindowLog* log) const {
  if (amplitude.method == WarpMethod::identity) return;
  const std::size_t T = options.window;
  const sim::SimulationPlan& plan = wk.simulator->plan();
  const std::size_t J = plan.joints.size();
  std::vector<int> chosen;
  if (amplitude.joints.empty()) {
    for (std::size_t k = 0; k < J; ++k)
      if (body.joint(static_cast<std::size_t>(plan.joints[k])).parent >= 0)
        chosen.push_back(plan.joints[k]);
  } else {
    for (const std::string& name : amplitude.joints) {
      const int b = body.index_of(name);
      if (std::find(plan.joints.begin(), plan.joints.end(), b) != plan.joints.end())
        chosen.push_back(b);
    }
  }
  wk.scale.resize(static_cast<std::size_t>(F));
  wk.half_angle.resize(static_cast<std::size_t>(F));
  wk.axis_norm.resize(static_cast<std::size_t>(F));
  wk.axis_cosine.resize(static_cast<std::size_t>(F));
  for (int joint : chosen) {
    if (amplitude.method == WarpMethod::scaling) {
      const double a = rng.normal(1.0, amplitude.sigma);
      if (log != nullptr) log->amplitude.push_back(a);
      std::fill(wk.scale.begin(), wk.scale.end(), a);
    } else {
      const int nk = amplitude.knots + 2;
      if (wk.basis_knots != amplitude.knots || wk.basis_u != wk.u) {
        wk.basis.resize(F, nk);
        std::vector<double> e(static_cast<std::size_t>(nk));
        for (int m = 0; m < nk; ++m) {
          std::fill(e.begin(), e.end(), 0.0);
          e[static_cast<std::size_t>(m)] = 1.0;
          const Interpolant curve = warp_curve_interpolant(e, T);
          Eigen::RowVectorXd col(F);
          curve.evaluate(wk.u, col);
          wk.basis.col(m) = col.transpose();
        }
        wk.basis_knots = amplitude.knots;
        wk.basis_u = wk.u;
      }
      Eigen::VectorXd kv(nk);
      for (int m = 0; m < nk; ++m) kv[m] = rng.normal(1.0, amplitude.sigma);
      if (log != nullptr) log->amplitude.insert(log->amplitude.end(), kv.begin(), kv.end());
      Eigen::Map<Eigen::VectorXd>(wk.scale.data(), F) = wk.basis * kv;
    }
    scale_angles(wm.rotation(0, static_cast<std::size_t>(joint)).coeffs().data(), wk.scale.data(),
                 wk.half_angle.data(), wk.axis_norm.data(), wk.axis_cosine.data(),
                 static_cast<std::size_t>(F));
  }
}

// 4. Simulate the carriers at the output sample times.
void PpdaAugmenter::Impl::simulate_carriers(const SpeedOp& speed, int64_t start,
                                            const WindowTiming& timing, Worker& wk,
                                            sim::Motion& wm) const {
  const std::size_t T = options.window;
  const double dt = 1.0 / rate;
  const double h = 1.0 / motion_rate;
  wk.times.resize(T);
  if (speed.method == WarpMethod::identity) {
    // The plain simulation's sample times, counted from the window's first frame.
    const TimeNs t_first = sample_time(0, timing.first_frame, motion_rate);
    for (std::size_t i = 0; i < T; ++i)
      wk.times[i] = sample_time(0, start + static_cast<int64_t>(i), rate) - t_first;
  } else {
    for (std::size_t i = 0; i < T; ++i) {
      wk.times[i] = static_cast<TimeNs>(
          std::llround((static_cast<double>(i) * dt + static_cast<double>(timing.lead) * h) * 1e9));
    }
  }
  wk.simulator->evaluate(wm, wk.times, wk.blocks);
}

// 5a. Sensor s's placement in this window: the subject's (when one was drawn and has the
// sensor), then varied by the sub-policy (sim::vary_placement).
sim::Placement PpdaAugmenter::Impl::sensor_placement(std::size_t s, const PlacementOp& op,
                                                     const SubjectPlacements* subject,
                                                     Rng& rng) const {
  sim::Placement pl = sensors[s].spec.placement;
  std::string preset = sensors[s].preset;
  if (subject != nullptr) {
    for (const sim::PlacementPreset& p : subject->sensors)
      if (p.name == sensors[s].spec.name) pl = sim::resolve_preset(p, body);
  }
  if (op.enabled) pl = sim::vary_placement(pl, preset, op, body, rng);
  return pl;
}

// 5c. The sensor's signals with its hardware errors: ranges draws its biases and white noise
// into sig (added in sensor_signal's pass); profile draws a model of the device and runs its
// error generator on the signals afterwards, its own range and resolution included. Otherwise
// the scene sensor's range and resolution bound the readings: its noise is the sub-policy's
// choice, but a device cannot read beyond its full scale nor between its LSBs (windows of a
// scene with a 20 m/s^2 accelerometer read 191 until review, 2026-11-27).
void PpdaAugmenter::Impl::apply_hardware(const HardwareOp& hw, std::size_t s, SensorSignalArgs& sig,
                                         Worker& wk, Rng& rng, PpdaWindowLog* log) const {
  const std::size_t T = sig.n;
  if (hw.kind == HardwareOp::Kind::ranges) {
    Vector3d ba, bg;
    for (int k = 0; k < 3; ++k) ba[k] = rng.uniform_in(-hw.accel_bias, hw.accel_bias);
    for (int k = 0; k < 3; ++k) bg[k] = rng.uniform_in(-hw.gyro_bias, hw.gyro_bias);
    if (log != nullptr) {
      log->accel_bias.push_back(ba);
      log->gyro_bias.push_back(bg);
    }
    wk.noise.resize(6 * T);
    rng.fill_normal(wk.noise);
    sig.noise = wk.noise.data();
    for (int k = 0; k < 3; ++k) sig.bias[k] = ba[k], sig.bias[3 + k] = bg[k];
    sig.sigma[0] = hw.accel_noise;
    sig.sigma[1] = hw.gyro_noise;
  }
  sensor_signal(sig);
  Eigen::Matrix3Xd& f = wk.f;
  Eigen::Matrix3Xd& w = wk.w;
  if (hw.kind == HardwareOp::Kind::profile) {
    HardwareModel model = draw_hardware_model(
        *hw.profile, HardwareSpread{hw.scale_spread, hw.misalignment_spread_rad}, rng);
    for (TriadModel* t : {static_cast<TriadModel*>(&model.accelerometer),
                          static_cast<TriadModel*>(&model.gyroscope)}) {
      // A low-pass at or beyond the dataset's Nyquist frequency changes nothing at this rate.
      if (t->bandwidth_hz >= 0.5 * rate) t->bandwidth_hz = 0.0;
      t->rate_hz = 0.0;
    }
    ImuErrorGenerator gen(model, rate, rng);
    const Eigen::Matrix3Xd truth = f;
    gen.apply_gyroscope(w, truth);
    gen.apply_accelerometer(f);
  } else if (const std::optional<HardwareModel>& device = sensors[s].hardware) {
    saturate_and_quantise(std::span<double>(f.data(), static_cast<std::size_t>(f.size())),
                          device->accelerometer.range, device->accelerometer.resolution);
    saturate_and_quantise(std::span<double>(w.data(), static_cast<std::size_t>(w.size())),
                          device->gyroscope.range, device->gyroscope.resolution);
  }
}

namespace {

Carriers make_fixed_carriers(const std::vector<sim::SceneSensor>& sensors) {
  Carriers c;
  c.fixed = true;
  for (const sim::SceneSensor& ss : sensors) {
    sim::SensorSpec s;
    s.name = ss.spec.name;
    s.placement.joint = ss.spec.placement.joint;
    s.placement.p_joint_sensor = ss.spec.placement.p_joint_sensor;
    c.specs.push_back(s);
  }
  return c;
}

// The joints a sub-policy may put a sensor on.
std::set<int> carrier_joints(const sim::Body& body, const std::vector<sim::SceneSensor>& sensors,
                             const SubPolicy& sub) {
  std::set<int> joints;
  for (const sim::SceneSensor& s : sensors) joints.insert(s.spec.placement.joint);
  if (sub.placement.enabled) {
    for (const std::string& p : sub.placement.swap_presets)
      joints.insert(sim::preset_placement(p, body).joint);
    for (const SubjectPlacements& subject : sub.placement.swap_subjects) {
      for (const sim::PlacementPreset& p : subject.sensors) {
        try {
          joints.insert(sim::resolve_preset(p, body).joint);
        } catch (const Error& e) {
          throw Error("augment: subject " + subject.scene_path + ": " + e.what());
        }
      }
    }
  }
  return joints;
}

}  // namespace

void PpdaAugmenter::Impl::check_start(int64_t start) const {
  const auto T = static_cast<int64_t>(options.window);
  if (start < 0 || start + T > samples)
    throw Error(fmt::format("augment: window start {} outside 0 .. {}", start, samples - T));
}

int PpdaAugmenter::max_amplitude_knots(std::size_t window) {
  if (window < 1) return 0;
  return std::max(0, static_cast<int>((window - 1) / kMinAmplitudeKnotSpacing) - 1);
}

void PpdaAugmenter::check(const SubPolicy& sub) const {
  const std::size_t T = impl_->options.window;
  const AmplitudeOp& a = sub.amplitude;
  // A joint the body does not have was found only when its sub-policy was first drawn, which
  // could end a long run late (review, 2026-11-27).
  for (const std::string& name : a.joints) {
    try {
      (void)impl_->body.index_of(name);
    } catch (const Error& e) {
      throw Error(
          fmt::format("augment: sub-policy {}: amplitude joints: {}", sub.describe(), e.what()));
    }
  }
  if (a.method == WarpMethod::warping && a.knots > max_amplitude_knots(T)) {
    throw Error(fmt::format(
        "augment: sub-policy {}: amplitude warping with {} knots on windows of {} samples puts "
        "them {:.3g} samples apart; at most {} knots ({} samples apart or more): a joint angle "
        "scaled faster than that is no human movement",
        sub.describe(), a.knots, T, static_cast<double>(T - 1) / (a.knots + 1),
        max_amplitude_knots(T), kMinAmplitudeKnotSpacing));
  }
}

Carriers PpdaAugmenter::Impl::carriers_for(const SubPolicy& sub) const {
  return sub.placement.keeps_positions() ? make_fixed_carriers(sensors)
                                         : make_carriers(carrier_joints(body, sensors, sub));
}

void PpdaAugmenter::apply(const SubPolicy& sub, std::span<const int64_t> starts, Rng& rng,
                          std::span<float> out, unsigned threads, std::vector<PpdaWindowLog>* log,
                          std::span<uint8_t> too_short) {
  Impl& m = *impl_;
  const std::size_t T = m.options.window, C = channels();
  if (out.size() != starts.size() * T * C) {
    throw Error(fmt::format("augment: output of {} floats for {} windows x {} x {}", out.size(),
                            starts.size(), T, C));
  }
  if (!too_short.empty() && too_short.size() != starts.size()) {
    throw Error(
        fmt::format("augment: {} too-short flags for {} windows", too_short.size(), starts.size()));
  }
  std::fill(too_short.begin(), too_short.end(), uint8_t{0});
  for (int64_t s : starts) m.check_start(s);
  check(sub);
  const Carriers carriers = m.carriers_for(sub);
  const Rng root(rng.next_u64());
  if (log != nullptr) log->assign(starts.size(), PpdaWindowLog{});
  // Window k draws from root.child(k) and writes its own rows: the batch does not depend on the
  // thread count. Each worker keeps its own simulator and scratch, made on its first window.
  const unsigned count = thread_count(threads, starts.size());
  std::vector<std::unique_ptr<Impl::Worker>> workers(count);
  parallel_for(starts.size(), count, [&](std::size_t k, unsigned w) {
    std::unique_ptr<Impl::Worker>& wk = workers[w];
    if (!wk) {
      wk = std::make_unique<Impl::Worker>();
      wk->simulator = std::make_unique<sim::Simulator>(m.body, carriers.specs, m.sim_options);
    }
    Rng r = root.child(k);
    try {
      m.simulate_window(sub, carriers, starts[k], r, *wk, nullptr, out.data() + k * T * C,
                        log != nullptr ? &(*log)[k] : nullptr);
    } catch (const MotionTooShort&) {
      // Its rows are untouched: retime() throws before the window is simulated.
      if (too_short.empty()) throw;
      too_short[k] = 1;
    }
  });
}

void PpdaAugmenter::apply(const Policy& policy, std::size_t sub_policy,
                          std::span<const int64_t> starts, Rng& rng, std::span<float> out,
                          unsigned threads) {
  if (sub_policy >= policy.sub_policies.size()) {
    throw Error(fmt::format("augment: sub-policy {} of a policy with {}", sub_policy,
                            policy.sub_policies.size()));
  }
  apply(policy.sub_policies[sub_policy], starts, rng, out, threads);
}

void PpdaAugmenter::apply_window(const SubPolicy& sub, int64_t start, Rng& rng,
                                 std::span<double> out, PpdaWindowLog* log) {
  Impl& m = *impl_;
  const std::size_t T = m.options.window, C = channels();
  if (out.size() != T * C)
    throw Error(fmt::format("augment: output of {} values for {} x {}", out.size(), T, C));
  m.check_start(start);
  check(sub);
  const Carriers carriers = m.carriers_for(sub);
  Impl::Worker wk;
  wk.simulator = std::make_unique<sim::Simulator>(m.body, carriers.specs, m.sim_options);
  m.simulate_window(sub, carriers, start, rng, wk, out.data(), nullptr, log);
}

}  // namespace imukit::augment
