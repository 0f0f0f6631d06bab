// Identification (sim/identify.hpp): recovery of a known placement, biases, time offset, clock
// rate and segment length from synthetic recordings with noise (the tolerances of issue 8),
// the unobservability diagnostic, pose tracks with gaps, and the real BROAD recording.
#include "imukit/sim/identify.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/so3.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/simulator.hpp"
#include "support/sampled_motion.hpp"
#include "support/test_data.hpp"

namespace imukit::sim {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

// Varied motion of a two-joint chain: the root turns about all three axes and translates, the
// child ("arm", carrying the sensor) swings about its own axes. Functions of time, so the same
// motion can be sampled at any rate.
struct VariedMotion {
  bool single_axis = false;  // root about world z only, no translation, child still
  Quaterniond root(double t) const {
    if (single_axis)
      return so3_exp(Vector3d(0, 0, 1.2 * std::sin(1.3 * t) + 0.7 * std::sin(3.1 * t + 0.4)));
    return so3_exp(Vector3d(0.8 * std::sin(0.9 * t) + 0.3 * std::sin(2.7 * t + 1.0),
                            0.7 * std::sin(1.3 * t + 0.5) + 0.25 * std::sin(3.3 * t),
                            1.1 * std::sin(0.6 * t + 2.0) + 0.3 * std::sin(2.1 * t + 0.3)));
  }
  Quaterniond child(double t) const {
    if (single_axis) return Quaterniond::Identity();
    return so3_exp(Vector3d(0.6 * std::sin(1.7 * t + 0.2), 0.5 * std::sin(2.3 * t + 1.1),
                            0.4 * std::sin(1.1 * t + 0.7)));
  }
  Vector3d trans(double t) const {
    if (single_axis) return Vector3d::Zero();
    return Vector3d(0.3 * std::sin(0.8 * t), 0.25 * std::sin(1.2 * t + 1.0),
                    0.15 * std::sin(1.9 * t + 0.5));
  }
  Motion sample(double rate, double seconds) const {
    const auto frames = static_cast<int64_t>(std::llround(seconds * rate)) + 1;
    return testing::sampled_motion(
        rate, frames, [this](double t) { return root(t); }, [this](double t) { return child(t); },
        [this](double t) { return trans(t); });
  }
};

Body chain_body(double arm_offset = 0.3) {
  Body b;
  b.add_joint("pelvis", -1, Vector3d::Zero());
  b.add_joint("arm", 0, Vector3d(arm_offset, 0.0, 0.1));
  return b;
}

struct Truth {
  Placement placement;
  Vector3d ba = Vector3d(0.05, -0.08, 0.12), bg = Vector3d(0.01, -0.005, 0.02);
  double dt = 0.2373;  // IMU sample stamped t measured the motion at t + dt
  double kappa = 0.0;  // clock rate
  double sigma_a = 0.05, sigma_g = 0.005;
};

// The recording a sensor with this truth would make: simulated from a 500 Hz sampling of the
// motion (the identification only sees 100 Hz frames), stamped on the IMU clock, plus bias and
// white noise.
ImuSeries synthetic_imu(const Body& body, const VariedMotion& vm, const Truth& tr, double seconds,
                        double imu_rate, uint64_t seed) {
  Motion fine = vm.sample(500.0, seconds + 1.0);
  SensorSpec s;
  s.name = "imu";
  s.placement = tr.placement;
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(body, {s}, so);
  std::vector<TimeNs> stamps, tau;
  const double t_ref = seconds / 2;
  for (double t = 0.5; t < seconds - 0.5; t += 1.0 / imu_rate) {
    stamps.push_back(std::llround(t * 1e9));
    tau.push_back(std::llround((t + tr.dt + tr.kappa * (t - t_ref)) * 1e9));
  }
  std::vector<SensorBlock> out;
  sim.evaluate(fine, tau, out);
  ImuSeries imu = ImuSeries::with_channels(stamps.size(), true, true);
  imu.t = stamps;
  Rng rng(seed);
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(stamps.size()); ++i) {
    for (int k = 0; k < 3; ++k) {
      imu.accel(k, i) = out[0].specific_force(k, i) + tr.ba[k] + tr.sigma_a * rng.normal();
      imu.gyro(k, i) = out[0].angular_rate(k, i) + tr.bg[k] + tr.sigma_g * rng.normal();
    }
  }
  return imu;
}

