#include "imukit/hwmodel/calibration.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/core.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/core/sampling.hpp"

namespace imukit::hwmodel {
namespace {

// T K (x - b) with T upper unit-triangular from (a0, a1, a2): [[1,-a0,a1],[0,1,-a2],[0,0,1]]
// (the paper's sign convention), K = diag(s).
template <typename T>
void accel_model(const T* mis, const T* s, const T* b, const T* x, T* out) {
  const T v0 = s[0] * (x[0] - b[0]), v1 = s[1] * (x[1] - b[1]), v2 = s[2] * (x[2] - b[2]);
  out[0] = v0 - mis[0] * v1 + mis[1] * v2;
  out[1] = v1 - mis[2] * v2;
  out[2] = v2;
}

// Gyroscope: unit diagonal with six off-diagonal terms m (row-major order of the off-diagonals).
template <typename T>
void gyro_model(const T* m, const T* s, const T* b, const T* x, T* out) {
  const T v0 = s[0] * (x[0] - b[0]), v1 = s[1] * (x[1] - b[1]), v2 = s[2] * (x[2] - b[2]);
  out[0] = v0 + m[0] * v1 + m[1] * v2;
  out[1] = m[2] * v0 + v1 + m[3] * v2;
  out[2] = m[4] * v0 + m[5] * v1 + v2;
}

struct AccelResidual {
  AccelResidual(const Eigen::Vector3d& mean, double g) : mean_(mean), g2_(g * g) {}
  template <typename T>
  bool operator()(const T* mis, const T* s, const T* b, T* r) const {
    const T x[3] = {T(mean_.x()), T(mean_.y()), T(mean_.z())};
    T a[3];
    accel_model(mis, s, b, x, a);
    // Divided by g so the residual is in m/s^2-like units near the solution.
    r[0] = (T(g2_) - (a[0] * a[0] + a[1] * a[1] + a[2] * a[2])) / T(std::sqrt(g2_));
    return true;
  }
  Eigen::Vector3d mean_;
  double g2_;
};

// Parameters near 1 and 0 whatever the input's units: the raw reading x enters as
// unit * (x - offset) with the starting scale and bias fixed in it, and the fit's scale factors
// `s` multiply that (start 1) and its biases `b` are in SI units (start 0). Fitted on raw counts
// directly (found in review: 32-bit offset-binary counts near 3e9 with scales near 2e-9), the
// solver's relative step test stopped at the starting guess: 1-3 % scale errors, exit 0.
struct GyroResidual {
  GyroResidual(const Eigen::Matrix3Xd* gyro, std::vector<double> dt, int64_t begin,
               const Eigen::Vector3d& u_from, const Eigen::Vector3d& u_to,
               const Eigen::Vector3d& offset, const Eigen::Vector3d& unit)
      : gyro_(gyro),
        dt_(std::move(dt)),
        begin_(begin),
        u_from_(u_from),
        u_to_(u_to),
        offset_(offset),
        unit_(unit) {}
  template <typename T>
  bool operator()(const T* m, const T* s, const T* b, T* r) const {
    // q_from_to: orientation of the sensor at the end relative to the start, integrated
    // sample by sample with the exact exponential of each (constant) rate step.
    T q[4] = {T(1), T(0), T(0), T(0)};
    for (size_t k = 0; k < dt_.size(); ++k) {
      const Eigen::Vector3d col =
          unit_.cwiseProduct(gyro_->col(begin_ + static_cast<int64_t>(k)) - offset_);
      const T x[3] = {T(col.x()), T(col.y()), T(col.z())};
      T w[3];
      gyro_model(m, s, b, x, w);
      const T aa[3] = {w[0] * dt_[k], w[1] * dt_[k], w[2] * dt_[k]};
      T dq[4], nq[4];
      ceres::AngleAxisToQuaternion(aa, dq);
      ceres::QuaternionProduct(q, dq, nq);
      for (int i = 0; i < 4; ++i) q[i] = nq[i];
    }
    // Gravity direction of the first pose seen from the second: R^T u.
    const T qc[4] = {q[0], -q[1], -q[2], -q[3]};
    const T u[3] = {T(u_from_.x()), T(u_from_.y()), T(u_from_.z())};
    T p[3];
    ceres::QuaternionRotatePoint(qc, u, p);
    for (int i = 0; i < 3; ++i) r[i] = p[i] - T(u_to_[i]);
    return true;
  }
  const Eigen::Matrix3Xd* gyro_;
  std::vector<double> dt_;
  int64_t begin_;
  Eigen::Vector3d u_from_, u_to_;
  Eigen::Vector3d offset_, unit_;
};

// Rank of a problem's Jacobian at the current parameters. Each column is scaled by the size of
// a meaningful change of its parameter (`reference`: 1 rad for an angle, the value itself for a
// scale factor, one SI unit's worth of counts for a bias), so a parameter the data barely
// touch shows up as a singular value far below the others (threshold 1e-4 of the largest);
// scaling columns to unit norm instead would hide exactly that.
// jacobian_rank's references for the calibration's blocks in order: `angles` misalignment angles
// (1 rad), the three scale factors s (themselves) and the three biases (one SI unit in counts,
// 1 / s).
std::vector<double> column_references(int angles, const double* s) {
  std::vector<double> r(static_cast<std::size_t>(angles), 1.0);
  for (int a = 0; a < 3; ++a) r.push_back(std::abs(s[a]));
  for (int a = 0; a < 3; ++a) r.push_back(1 / std::abs(s[a]));
  return r;
}

int jacobian_rank(ceres::Problem& problem, const std::vector<double>& reference, int* cols_out) {
  ceres::CRSMatrix crs;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[static_cast<size_t>(r)]; k < crs.rows[static_cast<size_t>(r) + 1]; ++k)
      J(r, crs.cols[static_cast<size_t>(k)]) = crs.values[static_cast<size_t>(k)];
  for (Eigen::Index c = 0; c < J.cols() && static_cast<size_t>(c) < reference.size(); ++c)
    J.col(c) *= reference[static_cast<size_t>(c)];
  *cols_out = crs.num_cols;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(J);
  const Eigen::VectorXd sv = svd.singularValues();
  int rank = 0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) rank += sv(i) > 1e-4 * sv(0);
  return rank;
}

}  // namespace

