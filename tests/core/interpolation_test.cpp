#include "imukit/core/interpolation.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "support/numbers.hpp"

namespace imukit {
namespace {

using Eigen::MatrixXd;
using ::testing::HasSubstr;

std::vector<double> eval1(InterpolationKind kind, const std::vector<double>& x,
                          const std::vector<double>& y, const std::vector<double>& xq) {
  return interpolate(kind, x, y, xq);
}

// Values on the Hermite cubic of [x0, x0 + h] at its midpoint: (y0 + y1)/2 + h (d0 - d1)/8
// (the Hermite basis at t = 1/2 is h00 = h01 = 1/2, h10 = 1/8, h11 = -1/8).

// Example A: x = [0, 1, 3, 4], y = [0, 2, 3, 1]; h = [1, 2, 1], secants m = [2, 0.5, -2].
//  d1: same signs, w1 = 2 h1 + h0 = 5, w2 = h1 + 2 h0 = 4, d1 = 9 / (5/2 + 4/0.5) = 9/10.5 = 6/7.
//  d2: m1 = 0.5 and m2 = -2 differ in sign -> 0.
//  d0 = ((2 h0 + h1) m0 - h0 m1) / (h0 + h1) = (4*2 - 0.5) / 3 = 2.5 (sign of m0: kept).
//  d3 = ((2*1 + 2)(-2) - 1*0.5) / 3 = -8.5/3 = -17/6; m0, m1 differ in sign but |d3| < 3|m0| = 6.
// (The equal-spacing shortcut (3 m0 - m1)/2 would give 2.75 and -3.25: the test tells them apart,
// as it tells w1 and w2 apart: swapped weights give d1 = 0.75.)
TEST(Pchip, SlopesFollowScipysRules) {
  const std::vector<double> x{0.0, 1.0, 3.0, 4.0};
  const Eigen::RowVector4d y(0.0, 2.0, 3.0, 1.0);
  const Interpolant f = Interpolant::pchip(x, y);
  const MatrixXd& d = f.knot_slopes();
  EXPECT_NEAR(d(0, 0), 2.5, 4 * kEps);
  EXPECT_NEAR(d(0, 1), 6.0 / 7.0, 4 * kEps);
  EXPECT_EQ(d(0, 2), 0.0);
  EXPECT_NEAR(d(0, 3), -17.0 / 6.0, 4 * kEps);

  // Midpoints: [0,1]: 1 + (2.5 - 6/7)/8 = 1 + 23/112 = 135/112;
  // [1,3]: 2.5 + 2 (6/7)/8 = 2.5 + 3/14 = 19/7; [3,4]: 2 + (0 + 17/6)/8 = 2 + 17/48 = 113/48.
  // Outside, the end cubics: on [0,1] c = (0, 2.5, 1/7, -9/14) so p(-1) = -2.5 + 1/7 + 9/14 =
  // -12/7; on [3,4] c = (3, 0, -19/6, 7/6) so p(5) = 3 - 4*19/6 + 8*7/6 = -1/3.
  const std::vector<double> xq{0.5, 2.0, 3.5, -1.0, 5.0, 0.0, 1.0, 3.0, 4.0};
  const MatrixXd v = f(xq);
  const double expected[] = {135.0 / 112.0, 19.0 / 7.0, 113.0 / 48.0, -12.0 / 7.0, -1.0 / 3.0,
                             0.0,           2.0,        3.0,          1.0};
  for (std::size_t i = 0; i < xq.size(); ++i) {
    EXPECT_NEAR(v(0, static_cast<Eigen::Index>(i)), expected[i], 8 * kEps) << "x = " << xq[i];
  }
}

TEST(Pchip, EndSlopesAreClippedLikeScipy) {
  // x = [0, 1, 2], y = [0, 1, -9]: m = [1, -10]. Left: d = (3*1 + 10)/2 = 6.5 > 3|m0| with m0, m1
  // of opposite signs -> 3 m0 = 3. Interior: signs differ -> 0. Right (h0 = h1 = 1, m0 = -10,
  // m1 = 1): d = (3*(-10) - 1)/2 = -15.5, |d| < 30 -> kept.
  {
    const std::vector<double> x{0.0, 1.0, 2.0};
    const Eigen::RowVector3d y(0.0, 1.0, -9.0);
    const Interpolant f = Interpolant::pchip(x, y);
    const MatrixXd& d = f.knot_slopes();
    EXPECT_EQ(d(0, 0), 3.0);
    EXPECT_EQ(d(0, 1), 0.0);
    EXPECT_EQ(d(0, 2), -15.5);
  }
  // x = [0, 1, 2], y = [0, 1, 6]: m = [1, 5]. Left: d = (3 - 5)/2 = -1, sign differs from m0 -> 0.
  // Interior: 6 / (3/1 + 3/5) = 5/3. Right: d = (3*5 - 1)/2 = 7.
  {
    const std::vector<double> x{0.0, 1.0, 2.0};
    const Eigen::RowVector3d y(0.0, 1.0, 6.0);
    const Interpolant f = Interpolant::pchip(x, y);
    const MatrixXd& d = f.knot_slopes();
    EXPECT_EQ(d(0, 0), 0.0);
    EXPECT_NEAR(d(0, 1), 5.0 / 3.0, 2 * kEps);
    EXPECT_EQ(d(0, 2), 7.0);
  }
  // A zero secant makes both neighbouring interior slopes 0 (flat stays flat).
  {
    const std::vector<double> x{0.0, 1.0, 2.0, 3.0, 4.0};
    const Eigen::Matrix<double, 1, 5> y(0.0, 1.0, 1.0, 2.0, 3.0);
    const Interpolant f = Interpolant::pchip(x, y);
    const MatrixXd& d = f.knot_slopes();
    EXPECT_EQ(d(0, 1), 0.0);
    EXPECT_EQ(d(0, 2), 0.0);
    const std::vector<double> flat{1.1, 1.5, 1.9};
    for (double v : eval1(InterpolationKind::pchip, x, {0.0, 1.0, 1.0, 2.0, 3.0}, flat)) {
      EXPECT_EQ(v, 1.0);
    }
  }
}

TEST(Pchip, KeepsMonotoneDataMonotone) {
  Rng rng(21);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 2 + static_cast<int>(rng.uniform_index(30));
    std::vector<double> x(n), y(n);
    x[0] = rng.normal();
    y[0] = rng.normal();
    for (int i = 1; i < n; ++i) {
      x[i] = x[i - 1] + 0.01 + 3.0 * rng.uniform();
      // Increments spanning six decades, some exactly zero (plateaus).
      y[i] = y[i - 1] + (rng.uniform() < 0.15 ? 0.0 : std::pow(10.0, rng.uniform(-3.0, 3.0)));
    }
    std::vector<double> xq;
    for (int i = 0; i + 1 < n; ++i) {
      for (int k = 0; k <= 50; ++k) xq.push_back(x[i] + (x[i + 1] - x[i]) * k / 50.0);
    }
    const std::vector<double> v = eval1(InterpolationKind::pchip, x, y, xq);
    const double tol = 8 * kEps * std::max(std::abs(y.front()), std::abs(y.back()));
    for (std::size_t j = 1; j < v.size(); ++j) {
      ASSERT_GE(v[j], v[j - 1] - tol) << "trial " << trial << " at x = " << xq[j];
    }
    // No overshoot: each interval stays within its end values.
    for (std::size_t j = 0; j < v.size(); ++j) {
      const std::size_t i = std::min<std::size_t>(j / 51, static_cast<std::size_t>(n - 2));
      ASSERT_GE(v[j], y[i] - tol);
      ASSERT_LE(v[j], y[i + 1] + tol);
    }
  }
}

TEST(Pchip, NeverOvershootsNonMonotoneData) {
  Rng rng(22);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 3 + static_cast<int>(rng.uniform_index(20));
    std::vector<double> x(n), y(n);
    for (int i = 0; i < n; ++i) {
      x[i] = (i == 0 ? 0.0 : x[i - 1]) + 0.05 + rng.uniform();
      y[i] = rng.normal();
    }
    std::vector<double> xq;
    for (int i = 0; i + 1 < n; ++i) {
      for (int k = 0; k <= 40; ++k) xq.push_back(x[i] + (x[i + 1] - x[i]) * k / 40.0);
    }
    const std::vector<double> v = eval1(InterpolationKind::pchip, x, y, xq);
    for (std::size_t j = 0; j < v.size(); ++j) {
      const std::size_t i = std::min<std::size_t>(j / 41, static_cast<std::size_t>(n - 2));
      ASSERT_GE(v[j], std::min(y[i], y[i + 1]) - 1e-14);
      ASSERT_LE(v[j], std::max(y[i], y[i + 1]) + 1e-14);
    }
  }
}