Truth default_truth(const Body& body) {
  Truth tr;
  tr.placement.joint = body.index_of("arm");
  tr.placement.p_joint_sensor = Vector3d(0.03, -0.02, 0.05);
  tr.placement.q_joint_sensor = euler_to_quaternion(Vector3d(20, -35, 110), "XYZ", true, true);
  return tr;
}

const ParameterEstimate& param(const IdentifyResult& r, const std::string& name) {
  for (const ParameterEstimate& e : r.parameters) {
    if (e.name == name) return e;
  }
  throw std::runtime_error("no parameter " + name);
}

// The acceptance test: 60 s of varied motion at 100 Hz, noise and bias, a quarter-second
// clock offset: rotation within 0.5 deg, position within 5 mm, time offset within 1 ms, biases
// within 3 standard errors (noise sigma / sqrt(N)).
TEST(Identify, RecoversPlacementBiasesAndTimeOffset) {
  const Body body = chain_body();
  const VariedMotion vm;
  const Truth tr = default_truth(body);
  const ImuSeries imu = synthetic_imu(body, vm, tr, 60.0, 100.0, 7);
  Motion motion = vm.sample(100.0, 61.0);
  IdentifyOptions o;
  o.joint = tr.placement.joint;
  const IdentifyResult r = identify(body, motion, imu, o);

  EXPECT_TRUE(r.unobservable.empty());
  EXPECT_NEAR(r.coarse_time_offset_s, tr.dt, 0.01);  // cross-correlation: within a sample
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, tr.placement.q_joint_sensor),
            0.5 * kRadPerDeg);
  EXPECT_LT((r.placement.p_joint_sensor - tr.placement.p_joint_sensor).norm(), 0.005);
  EXPECT_NEAR(r.time_offset_s, tr.dt, 0.001);
  const double n = static_cast<double>(r.samples_used);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.accel_bias[k], tr.ba[k], 3 * tr.sigma_a / std::sqrt(n)) << k;
    EXPECT_NEAR(r.gyro_bias[k], tr.bg[k], 3 * tr.sigma_g / std::sqrt(n)) << k;
  }
  // The reported uncertainties are the right size: the bias standard error is about
  // sigma / sqrt(N) (white noise; a little more from the correlation with other parameters).
  const double se_ba = param(r, "accel_bias.x").std_error,
               se_bg = param(r, "gyro_bias.z").std_error;
  EXPECT_GT(se_ba, 0.7 * tr.sigma_a / std::sqrt(n));
  EXPECT_LT(se_ba, 2.0 * tr.sigma_a / std::sqrt(n));
  EXPECT_GT(se_bg, 0.7 * tr.sigma_g / std::sqrt(n));
  EXPECT_LT(se_bg, 2.0 * tr.sigma_g / std::sqrt(n));
  EXPECT_LT(std::abs(r.time_offset_s - tr.dt), 5 * param(r, "time_offset").std_error + 1e-5);
  // After the fit only the noise is left; before it, the offset and placement dominate.
  EXPECT_NEAR(r.rms_after.accel, tr.sigma_a, 0.1 * tr.sigma_a);
  EXPECT_NEAR(r.rms_after.gyro, tr.sigma_g, 0.1 * tr.sigma_g);
  EXPECT_GT(r.rms_before.gyro, 20 * tr.sigma_g);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.accel_after.cols(), r.samples_used);

  const auto j = nlohmann::json::parse(placement_json(r, body));
  EXPECT_EQ(j["schema"], "imukit.placement/1");
  EXPECT_EQ(j["sensor"]["segment"], "arm");
  EXPECT_NEAR(j["sensor"]["position_m"][0].get<double>(), r.placement.p_joint_sensor.x(), 1e-12);
  EXPECT_NEAR(j["timing"]["time_offset_s"].get<double>(), r.time_offset_s, 1e-15);
}