Eigen::Vector3d interval_mean(const Eigen::Matrix3Xd& x, const StaticInterval& iv) {
  return x.middleCols(iv.begin, iv.end - iv.begin).rowwise().mean();
}

std::vector<StaticInterval> detect_static_intervals(std::span<const TimeNs> t,
                                                    const Eigen::Matrix3Xd& accel,
                                                    const StaticDetectorOptions& opt) {
  const auto n = static_cast<int64_t>(t.size());
  if (accel.cols() != n)
    throw Error("static detector: time stamps and accelerometer samples differ in count");
  if (!(opt.init_static_s > 0 && opt.init_static_s <= 1e7) ||
      !(opt.window_s > 0 && opt.window_s <= 1e4) || !(opt.min_interval_s >= 0) ||
      !(opt.threshold_factor > 0 && std::isfinite(opt.threshold_factor))) {
    throw Error(
        "static detector: the initial static period, window and threshold must be "
        "positive and finite");
  }
  const double span_s = n < 2 ? 0.0 : to_seconds(t.back() - t.front());
  // Checked in seconds before any count is rounded from them (a count from 1e300 s overflows).
  if (!(span_s > opt.init_static_s + opt.window_s)) {
    throw Error(fmt::format(
        "static detector: the recording ({} samples, {:.3g} s) is shorter than the initial static "
        "period ({:g} s) plus a window ({:g} s)",
        n, span_s, opt.init_static_s, opt.window_s));
  }
  const double period = span_s / static_cast<double>(n - 1);
  const int64_t half =
      std::max<int64_t>(1, static_cast<int64_t>(std::llround(0.5 * opt.window_s / period)));
  const int64_t init_end =
      std::max<int64_t>(2, static_cast<int64_t>(std::llround(opt.init_static_s / period)));
  if (init_end + 2 * half >= n) {
    throw Error(fmt::format(
        "static detector: the recording ({} samples) is shorter than the initial static period "
        "({:g} s) plus a window",
        n, opt.init_static_s));
  }
  // Sliding sums of x and x^2 (mean removed first for precision) give each window's variance.
  const Eigen::Vector3d mu = accel.rowwise().mean();
  std::vector<double> c1(static_cast<size_t>(3 * (n + 1)), 0.0),
      c2(static_cast<size_t>(3 * (n + 1)), 0.0);
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      const double v = accel(a, i) - mu(a);
      c1[static_cast<size_t>(3 * (i + 1) + a)] = c1[static_cast<size_t>(3 * i + a)] + v;
      c2[static_cast<size_t>(3 * (i + 1) + a)] = c2[static_cast<size_t>(3 * i + a)] + v * v;
    }
  std::vector<double> var(static_cast<size_t>(n), 0.0);
  for (int64_t i = 0; i < n; ++i) {
    const int64_t lo = std::max<int64_t>(0, i - half), hi = std::min(n, i + half + 1);
    const double cnt = static_cast<double>(hi - lo);
    double s = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double m1 =
          (c1[static_cast<size_t>(3 * hi + a)] - c1[static_cast<size_t>(3 * lo + a)]) / cnt;
      const double m2 =
          (c2[static_cast<size_t>(3 * hi + a)] - c2[static_cast<size_t>(3 * lo + a)]) / cnt;
      s += std::max(0.0, m2 - m1 * m1);
    }
    var[static_cast<size_t>(i)] = s;
  }
  // Reference: the accelerometer's total variance over the initial static period.
  double ref = 0.0;
  {
    const Eigen::Matrix3Xd init = accel.leftCols(init_end);
    const Eigen::Vector3d m = init.rowwise().mean();
    ref = (init.colwise() - m).array().square().sum() / static_cast<double>(init_end);
  }
  // A noiseless signal (a simulation, a mock without a noise model) has an initial variance of
  // zero, and its still windows differ from zero only by the sliding sums' round-off (about
  // 1e-12 of the mean square): the floor sits above that and far below any real sensor's noise.
  const double mean_square = c2[static_cast<size_t>(3 * n)] + c2[static_cast<size_t>(3 * n + 1)] +
                             c2[static_cast<size_t>(3 * n + 2)];
  const double floor = 1e-9 * mean_square / static_cast<double>(n);
  const double threshold = opt.threshold_factor * std::max(ref, floor);
  const int64_t min_len =
      std::max<int64_t>(2, static_cast<int64_t>(std::llround(opt.min_interval_s / period)));
  std::vector<StaticInterval> out;
  int64_t start = -1;
  for (int64_t i = 0; i <= n; ++i) {
    // <=: a noiseless (simulated, or coarsely quantised) signal has windows of zero variance,
    // and so may its initial period.
    const bool still = i < n && var[static_cast<size_t>(i)] <= threshold;
    if (still && start < 0) start = i;
    if (!still && start >= 0) {
      if (i - start >= min_len) out.push_back({start, i});
      start = -1;
    }
  }
  return out;
}