TEST(Pchip, IsContinuouslyDifferentiableAtTheKnots) {
  const std::vector<double> x{0.0, 0.5, 2.0, 2.5, 4.0};
  const Eigen::Matrix<double, 1, 5> y(1.0, 2.0, 2.5, 4.0, 3.0);
  const Interpolant f = Interpolant::pchip(x, y);
  for (std::size_t i = 1; i + 1 < x.size(); ++i) {
    const double left = std::nextafter(x[i], -1e9);
    MatrixXd d_left(1, 1), d_right(1, 1);
    f.evaluate_derivative(std::vector<double>{left}, 1, d_left);
    f.evaluate_derivative(std::vector<double>{x[i]}, 1, d_right);
    EXPECT_NEAR(d_left(0, 0), f.knot_slopes()(0, static_cast<Eigen::Index>(i)), 1e-12);
    EXPECT_NEAR(d_right(0, 0), f.knot_slopes()(0, static_cast<Eigen::Index>(i)), 1e-15);
  }
}

TEST(LinearInterpolation, InterpolatesAndExtrapolatesTheEndSegments) {
  // x = [0, 1, 3], y = [1, 3, 2]: slopes 2 and -0.5.
  const std::vector<double> x{0.0, 1.0, 3.0};
  const std::vector<double> y{1.0, 3.0, 2.0};
  const std::vector<double> xq{0.5, 2.0, -1.0, 4.0, 1.0, 3.0};
  // 1 + 0.5*2 = 2; 3 - 0.5 = 2.5; 1 - 2 = -1; 3 + 3*(-0.5) = 1.5; knots exact.
  const std::vector<double> expected{2.0, 2.5, -1.0, 1.5, 3.0, 2.0};
  const std::vector<double> v = eval1(InterpolationKind::linear, x, y, xq);
  for (std::size_t i = 0; i < xq.size(); ++i) EXPECT_EQ(v[i], expected[i]) << xq[i];
}