// Outliers (a few samples of garbage) do not move the estimate: Huber loss.
TEST(Identify, RobustToOutliers) {
  const Body body = chain_body();
  const VariedMotion vm;
  Truth tr = default_truth(body);
  tr.dt = 0.0041;
  ImuSeries imu = synthetic_imu(body, vm, tr, 20.0, 100.0, 8);
  Rng rng(3);
  for (Eigen::Index i = 100; i < imu.accel.cols(); i += 97) {
    imu.accel.col(i) += Vector3d(30, -20, 25) * (rng.uniform() + 0.5);
    imu.gyro.col(i) += Vector3d(-4, 3, 5) * (rng.uniform() + 0.5);
  }
  Motion motion = vm.sample(100.0, 21.0);
  IdentifyOptions o;
  o.joint = tr.placement.joint;
  const IdentifyResult r = identify(body, motion, imu, o);
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, tr.placement.q_joint_sensor),
            0.5 * kRadPerDeg);
  EXPECT_LT((r.placement.p_joint_sensor - tr.placement.p_joint_sensor).norm(), 0.005);
  EXPECT_NEAR(r.time_offset_s, tr.dt, 0.001);
  EXPECT_LT((r.accel_bias - tr.ba).norm(), 0.01);
}

// A clock running 150 ppm fast, gyro and accelerometer scale errors, and a wrong upper-arm
// length in the body (0.30 m nominal, 0.33 m true) are all recovered when asked for.
TEST(Identify, ClockRateScaleAndSegmentLength) {
  const Body truth_body = chain_body(0.33);
  const Body nominal = chain_body(0.30);
  const VariedMotion vm;
  Truth tr = default_truth(truth_body);
  tr.dt = -0.0123;
  tr.kappa = 150e-6;
  ImuSeries imu = synthetic_imu(truth_body, vm, tr, 40.0, 100.0, 9);
  const Vector3d sa(0.01, -0.02, 0.005), sg(-0.01, 0.015, 0.02);
  for (Eigen::Index i = 0; i < imu.accel.cols(); ++i) {
    // The scale acts on the true signal: (1 + s) (x + b) - s b = (1 + s) x + b.
    imu.accel.col(i) = (imu.accel.col(i) - tr.ba).cwiseProduct(Vector3d::Ones() + sa) + tr.ba;
    imu.gyro.col(i) = (imu.gyro.col(i) - tr.bg).cwiseProduct(Vector3d::Ones() + sg) + tr.bg;
  }
  Motion motion = vm.sample(100.0, 41.0);
  IdentifyOptions o;
  o.joint = tr.placement.joint;
  o.clock_rate = true;
  o.accel_scale = true;
  o.gyro_scale = true;
  o.segments = {nominal.index_of("arm")};
  o.segment_prior = 0.2;
  const IdentifyResult r = identify(nominal, motion, imu, o);
  ASSERT_TRUE(r.unobservable.empty());
  EXPECT_TRUE(r.warnings.empty());
  EXPECT_NEAR(r.clock_rate, tr.kappa, 10e-6);
  // IMU times are referred to the middle of the samples used; the truth to the middle of 0.5..39.5
  // s.
  const double t_ref = to_seconds(r.t_ref_ns);
  EXPECT_NEAR(r.time_offset_s, tr.dt + tr.kappa * (t_ref - 20.0), 0.001);
  EXPECT_LT((r.accel_scale - sa).cwiseAbs().maxCoeff(), 2e-3);
  EXPECT_LT((r.gyro_scale - sg).cwiseAbs().maxCoeff(), 2e-3);
  ASSERT_EQ(r.segment_lengths.size(), 1u);
  EXPECT_NEAR(r.segment_lengths[0].second, std::hypot(0.33, 0.1), 0.005);
  EXPECT_LT((r.placement.p_joint_sensor - tr.placement.p_joint_sensor).norm(), 0.005);
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, tr.placement.q_joint_sensor),
            0.5 * kRadPerDeg);
}

