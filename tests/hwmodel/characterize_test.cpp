#include "imukit/hwmodel/characterize.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "imukit/core/rng.hpp"

namespace imukit::hwmodel {
namespace {

TEST(Characterize, WhiteNoiseTriadGivesItsDensityAndNoOtherTerm) {
  // 20 000 s at 10 Hz of white noise with density N = sigma / sqrt(rate) per axis.
  const double rate = 10.0;
  const int64_t n = 200'000;
  const Eigen::Vector3d density(2e-3, 3e-3, 5e-3);
  Rng rng(11);
  std::vector<TimeNs> t(static_cast<std::size_t>(n));
  Eigen::Matrix3Xd x(3, n);
  for (int64_t i = 0; i < n; ++i) {
    t[static_cast<std::size_t>(i)] = i * 100'000'000;
    for (int a = 0; a < 3; ++a) x(a, i) = density(a) * std::sqrt(rate) * rng.normal();
  }
  const TriadNoise noise = characterize_triad(t, x);
  const NoiseEstimate e = noise_estimate(noise);
  for (int a = 0; a < 3; ++a) {
    const NoiseFit& f = noise.axes[static_cast<std::size_t>(a)].fit;
    // The profile section holds the fit's numbers unchanged.
    EXPECT_EQ((*e.noise_density)(a), f.value[kWhite]);
    EXPECT_EQ((*e.noise_density_sigma)(a), f.sigma[kWhite]);
    // The truth within 3 sigma of the fit (and the sigma a fraction of a percent).
    EXPECT_NEAR(f.value[kWhite], density(a), 3 * f.sigma[kWhite]) << "axis " << a;
    EXPECT_LT(f.sigma[kWhite], 0.01 * density(a));
    EXPECT_FALSE(f.active[kBiasInstability]);
    EXPECT_FALSE(f.active[kRandomWalk]);
    EXPECT_EQ((*e.bias_instability)(a), 0.0);
    EXPECT_EQ((*e.random_walk)(a), 0.0);
  }
  ASSERT_TRUE(e.allan.has_value());
  EXPECT_EQ(e.allan->tau_s, noise.allan.tau_s);
  EXPECT_EQ(e.allan->adev[2].size(), noise.allan.tau_s.size());
}

// Found in review: one constant axis (dead, or noise below one count) made the whole triad
// fail with "fewer than 2 usable points". Now that axis is marked constant with zero noise and
// the other two are characterized as usual.
TEST(Characterize, AConstantAxisIsMarkedAndTheOthersAreFitted) {
  const double rate = 10.0;
  const int64_t n = 50'000;
  const double density = 2e-3;
  Rng rng(12);
  std::vector<TimeNs> t(static_cast<std::size_t>(n));
  Eigen::Matrix3Xd x(3, n);
  for (int64_t i = 0; i < n; ++i) {
    t[static_cast<std::size_t>(i)] = i * 100'000'000;
    x(0, i) = density * std::sqrt(rate) * rng.normal();
    x(1, i) = density * std::sqrt(rate) * rng.normal();
    x(2, i) = 9.80665;  // constant
  }
  const TriadNoise noise = characterize_triad(t, x);
  EXPECT_FALSE(noise.axes[0].constant);
  EXPECT_FALSE(noise.axes[1].constant);
  EXPECT_TRUE(noise.axes[2].constant);
  const NoiseEstimate e = noise_estimate(noise);
  for (int a = 0; a < 2; ++a) {
    const NoiseFit& f = noise.axes[static_cast<std::size_t>(a)].fit;
    EXPECT_NEAR(f.value[kWhite], density, 3 * f.sigma[kWhite]) << a;
  }
  EXPECT_EQ((*e.noise_density)(2), 0.0);
  EXPECT_EQ((*e.noise_density_sigma)(2), 0.0);
  EXPECT_EQ((*e.random_walk)(2), 0.0);
}

// Found in review: white noise of 1e-170 was called constant (its squares underflowed to 0)
// while an axis of equal samples must still be. Noise at 1e-170 gives the 1.0 noise's N times
// 1e-170 (to 1e-12), at any magnitude an axis of equal samples is constant.
TEST(Characterize, TinyNoiseIsNoiseAndEqualSamplesAreConstantAtAnyMagnitude) {
  const int64_t n = 20'000;
  Rng rng(3);
  std::vector<TimeNs> t(static_cast<std::size_t>(n));
  Eigen::Matrix3Xd x(3, n);
  for (int64_t i = 0; i < n; ++i) {
    t[static_cast<std::size_t>(i)] = i * 10'000'000;
    x(0, i) = rng.normal();
    x(1, i) = 0.3 * rng.normal();
    x(2, i) = 1.0;
  }
  const TriadNoise one = characterize_triad(t, x);
  for (const double s : {1e-170, 1e-300, 1e300}) {
    const TriadNoise tiny = characterize_triad(t, x * s);
    for (std::size_t a = 0; a < 2; ++a) {
      EXPECT_FALSE(tiny.axes[a].constant) << s << " " << a;
      const double n1 = one.axes[a].fit.value[kWhite];
      EXPECT_NEAR(tiny.axes[a].fit.value[kWhite] / s, n1, 1e-12 * n1) << s << " " << a;
    }
    EXPECT_TRUE(tiny.axes[2].constant) << s;
    EXPECT_EQ(tiny.axes[2].fit.value[kWhite], 0.0) << s;
  }
}

TEST(Characterize, CalibrationSectionIsTheForwardModel) {
  TriadCalibration c;
  c.T << 1.0, 0.01, -0.02, 0.0, 1.0, 0.03, 0.0, 0.0, 1.0;
  c.scale = Eigen::Vector3d(0.5, 0.25, 2.0);
  c.bias = Eigen::Vector3d(1.0, -2.0, 3.0);
  const Calibration p = calibration_section(c, true, 0.01, 0.03, 12);
  EXPECT_EQ(p.scale, c.forward_scale());
  EXPECT_EQ(p.misalignment, c.forward_misalignment());
  EXPECT_EQ(p.bias, c.bias);
  EXPECT_TRUE(p.raw_counts);
  ASSERT_TRUE(p.residual.has_value());
  EXPECT_EQ(p.residual->rms, 0.01);
  EXPECT_EQ(p.residual->max, 0.03);
  EXPECT_EQ(p.residual->count, 12);
}

}  // namespace
}  // namespace imukit::hwmodel