TEST(CubicSpline, FourKnotsGiveTheCubicThroughThem) {
  // Not-a-knot at both interior knots of 4 points: one cubic. Through (0,0), (1,1), (2,0), (3,1):
  // differences 1,-1,1 / -2,2 / 4, so p(x) = x - x(x-1) + (2/3) x(x-1)(x-2):
  // p(0.5) = 0.5 + 0.25 + (2/3)(0.375) = 1; p(1.5) = 1.5 - 0.75 - 0.25 = 0.5;
  // p(-1) = -1 - 2 + (2/3)(-6) = -7; p(4) = 4 - 12 + 16 = 8.
  const std::vector<double> x{0.0, 1.0, 2.0, 3.0};
  const std::vector<double> y{0.0, 1.0, 0.0, 1.0};
  const std::vector<double> xq{0.5, 1.5, 2.5, -1.0, 4.0};
  const std::vector<double> expected{1.0, 0.5, 0.0, -7.0, 8.0};
  const std::vector<double> v = eval1(InterpolationKind::cubic_spline_not_a_knot, x, y, xq);
  for (std::size_t i = 0; i < xq.size(); ++i) EXPECT_NEAR(v[i], expected[i], 1e-14) << xq[i];
}

TEST(CubicSpline, FiveKnotsMatchTheHandSolvedSystem) {
  // x = 0..4, y = [0, 0, 1, 0, 0], h = 1, m = [0, 1, -1, 0]. Interior rows
  // s_{i-1} + 4 s_i + s_{i+1} = 3 (m_{i-1} + m_i): 3, 0, -3. Not-a-knot rows (d = x2 - x0 = 2):
  // s0 + 2 s1 = ((1 + 4)*0 + 1*1)/2 = 0.5 and 2 s3 + s4 = (1*(-1) + 5*0)/2 = -0.5.
  // By symmetry s2 = 0, s3 = -s1, s4 = -s0; then s0 + 4 s1 = 3 and s0 + 2 s1 = 0.5 give
  // s1 = 1.25, s0 = -2. Slopes [-2, 1.25, 0, -1.25, 2]; midpoints
  // [0,1]: 0 + (-2 - 1.25)/8 = -0.40625, [1,2]: 0.5 + (1.25 - 0)/8 = 0.65625.
  const std::vector<double> x{0.0, 1.0, 2.0, 3.0, 4.0};
  const Eigen::Matrix<double, 1, 5> y(0.0, 0.0, 1.0, 0.0, 0.0);
  const Interpolant f = Interpolant::cubic_spline(x, y);
  const double slopes[] = {-2.0, 1.25, 0.0, -1.25, 2.0};
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(f.knot_slopes()(0, i), slopes[i], 4 * kEps) << i;
  const MatrixXd v = f(std::vector<double>{0.5, 1.5, 2.5, 3.5});
  EXPECT_NEAR(v(0, 0), -0.40625, 4 * kEps);
  EXPECT_NEAR(v(0, 1), 0.65625, 4 * kEps);
  EXPECT_NEAR(v(0, 2), 0.65625, 4 * kEps);
  EXPECT_NEAR(v(0, 3), -0.40625, 4 * kEps);
}