// A motion clock 4 % fast (streams aligned by duration, as with a camera's effective frame
// rate): the IMU is simulated on the motion re-timed to the IMU's clock (sampled from the motion's
// functions at tau(t), so its rates and accelerations are the physical ones on that clock), and
// the fit with a wide clock-rate range (coarse grid, then Levenberg-Marquardt) recovers the
// scale, which enters the model by the chain rule (rate (1 + kappa) w, dynamic acceleration
// (1 + kappa)^2 a). With a twist correction the fitted twist stays near zero (there is none), and
// the fitted motion re-simulates the fitted signals to a small fraction of the noise.
TEST(Identify, TimeScaleFollowsTheChainRule) {
  const Body body = chain_body();
  const VariedMotion vm;
  Truth tr = default_truth(body);
  const double kappa = 0.04, c = 0.12;  // tau = c + (1 + kappa) t
  auto tau = [&](double t) { return c + (1 + kappa) * t; };
  const Motion warped = testing::sampled_motion(
      500.0, 500 * 30 + 1, [&](double t) { return vm.root(tau(t)); },
      [&](double t) { return vm.child(tau(t)); }, [&](double t) { return vm.trans(tau(t)); });
  SensorSpec spec;
  spec.name = "imu";
  spec.placement = tr.placement;
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(body, {spec}, so);
  std::vector<TimeNs> stamps;
  for (int i = 0; i < 50 * 29; ++i) stamps.push_back(std::llround(i / 50.0 * 1e9));
  std::vector<SensorBlock> out;
  Motion warped_copy = warped;
  sim.evaluate(warped_copy, stamps, out);
  ImuSeries imu = ImuSeries::with_channels(stamps.size(), true, true);
  imu.t = stamps;
  Rng rng(12);
  for (Eigen::Index i = 0; i < imu.accel.cols(); ++i) {
    for (int k = 0; k < 3; ++k) {
      imu.accel(k, i) = out[0].specific_force(k, i) + tr.ba[k] + tr.sigma_a * rng.normal();
      imu.gyro(k, i) = out[0].angular_rate(k, i) + tr.bg[k] + tr.sigma_g * rng.normal();
    }
  }
  Motion motion = vm.sample(100.0, 32.0);
  IdentifyOptions o;
  o.joint = tr.placement.joint;
  o.clock_rate = true;
  o.max_clock_rate = 0.1;
  o.correction = SegmentCorrection::twist;
  const IdentifyResult r = identify(body, motion, imu, o);
  EXPECT_TRUE(r.unobservable.empty());
  EXPECT_NEAR(r.coarse_clock_rate, kappa, 2e-3);
  EXPECT_NEAR(r.clock_rate, kappa, 1e-5);
  EXPECT_NEAR(r.time_offset_s, c + kappa * to_seconds(r.t_ref_ns), 5e-4);
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, tr.placement.q_joint_sensor),
            0.5 * kRadPerDeg);
  EXPECT_LT((r.placement.p_joint_sensor - tr.placement.p_joint_sensor).norm(), 0.005);
  EXPECT_LT(r.correction_angles.cwiseAbs().maxCoeff(), 0.5 * kRadPerDeg);
  EXPECT_NEAR(r.rms_after.accel, tr.sigma_a, 0.1 * tr.sigma_a);
  EXPECT_NEAR(r.rms_after.gyro, tr.sigma_g, 0.1 * tr.sigma_g);
  // The fitted motion at the IMU's rate re-simulates the fitted model.
  Motion fitted =
      fitted_motion(body, motion, r, imu.t.front(), static_cast<int64_t>(imu.size()), 50.0);
  SensorSpec placed = spec;
  placed.placement = r.placement;
  Simulator resim(body, {placed}, so);
  std::vector<TimeNs> times;
  for (TimeNs t : r.t) times.push_back(t - imu.t.front());
  resim.evaluate(fitted, times, out);
  const Eigen::Matrix3Xd fa = r.accel_after.colwise() - r.accel_bias;
  const Eigen::Matrix3Xd fg = r.gyro_after.colwise() - r.gyro_bias;
  EXPECT_LT(std::sqrt((out[0].specific_force - fa).squaredNorm() / static_cast<double>(fa.size())),
            0.1 * tr.sigma_a);
  EXPECT_LT(std::sqrt((out[0].angular_rate - fg).squaredNorm() / static_cast<double>(fg.size())),
            0.1 * tr.sigma_g);
}

