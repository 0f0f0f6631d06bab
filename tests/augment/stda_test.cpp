// STDA methods: shape and identity, per-call variation, replay against hand-computed results,
// and the distributions of the drawn parameters.
#include "imukit/augment/stda.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "imukit/core/error.hpp"
#include "support/numbers.hpp"

namespace imukit::augment {
namespace {

// A smooth, non-trivial batch: every channel a different sinusoid plus an offset.
std::vector<double> make_batch(const BatchShape& s, double phase = 0.0) {
  std::vector<double> x(s.size());
  for (std::size_t w = 0; w < s.windows; ++w)
    for (std::size_t i = 0; i < s.samples; ++i)
      for (std::size_t c = 0; c < s.channels; ++c)
        x[(w * s.samples + i) * s.channels + c] =
            0.5 * static_cast<double>(c) +
            std::sin(0.07 * static_cast<double>(i) * static_cast<double>(c + 1) + phase +
                     static_cast<double>(w));
  return x;
}

StdaSpec spec_of(StdaMethod m) {
  StdaSpec s;
  s.method = m;
  s.sigma = 0.2;
  s.knots = 2;
  s.lo = 0.8;
  s.hi = 1.4;
  s.ratio = 1.5;
  s.jitter_sigma[0] = 0.1;
  s.jitter_sigma[1] = 0.01;
  return s;
}

const StdaMethod kMethods[] = {StdaMethod::magnitude_scaling, StdaMethod::magnitude_warping,
                               StdaMethod::time_scaling,      StdaMethod::time_warping,
                               StdaMethod::rotation,          StdaMethod::jittering};

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

TEST(Stda, ImuLayoutIsAccelThenGyroPerSensor) {
  const ChannelLayout l = ChannelLayout::imu({"wrist", "ankle"});
  ASSERT_EQ(l.kinds.size(), 12u);
  EXPECT_EQ(l.kinds[0], ChannelKind::accelerometer);
  EXPECT_EQ(l.kinds[3], ChannelKind::gyroscope);
  EXPECT_EQ(l.kinds[6], ChannelKind::accelerometer);
  ASSERT_EQ(l.sensors.size(), 2u);
  EXPECT_EQ(l.sensors[1].triads, (std::vector<std::size_t>{6, 9}));
  EXPECT_NO_THROW(l.validate(12));
  EXPECT_THROW(l.validate(11), Error);
}

TEST(Stda, IdentityParametersLeaveTheBatchUnchanged) {
  const BatchShape shape{4, 50, 12};
  const ChannelLayout layout = ChannelLayout::imu({"a", "b"});
  for (StdaMethod m : kMethods) {
    StdaSpec s;
    s.method = m;  // every parameter at its identity default: sigma 0, b 1, r 1, angles 0, jitter 0
    for (double& a : s.max_angle_rad) a = 0.0;
    std::vector<double> x = make_batch(shape);
    const std::vector<double> x0 = x;
    Rng rng(7);
    apply_stda(s, layout, x, shape, rng);
    EXPECT_LE(max_abs_diff(x, x0), 1e-12) << to_string(m);
  }
}

TEST(Stda, ShapeIsKeptAndCallsVaryUnderOneRngButRepeatUnderTheSameSeed) {
  const BatchShape shape{3, 40, 6};
  const ChannelLayout layout = ChannelLayout::imu({"s"});
  for (StdaMethod m : kMethods) {
    const StdaSpec s = spec_of(m);
    std::vector<float> a(shape.size()), b(shape.size()), c(shape.size());
    const std::vector<double> x = make_batch(shape);
    std::copy(x.begin(), x.end(), a.begin());
    b = a;
    c = a;
    Rng rng(11);
    apply_stda(s, layout, a, shape, rng);
    apply_stda(s, layout, b, shape, rng);  // same rng, advanced: different draws
    Rng rng2(11);
    apply_stda(s, layout, c, shape, rng2);
    EXPECT_EQ(a.size(), shape.size());
    EXPECT_NE(a, b) << to_string(m);
    EXPECT_EQ(a, c) << to_string(m);
    // Windows of one call differ from each other too (one draw per window).
    std::vector<float> d(shape.size());
    for (std::size_t w = 0; w < shape.windows; ++w)
      std::copy(x.begin(), x.begin() + 40 * 6, d.begin() + static_cast<std::ptrdiff_t>(w * 240));
    Rng rng3(3);
    apply_stda(s, layout, d, shape, rng3);
    EXPECT_FALSE(std::equal(d.begin(), d.begin() + 240, d.begin() + 240)) << to_string(m);
  }
}

TEST(Stda, ReplayGivesTheLoggedResultBitForBit) {
  const BatchShape shape{5, 30, 12};
  const ChannelLayout layout = ChannelLayout::imu({"a", "b"});
  for (StdaMethod m : kMethods) {
    StdaSpec s = spec_of(m);
    s.per_channel = m == StdaMethod::magnitude_warping;
    std::vector<double> x = make_batch(shape), y = x;
    Rng rng(5);
    StdaDraws log;
    apply_stda(s, layout, x, shape, rng, &log);
    EXPECT_EQ(log.values.size(), log.per_window * shape.windows);
    replay_stda(s, layout, y, shape, log);
    EXPECT_EQ(x, y) << to_string(m);
    StdaDraws bad = log;
    bad.values.pop_back();
    EXPECT_THROW(replay_stda(s, layout, y, shape, bad), Error);
  }
}

TEST(Stda, ReplayedDrawsGiveHandComputedResults) {
  const std::size_t T = 101;
  const BatchShape shape{1, T, 6};
  const ChannelLayout layout = ChannelLayout::imu({"s"});
  // A ramp: channel c at sample i holds i + 1000 c.
  std::vector<double> ramp(shape.size());
  for (std::size_t i = 0; i < T; ++i)
    for (std::size_t c = 0; c < 6; ++c) ramp[i * 6 + c] = static_cast<double>(i) + 1000.0 * c;

  {  // Magnitude scaling by a = 1.5.
    StdaSpec s = spec_of(StdaMethod::magnitude_scaling);
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, 1, {1.5}});
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_DOUBLE_EQ(x[k], 1.5 * ramp[k]);
  }
  {  // Magnitude warping through collinear knots 1, 2, 3, 4: the spline is the line 1 + 3 t/(T-1).
    StdaSpec s = spec_of(StdaMethod::magnitude_warping);
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, 4, {1.0, 2.0, 3.0, 4.0}});
    for (std::size_t i = 0; i < T; ++i) {
      const double a = 1.0 + 3.0 * static_cast<double>(i) / 100.0;
      EXPECT_NEAR(x[i * 6 + 2], a * ramp[i * 6 + 2], 1e-9);
    }
  }
  {  // Time scaling by b = 2 around the centre 50: sample i reads 50 + 2 (i - 50), held at the
     // ends.
    StdaSpec s = spec_of(StdaMethod::time_scaling);
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, 1, {2.0}});
    for (std::size_t i = 0; i < T; ++i) {
      const double p = std::clamp(50.0 + 2.0 * (static_cast<double>(i) - 50.0), 0.0, 100.0);
      EXPECT_DOUBLE_EQ(x[i * 6 + 1], p + 1000.0);
    }
  }
  {  // Time warping, K = 1, r = 2, u = (0.2, 0.8): speeds u + 0.4 = (0.6, 1.2), knots (0, 100/3,
     // 100) at anchors (0, 50, 100): output sample 50 reads position 100/3.
    StdaSpec s = spec_of(StdaMethod::time_warping);
    s.knots = 1;
    s.ratio = 2.0;
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, 2, {0.2, 0.8}});
    EXPECT_NEAR(x[50 * 6], 100.0 / 3.0, 1e-9);
    EXPECT_DOUBLE_EQ(x[0], 0.0);
    EXPECT_NEAR(x[100 * 6], 100.0, 1e-9);
  }
  {  // Rotation by 90 degrees about x: (x, y, z) -> (x, -z, y), accelerometer and gyroscope alike.
    StdaSpec s = spec_of(StdaMethod::rotation);
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, 3, {kPi / 2, 0.0, 0.0}});
    for (std::size_t i = 0; i < T; i += 10) {
      for (std::size_t b : {0u, 3u}) {
        EXPECT_NEAR(x[i * 6 + b + 0], ramp[i * 6 + b + 0], 1e-9);
        EXPECT_NEAR(x[i * 6 + b + 1], -ramp[i * 6 + b + 2], 1e-9);
        EXPECT_NEAR(x[i * 6 + b + 2], ramp[i * 6 + b + 1], 1e-9);
      }
    }
  }
  {  // Jittering with every normal draw = 1: accelerometer + 0.1, gyroscope + 0.01.
    StdaSpec s = spec_of(StdaMethod::jittering);
    std::vector<double> x = ramp;
    replay_stda(s, layout, x, shape, {s.method, T * 6, std::vector<double>(T * 6, 1.0)});
    for (std::size_t i = 0; i < T; ++i) {
      EXPECT_DOUBLE_EQ(x[i * 6 + 1], ramp[i * 6 + 1] + 0.1);
      EXPECT_DOUBLE_EQ(x[i * 6 + 4], ramp[i * 6 + 4] + 0.01);
    }
  }
}