TEST(CubicSpline, ReproducesACubicExactlyOnUnevenKnots) {
  auto p = [](double t) { return 1.5 - 2.0 * t + 0.7 * t * t - 0.05 * t * t * t; };
  auto dp = [](double t) { return -2.0 + 1.4 * t - 0.15 * t * t; };
  auto ddp = [](double t) { return 1.4 - 0.3 * t; };
  for (int n = 4; n <= 50; ++n) {
    std::vector<double> x(n);
    for (int i = 0; i < n; ++i) x[i] = i + 0.3 * std::sin(3.0 * i);  // spacings 0.4 .. 1.6
    MatrixXd y(1, n);
    for (int i = 0; i < n; ++i) y(0, i) = p(x[i]);
    std::vector<double> xq;
    for (double t = x.front() - 0.5; t <= x.back() + 0.5; t += 0.0731) xq.push_back(t);
    const Interpolant f = Interpolant::cubic_spline(x, y);
    MatrixXd v(1, static_cast<Eigen::Index>(xq.size()));
    MatrixXd dv(1, v.cols()), ddv(1, v.cols());
    f.evaluate(xq, v);
    f.evaluate_derivative(xq, 1, dv);
    f.evaluate_derivative(xq, 2, ddv);
    const double scale = y.cwiseAbs().maxCoeff();
    for (std::size_t j = 0; j < xq.size(); ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      ASSERT_NEAR(v(0, jj), p(xq[j]), 1e-12 * scale) << "n = " << n << " x = " << xq[j];
      ASSERT_NEAR(dv(0, jj), dp(xq[j]), 1e-11 * scale) << "n = " << n;
      ASSERT_NEAR(ddv(0, jj), ddp(xq[j]), 1e-10 * scale) << "n = " << n;
    }
  }
}

TEST(CubicSpline, TwoAndThreeKnotsAreScipysSpecialCases) {
  // n = 2: the straight line through (1, 2) and (3, 6), extrapolated too: y = 2x.
  {
    const std::vector<double> x{1.0, 3.0};
    const std::vector<double> y{2.0, 6.0};
    const std::vector<double> xq{0.0, 2.0, 5.0};
    for (auto kind : {InterpolationKind::cubic_spline_not_a_knot, InterpolationKind::pchip,
                      InterpolationKind::linear}) {
      const std::vector<double> v = eval1(kind, x, y, xq);
      EXPECT_NEAR(v[0], 0.0, 4 * kEps);
      EXPECT_NEAR(v[1], 4.0, 4 * kEps);
      EXPECT_NEAR(v[2], 10.0, 8 * kEps);
    }
  }
  // n = 3: the parabola through (0,1), (1,2), (3,0): m0 = 1, m1 = -1, c = (m1 - m0)/(h0 + h1) =
  // -2/3, p(x) = 1 + x - (2/3) x (x - 1): p(2) = 5/3, p(-1) = -4/3, p(4) = -3, p(0.5) = 5/3.
  {
    const std::vector<double> x{0.0, 1.0, 3.0};
    const std::vector<double> y{1.0, 2.0, 0.0};
    const std::vector<double> xq{2.0, -1.0, 4.0, 0.5};
    const std::vector<double> expected{5.0 / 3.0, -4.0 / 3.0, -3.0, 5.0 / 3.0};
    const std::vector<double> v = eval1(InterpolationKind::cubic_spline_not_a_knot, x, y, xq);
    for (std::size_t i = 0; i < xq.size(); ++i) EXPECT_NEAR(v[i], expected[i], 8 * kEps);
  }
}