TurnOnBias turn_on_bias_stats(const std::vector<Eigen::Vector3d>& runs) {
  TurnOnBias s;
  s.runs = static_cast<int64_t>(runs.size());
  if (runs.empty()) return s;
  for (const auto& r : runs) s.mean += r;
  s.mean /= static_cast<double>(runs.size());
  if (runs.size() > 1) {
    for (const auto& r : runs) s.spread += (r - s.mean).cwiseAbs2();
    s.spread = (s.spread / static_cast<double>(runs.size() - 1)).cwiseSqrt();
  }
  return s;
}

Eigen::Vector3d gyro_static_bias(const Eigen::Matrix3Xd& gyro) {
  if (gyro.cols() == 0) throw Error("turn-on bias: empty gyroscope recording");
  return gyro.rowwise().mean();
}

Eigen::Vector3d accel_static_bias(const Eigen::Matrix3Xd& accel,
                                  const Eigen::Matrix3d& R_world_sensor, double gravity) {
  if (accel.cols() == 0) throw Error("turn-on bias: empty accelerometer recording");
  // At rest the specific force is -g_world = (0, 0, +g) in the world, seen in the sensor frame.
  return accel.rowwise().mean() - R_world_sensor.transpose() * Eigen::Vector3d(0, 0, gravity);
}