// Mean and standard deviation.
std::pair<double, double> moments(const std::vector<double>& v) {
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double sq = 0.0;
  for (double x : v) sq += (x - mean) * (x - mean);
  return {mean, std::sqrt(sq / static_cast<double>(v.size() - 1))};
}

TEST(Stda, DrawnParametersFollowTheirDistributions) {
  const std::size_t N = 20000;
  const ChannelLayout layout = ChannelLayout::imu({"s"});
  const BatchShape shape{N, 2, 6};
  std::vector<double> x(shape.size(), 1.0);
  Rng rng(2024);
  {  // a ~ N(1, 0.4^2): mean within 4 standard errors, sigma within 3 %.
    StdaSpec s = spec_of(StdaMethod::magnitude_scaling);
    s.sigma = 0.4;
    StdaDraws log;
    apply_stda(s, layout, x, shape, rng, &log);
    const auto [m, sd] = moments(log.values);
    EXPECT_NEAR(m, 1.0, 4 * 0.4 / std::sqrt(double(N)));
    EXPECT_NEAR(sd, 0.4, 0.03 * 0.4);
  }
  {  // b ~ U[0.5, 2]: inside, mean 1.25, sd 1.5 / sqrt(12).
    StdaSpec s = spec_of(StdaMethod::time_scaling);
    s.lo = 0.5;
    s.hi = 2.0;
    StdaDraws log;
    apply_stda(s, layout, x, shape, rng, &log);
    const auto [m, sd] = moments(log.values);
    EXPECT_GE(*std::min_element(log.values.begin(), log.values.end()), 0.5);
    EXPECT_LT(*std::max_element(log.values.begin(), log.values.end()), 2.0);
    EXPECT_NEAR(m, 1.25, 4 * 1.5 / std::sqrt(12.0 * N));
    EXPECT_NEAR(sd, 1.5 / std::sqrt(12.0), 0.02);
  }
  {  // Rotation angles ~ U[-pi, pi] per axis.
    StdaSpec s = spec_of(StdaMethod::rotation);
    StdaDraws log;
    apply_stda(s, layout, x, shape, rng, &log);
    const auto [m, sd] = moments(log.values);
    EXPECT_NEAR(m, 0.0, 4 * 2 * kPi / std::sqrt(12.0 * 3 * N));
    EXPECT_NEAR(sd, 2 * kPi / std::sqrt(12.0), 0.03);
    for (double a : log.values) EXPECT_LE(std::abs(a), kPi);
  }
}