// Rotation about one world axis only: the position along that axis does not enter the signals,
// and rotating the sensor about the axis can be traded for rotating its position: both are
// reported unobservable (NaN), not guessed; the biases and the time offset are still found.
TEST(Identify, ReportsUnobservableParameters) {
  Body body;
  body.add_joint("pelvis", -1, Vector3d::Zero());
  body.add_joint("arm", 0, Vector3d(0.2, 0, 0));
  VariedMotion vm;
  vm.single_axis = true;
  Truth tr = default_truth(body);
  tr.dt = 0.02;
  const ImuSeries imu = synthetic_imu(body, vm, tr, 30.0, 100.0, 10);
  Motion motion = vm.sample(100.0, 31.0);
  IdentifyOptions o;
  o.joint = tr.placement.joint;
  const IdentifyResult r = identify(body, motion, imu, o);
  auto flagged = [&](const std::string& name) {
    return std::find(r.unobservable.begin(), r.unobservable.end(), name) != r.unobservable.end();
  };
  EXPECT_TRUE(flagged("position.z"));
  EXPECT_TRUE(flagged("rotation.x") || flagged("rotation.y") || flagged("rotation.z"));
  EXPECT_FALSE(param(r, "position.z").observable);
  EXPECT_TRUE(std::isnan(r.placement.p_joint_sensor.z()));
  EXPECT_TRUE(std::isnan(r.placement.q_joint_sensor.w()));
  EXPECT_FALSE(flagged("time_offset"));
  EXPECT_NEAR(r.time_offset_s, tr.dt, 0.001);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.gyro_bias[k], tr.bg[k], 0.002) << k;
  const auto j = nlohmann::json::parse(placement_json(r, body));
  EXPECT_TRUE(j["sensor"]["position_m"][2].is_null());
  EXPECT_FALSE(j["unobservable"].empty());
}

TEST(Identify, RejectsBadInput) {
  const Body body = chain_body();
  const VariedMotion vm;
  Motion motion = vm.sample(100.0, 5.0);
  const Truth tr = default_truth(body);
  ImuSeries imu = synthetic_imu(body, vm, tr, 4.0, 100.0, 1);
  IdentifyOptions o;
  EXPECT_THROW(identify(body, motion, imu, o), Error);  // no joint
  o.joint = 1;
  ImuSeries no_gyro = imu;
  no_gyro.gyro.resize(3, 0);
  EXPECT_THROW(identify(body, motion, no_gyro, o), Error);
  ImuSeries far = imu;
  for (TimeNs& t : far.t) t += 100'000'000'000;  // 100 s after the motion
  o.coarse_time_offset = false;
  EXPECT_THROW(identify(body, motion, far, o), Error);
  o.segments = {0};  // the root has no parent segment
  EXPECT_THROW(identify(body, motion, imu, o), Error);
  // A still IMU does not correlate with the moving body: the offset is not guessed.
  o.segments.clear();
  o.coarse_time_offset = true;
  ImuSeries still = imu;
  still.gyro.setConstant(0.01);
  Rng rng(2);
  for (Eigen::Index i = 0; i < still.gyro.size(); ++i) still.gyro.data()[i] += 1e-3 * rng.normal();
  EXPECT_THROW(identify(body, motion, still, o), Error);
}

PoseTrack track_of(const VariedMotion& vm, double rate, int64_t rows, TimeNs t0) {
  PoseTrack p;
  p.p_world_body.resize(3, rows);
  for (int64_t k = 0; k < rows; ++k) {
    const double t = static_cast<double>(k) / rate;
    p.t.push_back(t0 + std::llround(t * 1e9));
    p.q_world_body.push_back(vm.root(t));
    p.p_world_body.col(k) = vm.trans(t);
  }
  return p;
}