TriadCalibration fit_accelerometer(const std::vector<Eigen::Vector3d>& means, double gravity,
                                   int max_iterations) {
  if (means.size() < 9) {
    throw Error("accelerometer calibration: " + std::to_string(means.size()) +
                " static poses, at least 9 are needed for 9 parameters");
  }
  // Initial guess per axis from the extremes over the poses: bias mid-range, scale 2g/range.
  Eigen::Vector3d lo = means.front(), hi = means.front();
  for (const auto& m : means) lo = lo.cwiseMin(m), hi = hi.cwiseMax(m);
  double mis[3] = {0, 0, 0}, s[3], b[3];
  for (int a = 0; a < 3; ++a) {
    const double range = hi(a) - lo(a);
    b[a] = 0.5 * (hi(a) + lo(a));
    s[a] = range > 0 ? 2.0 * gravity / range : 1.0;
  }
  ceres::Problem problem;
  for (const auto& m : means) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<AccelResidual, 1, 3, 3, 3>(new AccelResidual(m, gravity)),
        nullptr, mis, s, b);
  }
  auto refs = [&] { return column_references(3, s); };
  int cols = 0;
  const int rank_before = jacobian_rank(problem, refs(), &cols);
  ceres::Solver::Options so;
  so.max_num_iterations = max_iterations;
  so.linear_solver_type = ceres::DENSE_QR;
  so.function_tolerance = 1e-14;
  so.parameter_tolerance = 1e-14;
  so.gradient_tolerance = 1e-16;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  const int rank = jacobian_rank(problem, refs(), &cols);
  if (rank < cols || rank_before < cols) {
    throw Error(
        "accelerometer calibration: the static poses do not excite all axes (Jacobian rank " +
        std::to_string(std::min(rank, rank_before)) + " of " + std::to_string(cols) +
        "); hold the sensor in more orientations, each axis up and down");
  }
  if (summary.termination_type == ceres::FAILURE) {
    throw Error("accelerometer calibration did not converge: " + summary.BriefReport());
  }
  TriadCalibration c;
  c.T << 1, -mis[0], mis[1], 0, 1, -mis[2], 0, 0, 1;
  c.scale = Eigen::Vector3d(s[0], s[1], s[2]);
  c.bias = Eigen::Vector3d(b[0], b[1], b[2]);
  return c;
}

namespace {

std::vector<Eigen::Vector3d> pose_means(const Eigen::Matrix3Xd& accel,
                                        const std::vector<StaticInterval>& iv) {
  std::vector<Eigen::Vector3d> m;
  for (const auto& i : iv) m.push_back(interval_mean(accel, i));
  return m;
}

void norm_errors(const TriadCalibration& c, const std::vector<Eigen::Vector3d>& means, double g,
                 std::vector<double>& err, double& rms, double& mx) {
  err.clear();
  double ss = 0.0;
  mx = 0.0;
  for (const auto& m : means) {
    const double e = c.apply(m).norm() - g;
    err.push_back(e);
    ss += e * e;
    mx = std::max(mx, std::abs(e));
  }
  rms = means.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(means.size()));
}

// The threshold search (the paper's k): the factor whose static poses give the accelerometer
// fit with the smallest norm error per spare pose, sum e^2 / (poses - 9). Fits of different
// pose counts are compared: 9 poses leave the 9 parameters no spare equation, so wherever the
// quadric through them is an ellipsoid (as for any poses near the gravity sphere) the fit
// passes through every pose, a residual of zero however wrong the poses are, and a factor that
// merged poses across slow turns down to 9 would otherwise always win. A fit without a spare
// pose is taken only when no factor gives one.
double residual_per_spare_pose(const CalibrationResult& r) {
  const auto poses = static_cast<double>(r.accel_norm_error.size());
  constexpr double kParameters = 9.0;
  if (poses <= kParameters) return std::numeric_limits<double>::infinity();
  return r.accel_rms * r.accel_rms * poses / (poses - kParameters);
}