TEST(Interpolation, MultiChannelEqualsChannelByChannel) {
  Rng rng(23);
  const int n = 17, channels = 6;
  std::vector<double> x(n);
  for (int i = 0; i < n; ++i) x[i] = (i == 0 ? 0.0 : x[i - 1]) + 0.1 + rng.uniform();
  MatrixXd y(channels, n);
  for (int c = 0; c < channels; ++c) {
    for (int i = 0; i < n; ++i) y(c, i) = rng.normal();
  }
  std::vector<double> xq;
  for (int j = 0; j < 300; ++j) xq.push_back(rng.uniform(x.front() - 1.0, x.back() + 1.0));
  for (auto kind : {InterpolationKind::linear, InterpolationKind::pchip,
                    InterpolationKind::cubic_spline_not_a_knot}) {
    const MatrixXd all = interpolate(kind, x, y, xq);
    ASSERT_EQ(all.rows(), channels);
    for (int c = 0; c < channels; ++c) {
      const std::vector<double> yc(y.row(c).begin(), y.row(c).end());
      const std::vector<double> one = eval1(kind, x, yc, xq);
      for (std::size_t j = 0; j < xq.size(); ++j) {
        ASSERT_EQ(all(c, static_cast<Eigen::Index>(j)), one[j]) << "channel " << c;
      }
    }
  }
}

TEST(Interpolation, QueryOrderDoesNotChangeTheResult) {
  Rng rng(24);
  const std::vector<double> x{0.0, 0.3, 1.0, 1.2, 2.5, 4.0};
  const std::vector<double> y{0.0, 1.0, -1.0, 0.5, 2.0, 0.0};
  std::vector<double> sorted;
  for (int j = 0; j < 500; ++j) sorted.push_back(rng.uniform(-1.0, 5.0));
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> reversed(sorted.rbegin(), sorted.rend());
  const std::vector<double> a = eval1(InterpolationKind::pchip, x, y, sorted);
  const std::vector<double> b = eval1(InterpolationKind::pchip, x, y, reversed);
  for (std::size_t j = 0; j < a.size(); ++j) ASSERT_EQ(a[j], b[a.size() - 1 - j]);
}

TEST(Interpolation, RejectsBadInputWithAClearMessage) {
  const std::vector<double> good_x{0.0, 1.0, 2.0};
  const std::vector<double> good_y{0.0, 1.0, 0.0};
  const std::vector<double> xq{0.5};
  auto message = [](auto&& call) -> std::string {
    try {
      call();
    } catch (const Error& e) {
      return e.what();
    }
    return "no exception";
  };
  for (auto kind : {InterpolationKind::linear, InterpolationKind::pchip,
                    InterpolationKind::cubic_spline_not_a_knot}) {
    EXPECT_THAT(message([&] { eval1(kind, {}, {}, xq); }), HasSubstr("at least 2 knots, got 0"));
    EXPECT_THAT(message([&] { eval1(kind, {1.0}, {1.0}, xq); }),
                HasSubstr("at least 2 knots, got 1"));
    EXPECT_THAT(message([&] {
                  eval1(kind, {0.0, 1.0, 1.0}, good_y, xq);
                }),
                HasSubstr("strictly increasing, but x[2] = 1 <= x[1] = 1"));
    EXPECT_THAT(message([&] {
                  eval1(kind, {0.0, 2.0, 1.0}, good_y, xq);
                }),
                HasSubstr("strictly increasing, but x[2] = 1 <= x[1] = 2"));
    EXPECT_THAT(message([&] {
                  eval1(kind, {0.0, std::nan(""), 2.0}, good_y, xq);
                }),
                HasSubstr("x[1] = nan is not finite"));
    EXPECT_THAT(message([&] {
                  eval1(kind, good_x, {0.0, 1.0, std::nan("")}, xq);
                }),
                HasSubstr("y(channel 0, knot 2) = nan is not finite"));
    EXPECT_THAT(message([&] {
                  eval1(kind, good_x, {0.0, std::numeric_limits<double>::infinity(), 1.0}, xq);
                }),
                HasSubstr("y(channel 0, knot 1) = inf is not finite"));
    EXPECT_THAT(message([&] {
                  eval1(kind, good_x, {0.0, 1.0}, xq);
                }),
                HasSubstr("y has 2 columns (one per knot) but x has 3 knots"));
    EXPECT_THAT(message([&] {
                  eval1(kind, good_x, good_y, {0.5, std::nan("")});
                }),
                HasSubstr("query xq[1] = nan is not finite"));
  }
}

}  // namespace
}  // namespace imukit