TEST(Identify, PoseTrackGapsAreFilledAndListed) {
  const VariedMotion vm;
  PoseTrack p = track_of(vm, 200.0, 400, 1'000'000'000);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k : {0, 1, 2, 397, 398, 399})
    p.q_world_body[static_cast<std::size_t>(k)].coeffs().setConstant(nan);
  for (int k = 100; k < 105; ++k)
    p.q_world_body[static_cast<std::size_t>(k)].coeffs().setConstant(nan);
  p.p_world_body.col(200).setConstant(nan);
  const PoseMotion pm = pose_track_motion(p, "track");
  EXPECT_EQ(pm.motion.frames(), 394);
  EXPECT_EQ(pm.start_ns, 1'000'000'000 + 15'000'000);
  EXPECT_NEAR(pm.motion.rate_hz(), 200.0, 1e-9);
  ASSERT_EQ(pm.gaps.size(), 2u);
  EXPECT_EQ(pm.gaps[0].first, 97 * 5'000'000);
  EXPECT_EQ(pm.gaps[0].second, 101 * 5'000'000);
  EXPECT_EQ(pm.missing_rows, 6);
  // Filled values lie between their neighbours (slerp / linear), so differentiation stays finite.
  const Quaterniond qa = pm.motion.rotation(96, 0), qb = pm.motion.rotation(102, 0);
  const Quaterniond qm = pm.motion.rotation(99, 0);
  EXPECT_NEAR(angular_distance(qa, qm) + angular_distance(qm, qb), angular_distance(qa, qb), 1e-9);
  EXPECT_NEAR((pm.motion.root_translation(197) -
               0.5 * (pm.motion.root_translation(196) + pm.motion.root_translation(198)))
                  .norm(),
              0.0, 1e-12);
  // Non-uniform rows and all-missing tracks are errors.
  PoseTrack bad = track_of(vm, 200.0, 50, 0);
  bad.t[20] += 2'000'000;
  EXPECT_THROW(pose_track_motion(bad, "bad"), Error);
  PoseTrack empty = track_of(vm, 200.0, 50, 0);
  for (auto& q : empty.q_world_body) q.coeffs().setConstant(nan);
  EXPECT_THROW(pose_track_motion(empty, "empty"), Error);
}

// A rigid body tracked optically (orientation of the IMU frame, position of a marker body 4 cm
// away, gaps), as in BROAD: identify the lever arm, a small residual rotation, the clock lag.
TEST(Identify, PoseTrackWithGapsAndLeverArm) {
  const VariedMotion vm;
  const double rate = 1.0 / 0.0035;
  const int64_t rows = static_cast<int64_t>(20.0 * rate);
  PoseTrack p = track_of(vm, rate, rows, 0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 3000; k < 3024; ++k)
    p.q_world_body[static_cast<std::size_t>(k)].coeffs().setConstant(nan);
  for (int k = 4500; k < 4505; ++k) p.p_world_body.col(k).setConstant(nan);
  const PoseMotion pm = pose_track_motion(p, "track");
  Truth tr;
  tr.placement.joint = 0;
  tr.placement.p_joint_sensor = Vector3d(0.021, -0.034, 0.012);
  tr.placement.q_joint_sensor = so3_exp(Vector3d(0.01, -0.02, 0.015));
  tr.dt = -0.004;
  tr.sigma_a = 0.03;
  tr.sigma_g = 0.003;
  Body body;
  body.add_joint("pelvis", -1, Vector3d::Zero());
  body.add_joint("arm", 0, Vector3d::Zero());
  VariedMotion root_only = vm;
  // The IMU is rigid on the tracked body: simulate on the root.
  ImuSeries imu = synthetic_imu(body, root_only, tr, 19.0, rate, 11);
  IdentifyOptions o;
  o.joint = 0;
  o.init_rotation_from_data = false;
  o.motion_start_ns = pm.start_ns;
  o.invalid_motion = pm.gaps;
  Motion motion = pm.motion;
  const IdentifyResult r = identify(pm.body, motion, imu, o);
  EXPECT_TRUE(r.unobservable.empty());
  EXPECT_LT((r.placement.p_joint_sensor - tr.placement.p_joint_sensor).norm(), 0.005);
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, tr.placement.q_joint_sensor),
            0.5 * kRadPerDeg);
  EXPECT_NEAR(r.time_offset_s, tr.dt, 0.001);
  // The samples reading a gap (plus a 3-frame guard) are left out.
  EXPECT_GT(r.samples_excluded, 24 + 5);
  EXPECT_LT(r.rms_after.accel, 1.1 * tr.sigma_a);
}