CalibrationResult fit_accelerometer_poses(std::span<const TimeNs> t, const Eigen::Matrix3Xd& accel,
                                          const CalibrationOptions& options) {
  CalibrationResult best;
  double best_score = 0.0;
  bool have = false;
  std::string last_error = "no threshold factor gave enough static poses";
  bool too_few = true;  // every factor failed for want of poses
  for (int k = 1; k <= options.max_threshold_factor; ++k) {
    StaticDetectorOptions d = options.detector;
    d.threshold_factor = static_cast<double>(k);
    const auto iv = detect_static_intervals(t, accel, d);
    if (static_cast<int>(iv.size()) < options.min_poses) {
      if (too_few) {
        last_error = "only " + std::to_string(iv.size()) + " static poses found (at least " +
                     std::to_string(options.min_poses) + " are needed)";
      }
      continue;
    }
    const auto means = pose_means(accel, iv);
    TriadCalibration c;
    try {
      c = fit_accelerometer(means, options.gravity, options.max_iterations);
    } catch (const Error& e) {
      // A fit that failed with enough poses says more than a factor that found too few.
      last_error = e.what();
      too_few = false;
      continue;
    }
    CalibrationResult r;
    r.accel = c;
    r.poses = iv;
    r.threshold_factor = static_cast<double>(k);
    norm_errors(c, means, options.gravity, r.accel_norm_error, r.accel_rms, r.accel_max);
    const double score = residual_per_spare_pose(r);
    if (!have || score < best_score) best = std::move(r), best_score = score, have = true;
  }
  if (!have && too_few) throw TooFewPosesError("calibration: " + last_error);
  if (!have) throw Error("calibration: " + last_error);
  return best;
}

// The gyroscope's starting scale: 1 for SI input, guessed for raw counts from the rotation angle
// between poses (from gravity) against the integrated raw rate.
double initial_gyro_scale(std::span<const TimeNs> t, const Eigen::Matrix3Xd& gyro,
                          const std::vector<StaticInterval>& iv,
                          const std::vector<Eigen::Vector3d>& dirs, const Eigen::Vector3d& b0) {
  double num = 0.0, den = 0.0;
  for (size_t p = 0; p + 1 < iv.size(); ++p) {
    const double angle = std::acos(std::clamp(dirs[p].dot(dirs[p + 1]), -1.0, 1.0));
    Eigen::Vector3d integ = Eigen::Vector3d::Zero();
    for (int64_t q = iv[p].end; q < iv[p + 1].begin; ++q)
      integ += (gyro.col(q) - b0) *
               to_seconds(t[static_cast<size_t>(q + 1)] - t[static_cast<size_t>(q)]);
    if (angle > 0.3) num += angle, den += integ.norm();
  }
  return den > 0 && num > 0 ? num / den : 1.0;
}

// Each rotation's residual angle after the fit (the residual is the chord between the predicted
// and the measured gravity direction), into best's gyroscope error fields.
void gyro_residual_angles(const ceres::Problem& problem, const double* m, const double* s,
                          const double* b, CalibrationResult& best) {
  double ss = 0.0;
  best.gyro_max_rad = 0.0;
  std::vector<ceres::ResidualBlockId> ids;
  problem.GetResidualBlocks(&ids);
  for (ceres::ResidualBlockId id : ids) {
    double r[3];
    const ceres::CostFunction* cf = problem.GetCostFunctionForResidualBlock(id);
    const double* params[3] = {m, s, b};
    cf->Evaluate(params, r, nullptr);
    // |p - u| = 2 sin(angle/2) for unit vectors.
    const double chord = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    const double ang = 2.0 * std::asin(std::min(1.0, 0.5 * chord));
    best.gyro_direction_error_rad.push_back(ang);
    ss += ang * ang;
    best.gyro_max_rad = std::max(best.gyro_max_rad, ang);
  }
  best.gyro_rms_rad = std::sqrt(
      ss / static_cast<double>(std::max<size_t>(1, best.gyro_direction_error_rad.size())));
}