TEST(Stda, TimeWarpRealisesTheSpeedRatioExactly) {
  // T = 101, K = 4: the K + 2 = 6 anchors fall on samples 0, 20, ..., 100, so the realised
  // average speed of each segment is (pos[20 (k+1)] - pos[20 k]) / 20.
  const std::size_t T = 101;
  Rng rng(99);
  for (double r : {1.5, 2.0, 4.0}) {
    for (int trial = 0; trial < 500; ++trial) {
      std::vector<double> u(5);
      for (double& v : u) v = rng.uniform();
      const std::vector<double> v = time_warp_speeds(u, r);
      const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
      EXPECT_NEAR(*mx / *mn, r, 1e-9 * r);
      const std::vector<double> pos = time_warp_positions(u, r, T);
      std::vector<double> seg;
      for (int k = 0; k < 5; ++k) seg.push_back(pos[20 * (k + 1)] - pos[20 * k]);
      const auto [smn, smx] = std::minmax_element(seg.begin(), seg.end());
      EXPECT_NEAR(*smx / *smn, r, 1e-9 * r);
      EXPECT_DOUBLE_EQ(pos.front(), 0.0);
      EXPECT_NEAR(pos.back(), 100.0, 1e-12);
      for (std::size_t i = 1; i < T; ++i) EXPECT_GT(pos[i], pos[i - 1]);  // PCHIP keeps it monotone
    }
  }
}