// BROAD trial 02 (slow rotation), 12 s of its motion phase: the fit must explain the real
// gyroscope and accelerometer better than the raw pose track does, with a lag of a few ms
// (the README: IMU about 1 - 1.5 samples late) and a lever arm of a few cm.
TEST(Identify, BroadRealRecording) {
  IMUKIT_REQUIRE_DATA(data);
  const auto path = (data / "broad" / "02_undisturbed_slow_rotation_B.csv").string();
  const ColumnTable imu_table = read_column_text(path, ColumnSpec::parse("t,ax,ay,az,gx,gy,gz,_*"));
  const ColumnTable pose_table = read_column_text(
      path, ColumnSpec::parse("t,_9,qw,qx,qy,qz,px,py,pz,_", "qw,qx,qy,qz,px,py,pz"));
  // 60 .. 72 s of the motion phase.
  const std::size_t a = 60 * 285, b = 72 * 285;
  ImuSeries full = to_imu_series(imu_table);
  ImuSeries imu = ImuSeries::with_channels(b - a, true, true);
  for (std::size_t i = a; i < b; ++i) {
    imu.t[i - a] = full.t[i];
    imu.accel.col(static_cast<Eigen::Index>(i - a)) = full.accel.col(static_cast<Eigen::Index>(i));
    imu.gyro.col(static_cast<Eigen::Index>(i - a)) = full.gyro.col(static_cast<Eigen::Index>(i));
  }
  PoseTrack track;
  track.p_world_body.resize(3, static_cast<Eigen::Index>(b - a + 600));
  for (std::size_t i = a - 300; i < b + 300; ++i) {
    track.t.push_back(pose_table.t[i]);
    track.q_world_body.emplace_back(pose_table[Column::qw][i], pose_table[Column::qx][i],
                                    pose_table[Column::qy][i], pose_table[Column::qz][i]);
    track.p_world_body.col(static_cast<Eigen::Index>(i - (a - 300))) =
        Vector3d(pose_table[Column::px][i], pose_table[Column::py][i], pose_table[Column::pz][i]);
  }
  const PoseMotion pm = pose_track_motion(track, path);
  IdentifyOptions o;
  o.joint = 0;
  o.motion_start_ns = pm.start_ns;
  o.invalid_motion = pm.gaps;
  o.init_rotation_from_data = false;
  Motion motion = pm.motion;
  const IdentifyResult r = identify(pm.body, motion, imu, o);
  EXPECT_TRUE(r.unobservable.empty());
  // The gyro residual is dominated by the optical rate's own noise (README: ~0.09 rad/s), so
  // the lag and bias only shave a little off; the accelerometer gains from the lever arm.
  EXPECT_LT(r.rms_after.gyro, r.rms_before.gyro);
  EXPECT_LT(r.rms_after.accel, 0.8 * r.rms_before.accel);
  EXPECT_LT(r.time_offset_s, -0.002);
  EXPECT_GT(r.time_offset_s, -0.008);
  EXPECT_GT(r.placement.p_joint_sensor.norm(), 0.01);
  EXPECT_LT(r.placement.p_joint_sensor.norm(), 0.15);
  EXPECT_LT(angular_distance(r.placement.q_joint_sensor, Quaterniond::Identity()), 2 * kRadPerDeg);
}

}  // namespace
}  // namespace imukit::sim