// The gyroscope's misalignment, scale and bias from the rotations between best's poses: each
// rotation, integrated, must turn the gravity direction of one pose into the next's.
void fit_gyroscope(std::span<const TimeNs> t, const Eigen::Matrix3Xd& accel,
                   const Eigen::Matrix3Xd& gyro, const CalibrationOptions& options,
                   CalibrationResult& best) {
  const auto& iv = best.poses;
  // Bias from the first static pose (the initial static period), then refined with the rest;
  // the starting scale from the rotation angles. Both are fixed in the residual (GyroResidual),
  // the fitted s and b are relative to them.
  double m[6] = {0, 0, 0, 0, 0, 0}, s[3] = {1, 1, 1}, b[3] = {0, 0, 0};
  const Eigen::Vector3d b0 = interval_mean(gyro, iv.front());
  ceres::Problem problem;
  std::vector<Eigen::Vector3d> dirs;
  for (const auto& i : iv) dirs.push_back(best.accel.apply(interval_mean(accel, i)).normalized());
  const Eigen::Vector3d unit = Eigen::Vector3d::Constant(initial_gyro_scale(t, gyro, iv, dirs, b0));
  // Samples missing inside a rotation: the rate before the gap was held across it, and the
  // solver took the missing turn into scale, misalignment and bias (0.4 s lost in 5 of 13
  // rotations: the y scale 1.7 % off, the z bias 56 %, and a residual no larger than a real
  // session's; found in review, 2026-11-27). Jittered or rounded stamps are no gap
  // (SamplingStats::samples_missing).
  const SamplingStats sampling = analyze_sampling(t);
  const double gap_s = sampling.samples_missing() ? 1.5 * sampling.median_period_s
                                                  : std::numeric_limits<double>::infinity();
  for (size_t p = 0; p + 1 < iv.size(); ++p) {
    // From the middle of pose p to the middle of pose p+1: the static parts at both ends carry
    // the bias into the fit and cost nothing in rotation.
    const int64_t from = (iv[p].begin + iv[p].end) / 2, to = (iv[p + 1].begin + iv[p + 1].end) / 2;
    std::vector<double> dt;
    for (int64_t q = from; q < to; ++q) {
      dt.push_back(to_seconds(t[static_cast<size_t>(q + 1)] - t[static_cast<size_t>(q)]));
      if (dt.back() > gap_s) {
        throw Error(fmt::format(
            "gyroscope calibration: samples are missing in the rotation between poses {} and {} "
            "(a step of {:.4f} s at t = {:.3f} s, where the median period is {:.4f} s): the "
            "rotation cannot be integrated across the gap; cut the recording before it or "
            "record the session again",
            p + 1, p + 2, dt.back(), to_seconds(t[static_cast<size_t>(q)] - t[0]),
            sampling.median_period_s));
      }
    }
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<GyroResidual, 3, 6, 3, 3>(
            new GyroResidual(&gyro, std::move(dt), from, dirs[p], dirs[p + 1], b0, unit)),
        nullptr, m, s, b);
  }
  // The biases are in SI units here: one unit is the meaningful change (reference 1 = 1 / s
  // at s = 1).
  auto refs = [&] { return column_references(6, s); };
  int cols = 0;
  const int rank_before = jacobian_rank(problem, refs(), &cols);
  ceres::Solver::Options so;
  so.max_num_iterations = options.max_iterations;
  so.linear_solver_type = ceres::DENSE_QR;
  so.num_threads = 2;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  const int rank = jacobian_rank(problem, refs(), &cols);
  if (std::min(rank, rank_before) < cols) {
    throw Error(
        "gyroscope calibration: the rotations between poses do not excite all axes "
        "(Jacobian rank " +
        std::to_string(std::min(rank, rank_before)) + " of " + std::to_string(cols) +
        "); rotate about each of the three axes");
  }
  if (summary.termination_type == ceres::FAILURE) {
    throw Error("gyroscope calibration did not converge: " + summary.BriefReport());
  }
  best.gyro.T << 1, m[0], m[1], m[2], 1, m[3], m[4], m[5], 1;
  // s_fit (unit (x - b0) - b_fit) = (s_fit unit) (x - (b0 + b_fit / unit)), per axis.
  for (int a = 0; a < 3; ++a) {
    best.gyro.scale(a) = unit(a) * s[a];
    best.gyro.bias(a) = b0(a) + b[a] / unit(a);
  }
  gyro_residual_angles(problem, m, s, b, best);
}

}  // namespace