TEST(Stda, JitterHasTheStatedSigmaPerChannelKind) {
  const BatchShape shape{200, 100, 6};
  const ChannelLayout layout = ChannelLayout::imu({"s"});
  std::vector<float> x(shape.size(), 0.0f);
  StdaSpec s = spec_of(StdaMethod::jittering);
  s.jitter_sigma[0] = 0.2;   // m/s^2
  s.jitter_sigma[1] = 0.02;  // rad/s
  Rng rng(1);
  apply_stda(s, layout, x, shape, rng);
  std::vector<double> acc, gyr;
  for (std::size_t k = 0; k < x.size(); ++k) (k % 6 < 3 ? acc : gyr).push_back(x[k]);
  EXPECT_NEAR(moments(acc).second, 0.2, 0.2 * 0.01);
  EXPECT_NEAR(moments(gyr).second, 0.02, 0.02 * 0.01);
}

// One rotation per window for every sensor, the paper's X'_n = R X_n: each sensor drew its own
// until review, 2026-11-27, which turned the sensors relative to each other.
TEST(Stda, RotationTurnsEverySensorsTriadsByOneRotationAndKeepsNorms) {
  const BatchShape shape{10, 20, 12};
  const ChannelLayout layout = ChannelLayout::imu({"a", "b"});
  std::vector<double> x = make_batch(shape), x0 = x;
  Rng rng(3);
  StdaDraws log;
  apply_stda(spec_of(StdaMethod::rotation), layout, x, shape, rng, &log);
  ASSERT_EQ(log.per_window, 3u);
  for (std::size_t w = 0; w < shape.windows; ++w) {
    for (std::size_t s = 0; s < 2; ++s) {
      const double* a = &log.values[w * 3];
      const Eigen::Matrix3d R = (Eigen::AngleAxisd(a[0], Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(a[1], Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(a[2], Eigen::Vector3d::UnitZ()))
                                    .toRotationMatrix();
      for (std::size_t i = 0; i < shape.samples; ++i) {
        for (std::size_t b : {0u, 3u}) {
          const std::size_t o = (w * shape.samples + i) * 12 + 6 * s + b;
          const Eigen::Vector3d in(x0[o], x0[o + 1], x0[o + 2]), out(x[o], x[o + 1], x[o + 2]);
          EXPECT_NEAR((R * in - out).norm(), 0.0, 1e-12);
        }
      }
    }
  }
}

TEST(Stda, FloatAndDoubleAgreeAndBadInputIsRejected) {
  const BatchShape shape{3, 25, 6};
  const ChannelLayout layout = ChannelLayout::imu({"s"});
  for (StdaMethod m : kMethods) {
    std::vector<double> d = make_batch(shape);
    std::vector<float> f(d.begin(), d.end());
    Rng r1(8), r2(8);
    apply_stda(spec_of(m), layout, d, shape, r1);
    apply_stda(spec_of(m), layout, f, shape, r2);
    for (std::size_t k = 0; k < d.size(); ++k) EXPECT_NEAR(f[k], d[k], 1e-5 * (1 + std::abs(d[k])));
  }
  std::vector<double> x(10);
  Rng rng(1);
  EXPECT_THROW(apply_stda(spec_of(StdaMethod::jittering), layout, x, shape, rng), Error);
  std::vector<double> y = make_batch(shape);
  StdaSpec s = spec_of(StdaMethod::magnitude_scaling);
  s.sigma = std::nan("");
  EXPECT_THROW(apply_stda(s, layout, y, shape, rng), Error);
  s = spec_of(StdaMethod::time_warping);
  s.ratio = 0.5;
  EXPECT_THROW(apply_stda(s, layout, y, shape, rng), Error);
  s = spec_of(StdaMethod::time_scaling);
  s.lo = 2.0;
  s.hi = 1.0;
  EXPECT_THROW(apply_stda(s, layout, y, shape, rng), Error);
  EXPECT_THROW(parse_stda_method("warp"), Error);
  EXPECT_EQ(parse_stda_method("time_warping"), StdaMethod::time_warping);
}

}  // namespace
}  // namespace imukit::augment
