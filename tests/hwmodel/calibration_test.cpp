#include "imukit/hwmodel/calibration.hpp"

#include <gtest/gtest.h>

#include <limits>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace imukit::hwmodel {
namespace {

struct Synthetic {
  std::vector<TimeNs> t;
  Eigen::Matrix3Xd accel, gyro;
};

// A multi-position session at 100 Hz: 50 s static, then for each target orientation a
// rotation (about a fixed body axis, smooth speed profile; 2 s unless turn_seconds[p] says
// otherwise) and a 4 s rest. Readings are made with the true calibrations
// (raw = (T diag(scale))^-1 true + bias) plus white noise.
Synthetic make_session(const std::vector<Eigen::Matrix3d>& poses, const TriadCalibration& acc,
                       const TriadCalibration& gyr, double g, double noise, uint64_t seed,
                       double gyro_counts_per_count = 1.0,
                       const std::vector<double>& turn_seconds = {}) {
  const double rate = 100.0, dt = 1.0 / rate;
  std::vector<Eigen::Vector3d> f, w;
  Eigen::Matrix3d R = poses.front();
  auto rest = [&](double seconds) {
    for (int i = 0; i < int(seconds * rate); ++i) {
      f.push_back(R.transpose() * Eigen::Vector3d(0, 0, g));
      w.push_back(Eigen::Vector3d::Zero());
    }
  };
  rest(50.0);
  for (size_t p = 1; p < poses.size(); ++p) {
    const Eigen::AngleAxisd delta(R.transpose() * poses[p]);
    const Eigen::Vector3d phi = delta.angle() * delta.axis();
    const Eigen::Matrix3d R0 = R;
    const double seconds = p < turn_seconds.size() ? turn_seconds[p] : 2.0;
    const int steps = int(seconds * rate);
    for (int i = 0; i < steps; ++i) {
      // s(u) = (1 - cos(pi u)) / 2 over u in [0, 1]; rate is ds/dt phi, constant in direction.
      const double u = (i + 0.5) / steps;
      const double sdot = 0.5 * std::numbers::pi * std::sin(std::numbers::pi * u) / seconds;
      const double s = 0.5 * (1.0 - std::cos(std::numbers::pi * (i + 1.0) / steps));
      w.push_back(sdot * phi);
      R = R0 * Eigen::AngleAxisd(s * phi.norm(), phi.normalized()).toRotationMatrix();
      f.push_back(R.transpose() * Eigen::Vector3d(0, 0, g));
    }
    R = poses[p];
    rest(4.0);
  }
  Synthetic out;
  const auto n = Eigen::Index(f.size());
  out.accel.resize(3, n);
  out.gyro.resize(3, n);
  Rng rng(seed);
  const Eigen::Matrix3d Ainv = (acc.T * acc.scale.asDiagonal()).inverse();
  const Eigen::Matrix3d Ginv = (gyr.T * gyr.scale.asDiagonal()).inverse();
  for (Eigen::Index i = 0; i < n; ++i) {
    out.t.push_back(sample_time(0, i, rate));
    const Eigen::Vector3d na(rng.normal(), rng.normal(), rng.normal());
    const Eigen::Vector3d ng(rng.normal(), rng.normal(), rng.normal());
    out.accel.col(i) = Ainv * f[size_t(i)] + acc.bias + noise * 50.0 * na;
    out.gyro.col(i) = Ginv * w[size_t(i)] + gyr.bias + noise * gyro_counts_per_count * ng;
  }
  (void)dt;
  return out;
}

std::vector<Eigen::Matrix3d> many_poses(int count, uint64_t seed) {
  Rng rng(seed);
  std::vector<Eigen::Matrix3d> p{Eigen::Matrix3d::Identity()};
  for (int i = 1; i < count; ++i) {
    // Random axis and a turn of 60..150 degrees from the previous pose: every axis gets tilted
    // and rotated about.
    Eigen::Vector3d axis(rng.normal(), rng.normal(), rng.normal());
    const double angle = rng.uniform(1.0, 2.6);
    p.push_back(p.back() * Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix());
  }
  return p;
}

TriadCalibration accel_truth() {
  TriadCalibration c;
  c.T << 1, -0.01, 0.02, 0, 1, -0.015, 0, 0, 1;
  c.scale = Eigen::Vector3d(1.0 / 410.0, 1.0 / 395.0, 1.0 / 402.0);  // counts -> m/s^2
  c.bias = Eigen::Vector3d(32768.0 + 120.0, 32768.0 - 80.0, 32768.0 + 40.0);
  return c;
}
TriadCalibration gyro_truth() {
  TriadCalibration c;
  c.T << 1, 0.01, -0.02, 0.015, 1, 0.005, -0.01, 0.02, 1;
  c.scale = Eigen::Vector3d(1.0 / 5000.0, 1.0 / 5200.0, 1.0 / 4900.0);  // counts -> rad/s
  c.bias = Eigen::Vector3d(32768.0 + 30.0, 32768.0 - 20.0, 32768.0 + 10.0);
  return c;
}

TEST(Calibration, RecoversKnownAccelerometerAndGyroscopeCalibration) {
  const double g = 9.81;
  const auto acc = accel_truth();
  const auto gyr = gyro_truth();
  const Synthetic s = make_session(many_poses(25, 4), acc, gyr, g, 0.5, 9);
  CalibrationOptions opt;
  opt.gravity = g;
  const CalibrationResult r = calibrate(s.t, s.accel, s.gyro, opt);
  EXPECT_GE(r.poses.size(), 25u - 2u);
  for (int a = 0; a < 3; ++a) {
    // Pose means carry about 1.3 counts of noise (25 counts per sample, 400 samples), a few
    // parts in 1e4 of the +-4000-count gravity swing: tolerances are a few times that.
    EXPECT_NEAR(r.accel.scale(a), acc.scale(a), 1e-3 * acc.scale(a)) << a;
    EXPECT_NEAR(r.accel.bias(a), acc.bias(a), 3.0) << a;  // counts
    EXPECT_NEAR(r.gyro.scale(a), gyr.scale(a), 2e-3 * gyr.scale(a)) << a;
    EXPECT_NEAR(r.gyro.bias(a), gyr.bias(a), 0.6) << a;
  }
  EXPECT_TRUE(r.accel.T.isApprox(acc.T, 1e-3));
  EXPECT_LT((r.gyro.T - gyr.T).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(r.accel_rms, 0.01);  // m/s^2
  EXPECT_LT(r.gyro_rms_rad, 2e-3);
}

// Found in review: 32-bit offset-binary counts (biases near 3e9, scales near 2e-9 rad/s per
// count) left the gyroscope at its starting guess (scale errors of 1.4-3.1 %, exit 0): the
// solver's relative step test saw the biases' size. The fit now works relative to its start.
TEST(Calibration, GyroscopeOfThirtyTwoBitCountsCalibratesAsWellAsSixteenBit) {
  const double g = 9.81;
  const auto acc = accel_truth();
  TriadCalibration gyr = gyro_truth();
  gyr.scale /= 3e4;  // counts -> rad/s: 30000 times finer
  gyr.bias = Eigen::Vector3d(3.0e9 + 30.0 * 3e4, 3.0e9 - 20.0 * 3e4, 3.0e9 + 10.0 * 3e4);
  const Synthetic s = make_session(many_poses(25, 4), acc, gyr, g, 0.5, 9, 3e4);
  CalibrationOptions opt;
  opt.gravity = g;
  const CalibrationResult r = calibrate(s.t, s.accel, s.gyro, opt);
  for (int a = 0; a < 3; ++a) {
    // The tolerances of the 16-bit case above, the bias's in its counts.
    EXPECT_NEAR(r.gyro.scale(a), gyr.scale(a), 2e-3 * gyr.scale(a)) << a;
    EXPECT_NEAR(r.gyro.bias(a), gyr.bias(a), 0.6 * 3e4) << a;
  }
  EXPECT_LT((r.gyro.T - gyr.T).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(r.gyro_rms_rad, 2e-3);
}

TEST(Calibration, ReportsRankDeficiencyWhenPosesTiltOnlyAboutOneAxis) {
  // All poses are rotations about x: gravity never gets a component on x, so the x scale and
  // bias are not determined.
  std::vector<Eigen::Matrix3d> poses;
  for (int i = 0; i < 14; ++i)
    poses.push_back(Eigen::AngleAxisd(0.45 * i, Eigen::Vector3d::UnitX()).toRotationMatrix());
  const Synthetic s = make_session(poses, accel_truth(), gyro_truth(), 9.81, 0.5, 3);
  CalibrationOptions opt;
  opt.gravity = 9.81;
  try {
    calibrate(s.t, s.accel, s.gyro, opt);
    FAIL() << "expected a rank-deficiency error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("do not excite all axes"), std::string::npos) << e.what();
    // Not "too few poses": the CLI's hint about the initial static period is not for this one.
    EXPECT_EQ(dynamic_cast<const TooFewPosesError*>(&e), nullptr) << e.what();
    std::printf("%s\n", e.what());
  }
}

TEST(Calibration, ADeadGyroscopeIsSaidToBeDeadNotUnexcited) {
  Synthetic s = make_session(many_poses(12, 4), accel_truth(), gyro_truth(), 9.81, 0.5, 9);
  s.gyro.row(1).setZero();
  CalibrationOptions opt;
  opt.gravity = 9.81;
  try {
    calibrate(s.t, s.accel, s.gyro, opt);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the gyroscope's y axis reads 0 in every sample"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--no-gyro"), std::string::npos) << e.what();
  }
  opt.calibrate_gyro = false;  // the accelerometer alone still calibrates
  EXPECT_GE(calibrate(s.t, s.accel, s.gyro, opt).poses.size(), 9u);
}

// Review, 2026-11-27: a NaN sample (a gap declared with --gaps) aborted the process (an SVD of
// the empty matrix Ceres left after NaN residuals), and one outside the poses silently dropped
// its axis from the static detector. Every non-finite sample is refused, named.
TEST(Calibration, ANonFiniteSampleIsRefusedNamingIt) {
  for (const bool in_gyro : {false, true}) {
    Synthetic s = make_session(many_poses(12, 4), accel_truth(), gyro_truth(), 9.81, 0.5, 9);
    const Eigen::Index i = s.accel.cols() / 2;
    (in_gyro ? s.gyro : s.accel)(0, i) = std::numeric_limits<double>::quiet_NaN();
    CalibrationOptions opt;
    opt.gravity = 9.81;
    try {
      calibrate(s.t, s.accel, s.gyro, opt);
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(std::string(in_gyro ? "gyroscope" : "accelerometer") + " sample " +
                          std::to_string(i) + " (t = "),
                std::string::npos)
          << what;
      EXPECT_NE(what.find("is not finite (nan, "), std::string::npos) << what;
    }
    if (in_gyro) {  // the accelerometer alone still calibrates without the gyroscope
      opt.calibrate_gyro = false;
      EXPECT_GE(calibrate(s.t, s.accel, s.gyro, opt).poses.size(), 9u);
    }
  }
}

// Found in review, 2026-11-27: samples missing inside a rotation were integrated across with
// the last rate held (0.4 s lost in 5 of 13 rotations moved the y scale by 1.7 % and the z bias
// by 56 %, with a residual no larger than a real session's). Such a gap is now named.
TEST(Calibration, SamplesMissingInsideARotationAreNamed) {
  const Synthetic s = make_session(many_poses(12, 4), accel_truth(), gyro_truth(), 9.81, 0.5, 9);
  // The first rotation runs from sample 5000 (after 50 s at rest) for 200 samples: drop 40 of
  // them in its middle.
  Synthetic gap;
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < s.accel.cols(); ++i)
    if (i < 5080 || i >= 5120) keep.push_back(i);
  gap.accel.resize(3, Eigen::Index(keep.size()));
  gap.gyro.resize(3, Eigen::Index(keep.size()));
  for (size_t k = 0; k < keep.size(); ++k) {
    gap.t.push_back(s.t[size_t(keep[k])]);
    gap.accel.col(Eigen::Index(k)) = s.accel.col(keep[k]);
    gap.gyro.col(Eigen::Index(k)) = s.gyro.col(keep[k]);
  }
  CalibrationOptions opt;
  opt.gravity = 9.81;
  EXPECT_NO_THROW(calibrate(s.t, s.accel, s.gyro, opt));
  testing::expect_error([&] { calibrate(gap.t, gap.accel, gap.gyro, opt); },
                        {"gyroscope calibration: samples are missing in the rotation between "
                         "poses 1 and 2 (a step of 0.4100 s at t = 50.790 s, where the median "
                         "period is 0.0100 s)"});
  opt.calibrate_gyro = false;  // the accelerometer's poses are untouched
  EXPECT_GE(calibrate(gap.t, gap.accel, gap.gyro, opt).poses.size(), 9u);
}

// Found in review, 2026-11-27: poses tilted at most 30 degrees from z up pass the rank test but
// leave the z bias 9-23 % off with a residual of 1e-5 m/s^2. Each axis must be held up and down.
TEST(Calibration, PosesThatNeverTurnAnAxisDownAreRefused) {
  // Tilts about x and y of 0 or +-30 degrees (and their combinations, up to 42 degrees).
  std::vector<Eigen::Matrix3d> poses;
  for (const auto& [a, b] : std::vector<std::pair<double, double>>{{0, 0},
                                                                   {30, 0},
                                                                   {-30, 0},
                                                                   {0, 30},
                                                                   {0, -30},
                                                                   {30, 30},
                                                                   {-30, -30},
                                                                   {30, -30},
                                                                   {-30, 30},
                                                                   {15, 0},
                                                                   {0, 15},
                                                                   {0, 0}}) {
    const double r = std::numbers::pi / 180.0;
    poses.push_back((Eigen::AngleAxisd(a * r, Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(b * r, Eigen::Vector3d::UnitY()))
                        .toRotationMatrix());
  }
  const Synthetic s = make_session(poses, accel_truth(), gyro_truth(), 9.81, 0.5, 9);
  CalibrationOptions opt;
  opt.gravity = 9.81;
  opt.calibrate_gyro = false;
  testing::expect_error([&] { calibrate(s.t, s.accel, s.gyro, opt); },
                        {"calibration: the accelerometer's x axis was not held both up and down",
                         "hold the sensor in more orientations, each axis up and down"});
}

TEST(Calibration, RejectsTooFewPoses) {
  std::vector<TimeNs> t;
  Eigen::Matrix3Xd a = Eigen::Matrix3Xd::Zero(3, 7000), w = Eigen::Matrix3Xd::Zero(3, 7000);
  for (int i = 0; i < 7000; ++i) t.push_back(sample_time(0, i, 100.0));
  a.row(2).setConstant(9.8);
  EXPECT_THROW(calibrate(t, a, w, CalibrationOptions{}), TooFewPosesError);
}

// Found in review: the threshold search compared the plain rms of fits with different pose
// counts, and a fit of exactly 9 poses near the gravity sphere passes through all of them. Here
// three of the twelve turns are slow (20 degrees in 8 s): a small k keeps them apart as twelve
// poses, a large k reads the slow turns as stillness and merges their neighbours into 9 poses
// whose means are no true pose. The search must keep the twelve.
TEST(Calibration, ThresholdSearchDoesNotPreferAFitWithoutSparePoses) {
  const double g = 9.81;
  const auto acc = accel_truth();
  const auto gyr = gyro_truth();
  std::vector<Eigen::Matrix3d> poses = many_poses(9, 4);
  std::vector<double> turn_seconds(poses.size(), 2.0);
  for (size_t p : {2u, 5u, 8u}) {  // a slow 20-degree turn after poses 2, 5 and 8
    poses.insert(
        poses.begin() + long(p) + 1,
        poses[p] * Eigen::AngleAxisd(20.0 * kRadPerDeg, Eigen::Vector3d(1, 1, 0).normalized())
                       .toRotationMatrix());
    turn_seconds.insert(turn_seconds.begin() + long(p) + 1, 8.0);
  }
  ASSERT_EQ(poses.size(), 12u);
  const Synthetic s = make_session(poses, acc, gyr, g, 0.5, 9, 1.0, turn_seconds);
  CalibrationOptions opt;
  opt.gravity = g;
  opt.calibrate_gyro = false;
  // The premise: some factor finds the twelve poses, and a larger one only 9.
  std::vector<size_t> found;
  for (int k = 1; k <= opt.max_threshold_factor; ++k) {
    StaticDetectorOptions d = opt.detector;
    d.threshold_factor = k;
    found.push_back(detect_static_intervals(s.t, s.accel, d).size());
  }
  ASSERT_NE(std::find(found.begin(), found.end(), 12u), found.end())
      << ::testing::PrintToString(found);
  ASSERT_NE(std::find(found.begin(), found.end(), 9u), found.end())
      << ::testing::PrintToString(found);

  const CalibrationResult r = calibrate(s.t, s.accel, s.gyro, opt);
  EXPECT_EQ(r.poses.size(), 12u) << "k = " << r.threshold_factor;
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(r.accel.scale(a), acc.scale(a), 2e-3 * acc.scale(a)) << a;
    // Counts (about 400 per m/s^2): 12 poses, three of them next to a slow turn whose ends
    // the detector counts as still, so a few counts off (5.6 on one axis in the clang build).
    EXPECT_NEAR(r.accel.bias(a), acc.bias(a), 10.0) << a;
  }
}

TEST(Calibration, ForwardModelInvertsTheCorrection) {
  // profile.hpp's forward model raw = diag(s) M true + bias with unit-diagonal M must undo
  // apply() for both the triangular (accelerometer) and full (gyroscope) misalignment.
  for (const TriadCalibration& c : {accel_truth(), gyro_truth()}) {
    const Eigen::Matrix3d M = c.forward_misalignment();
    EXPECT_NEAR((M.diagonal() - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff(), 0.0, 1e-15);
    const Eigen::Vector3d truth(0.3, -1.2, 9.0);
    const Eigen::Vector3d raw = c.forward_scale().asDiagonal() * M * truth + c.bias;
    EXPECT_LT((c.apply(raw) - truth).norm(), 1e-12 * truth.norm());
  }
}

TEST(TurnOnBias, MeanAndSpreadAcrossRuns) {
  const TurnOnBias s = turn_on_bias_stats(
      {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(3, 2, 1), Eigen::Vector3d(2, 2, 2)});
  ASSERT_TRUE(s.runs.has_value());
  EXPECT_EQ(*s.runs, 3);
  EXPECT_TRUE(s.mean.isApprox(Eigen::Vector3d(2, 2, 2)));
  EXPECT_NEAR(s.spread(0), 1.0, 1e-15);
  EXPECT_NEAR(s.spread(1), 0.0, 1e-15);
  // Accelerometer at rest, z up, reading 0.1 too much on x: bias (0.1, 0, 0).
  Eigen::Matrix3Xd acc(3, 2);
  acc << 0.1, 0.1, 0, 0, 9.8, 9.8;
  EXPECT_TRUE(accel_static_bias(acc, Eigen::Matrix3d::Identity(), 9.8)
                  .isApprox(Eigen::Vector3d(0.1, 0, 0)));
  // Turned +90 degrees about x: the sensor's y axis points up (R_world_sensor e_y = e_z), so
  // at rest y reads +g. Readings (0.1, 9.8, 0) leave the same bias; with R instead of R^T the
  // expected reading would be (0, -9.8, 0) and the bias (0.1, 19.6, 0).
  const Eigen::Matrix3d R_world_sensor =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  ASSERT_NEAR((R_world_sensor * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 0.0,
              1e-15);
  Eigen::Matrix3Xd turned(3, 2);
  turned << 0.1, 0.1, 9.8, 9.8, 0, 0;
  EXPECT_LT((accel_static_bias(turned, R_world_sensor, 9.8) - Eigen::Vector3d(0.1, 0, 0)).norm(),
            1e-12);
}

TEST(Calibration, XsensRecordingCalibratesToGravity) {
  IMUKIT_REQUIRE_DATA(data);
  const auto spec = ColumnSpec::parse("t,ax,ay,az");
  const ImuSeries acc =
      to_imu_series(read_column_text((data / "imu_tk_xsens/xsens_acc.txt").string(), spec));
  const auto gspec = ColumnSpec::parse("t,gx,gy,gz");
  const ImuSeries gyr =
      to_imu_series(read_column_text((data / "imu_tk_xsens/xsens_gyro.txt").string(), gspec));
  ASSERT_EQ(acc.t, gyr.t);
  CalibrationOptions opt;
  opt.gravity = 9.81744;
  const CalibrationResult r = calibrate(acc.t, acc.accel, gyr.gyro, opt);
  EXPECT_GE(r.poses.size(), 30u);
  // The static means' norms after calibration match g to better than 0.02 m/s^2 rms.
  EXPECT_LT(r.accel_rms, 0.02);
  EXPECT_LT(r.gyro_rms_rad, 0.03);  // measured 0.019 rad (docs/validation.md)
  // Xsens MTi raw counts: roughly 400 counts per m/s^2 and a mid-scale offset near 32768.
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(1.0 / r.accel.scale(a), 300.0);
    EXPECT_LT(1.0 / r.accel.scale(a), 500.0);
    EXPECT_NEAR(r.accel.bias(a), 32768.0, 2000.0);
  }
  // Its run time is the benchmark's business (bench_hwmodel BM_CalibrateXsens), not a test's:
  // a wall-clock bound fails on a loaded machine and under the sanitizers.

  // Leave poses out: fit on 70 % of the poses (every pose whose index mod 10 is not 2, 5 or
  // 8), check the norm of the other 30 % against g.
  std::vector<Eigen::Vector3d> train, held;
  for (size_t i = 0; i < r.poses.size(); ++i) {
    const Eigen::Vector3d m = interval_mean(acc.accel, r.poses[i]);
    (i % 10 == 2 || i % 10 == 5 || i % 10 == 8 ? held : train).push_back(m);
  }
  const TriadCalibration c70 = fit_accelerometer(train, opt.gravity);
  double ss = 0.0;
  for (const auto& m : held) ss += std::pow(c70.apply(m).norm() - opt.gravity, 2);
  const double held_rms = std::sqrt(ss / double(held.size()));
  EXPECT_LT(held_rms, 0.005) << held_rms;  // measured 0.0016 m/s^2 (docs/validation.md)
}

}  // namespace
}  // namespace imukit::hwmodel