// Every accelerometer axis must have been held well up and well down (a calibrated gravity
// component of at least kMinAxisGravity g each way): the rank test passes pose sets that
// determine the bias only weakly. Poses tilted at most 30 degrees from z up put the z bias
// 9-23 % off with a residual of 1e-5 m/s^2 (found in review, 2026-11-27).
constexpr double kMinAxisGravity = 0.55;  // 33 degrees above the horizontal
void require_each_axis_up_and_down(const CalibrationResult& r, const Eigen::Matrix3Xd& accel) {
  Eigen::Vector3d up = Eigen::Vector3d::Constant(-1.0), down = Eigen::Vector3d::Constant(1.0);
  for (const Eigen::Vector3d& m : pose_means(accel, r.poses)) {
    const Eigen::Vector3d d = r.accel.apply(m).normalized();
    up = up.cwiseMax(d);
    down = down.cwiseMin(d);
  }
  for (int a = 0; a < 3; ++a) {
    if (up[a] >= kMinAxisGravity && down[a] <= -kMinAxisGravity) continue;
    throw Error(fmt::format(
        "calibration: the accelerometer's {} axis was not held both up and down (its share of "
        "gravity over the {} poses reaches {:+.2f} and {:+.2f}, at least +-{} needed): its bias "
        "and scale are poorly determined; hold the sensor in more orientations, each axis up "
        "and down",
        "xyz"[a], r.poses.size(), up[a], down[a], kMinAxisGravity));
  }
}

CalibrationResult calibrate(std::span<const TimeNs> t, const Eigen::Matrix3Xd& accel,
                            const Eigen::Matrix3Xd& gyro, const CalibrationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto n = static_cast<int64_t>(t.size());
  if (accel.cols() != n || (options.calibrate_gyro && gyro.cols() != n)) {
    throw Error("calibration: accelerometer, gyroscope and time stamps differ in length");
  }
  // A NaN sample (a gap declared with --gaps) made Ceres evaluate NaN residuals and the rank
  // check run an SVD of an empty matrix, an assertion (abort); one NaN outside the poses silently
  // removed its axis from the static detector (review, 2026-11-27). Poses and the gyroscope's
  // integration between them need every sample.
  const auto require_finite = [&](const Eigen::Matrix3Xd& m, const char* what) {
    if (const auto i = first_non_finite_sample(m)) {
      throw Error(fmt::format(
          "calibration: {} sample {} (t = {:.6f} s) is not finite ({}, {}, {}): a "
          "multi-position calibration integrates the gyroscope between poses and needs every "
          "sample; cut the recording before the gap or record the session again",
          what, *i, to_seconds(t[static_cast<std::size_t>(*i)] - t[0]), m(0, *i), m(1, *i),
          m(2, *i)));
    }
  };
  require_finite(accel, "accelerometer");
  if (options.calibrate_gyro) require_finite(gyro, "gyroscope");
  // Ceres would chase a NaN or astronomically scaled model; gravity is a physical quantity.
  if (!(options.gravity > 0 && options.gravity <= 1000))
    throw Error(fmt::format("calibration: gravity {:g} m/s^2 is not plausible", options.gravity));
  if (n < 2) {
    throw Error(fmt::format(
        "calibration: the recording has {} sample(s); a multi-position calibration needs the "
        "initial static period and {} or more still poses",
        n, options.min_poses));
  }
  CalibrationResult best = fit_accelerometer_poses(t, accel, options);
  require_each_axis_up_and_down(best, accel);
  if (options.calibrate_gyro) {
    // A dead gyroscope (found in review: all zeros) was told to "rotate about each of the three
    // axes" by the rank check; rotations between poses always move a live one.
    for (int a = 0; a < 3; ++a) {
      if (n > 0 && (gyro.row(a).array() == gyro(a, 0)).all()) {
        throw Error(fmt::format(
            "gyroscope calibration: the gyroscope's {} axis reads {:g} in every sample although "
            "the device turned between its poses (a dead or disconnected gyroscope?); calibrate "
            "the "
            "accelerometer alone (imukit calibrate --no-gyro)",
            "xyz"[a], gyro(a, 0)));
      }
    }
  }
  if (options.calibrate_gyro) fit_gyroscope(t, accel, gyro, options, best);
  best.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return best;
}

}  // namespace imukit::hwmodel
