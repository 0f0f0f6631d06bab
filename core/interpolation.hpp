// Piecewise-polynomial interpolation of many channels at once: linear, PCHIP (shape preserving,
// the slopes of scipy.interpolate.PchipInterpolator) and the not-a-knot cubic spline (scipy's
// CubicSpline default). Used for time warping, magnitude warping and resampling of signals and
// motion.
//
// Layout: knots x (n >= 2, finite, strictly increasing) and values y as a C x n matrix, one row
// per channel and one column per knot -- the layout of ImuSeries (3 x N) and of a row of an
// (N, T, C) .npy file -- so the C values at one knot are contiguous and every query finds its
// interval once for all channels. Results are C x m for m query points.
//
// Every interpolant is stored as one cubic per interval in the local coordinate s = x - x_i
// (p(s) = c0 + c1 s + c2 s^2 + c3 s^3, the Hermite form scipy uses). Queries outside [x_0, x_n-1]
// are extrapolated with the first or last interval's polynomial (scipy's default,
// extrapolate=True); a query equal to a knot x_i (i < n-1) uses interval i, the last knot uses the
// last interval.
//
// Bad input (fewer than 2 knots, x not strictly increasing, NaN or infinity in x, y or a query,
// mismatched sizes) throws imukit::Error naming the offending index.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

namespace imukit {

enum class InterpolationKind {
  linear,
  pchip,                    // scipy PchipInterpolator (Fritsch & Butland 1984 slopes)
  cubic_spline_not_a_knot,  // scipy CubicSpline(bc_type="not-a-knot")
};

class Interpolant {
 public:
  // x: n knots; y: C x n values (channels in rows).
  static Interpolant linear(std::span<const double> x, const Eigen::Ref<const Eigen::MatrixXd>& y);

  // Slopes d_k at the knots as in scipy: interior d_k = 0 where the neighbouring secants m_{k-1},
  // m_k differ in sign or either is 0, else the weighted harmonic mean
  //   (w1 + w2) / d_k = w1 / m_{k-1} + w2 / m_k,  w1 = 2 h_k + h_{k-1},  w2 = h_k + 2 h_{k-1};
  // end slopes from the one-sided three-point formula d = ((2 h0 + h1) m0 - h0 m1) / (h0 + h1),
  // set to 0 if its sign differs from m0's, and to 3 m0 if m0 and m1 differ in sign and
  // |d| > 3 |m0| (Moler, Numerical Computing with MATLAB, sec. 3.6). n = 2 is the straight line.
  static Interpolant pchip(std::span<const double> x, const Eigen::Ref<const Eigen::MatrixXd>& y);

  // C2 cubic spline whose third derivative is continuous at x_1 and x_n-2 (not-a-knot), found by
  // an O(n) tridiagonal solve with partial pivoting. n = 2 gives the straight line and n = 3 the
  // parabola through the three points (scipy's special cases); n = 4 gives the single cubic
  // through the four points.
  static Interpolant cubic_spline(std::span<const double> x,
                                  const Eigen::Ref<const Eigen::MatrixXd>& y);

  static Interpolant make(InterpolationKind kind, std::span<const double> x,
                          const Eigen::Ref<const Eigen::MatrixXd>& y);

  Eigen::Index channels() const { return channels_; }
  std::size_t knots() const { return x_.size(); }
  std::span<const double> x() const { return x_; }
  // The first derivative at each knot (C x n), as the construction chose it; for linear, the
  // secant of the interval to the right of the knot (of the last interval at x_n-1).
  const Eigen::MatrixXd& knot_slopes() const { return slopes_; }

  // Values at the query points into out (C x xq.size()). Queries may come in any order; sorted
  // queries are found in amortised O(1) each, others by binary search.
  void evaluate(std::span<const double> xq, Eigen::Ref<Eigen::MatrixXd> out) const;
  Eigen::MatrixXd operator()(std::span<const double> xq) const;

  // The order-th derivative (0 to 3) at the query points into out (C x xq.size()).
  void evaluate_derivative(std::span<const double> xq, int order,
                           Eigen::Ref<Eigen::MatrixXd> out) const;

 private:
  Interpolant(std::vector<double> x, Eigen::Index channels, int degree);
  // Fills the interval cubics from the values, the secants m (C x (n-1)) and the knot
  // derivatives d (C x n), keeping d.
  void set_hermite(const Eigen::Ref<const Eigen::MatrixXd>& y, const Eigen::MatrixXd& m,
                   Eigen::MatrixXd d);
  std::size_t find_interval(double xq, std::size_t hint) const;
  template <int Order>
  void evaluate_impl(std::span<const double> xq, Eigen::Ref<Eigen::MatrixXd> out) const;

  std::vector<double> x_;
  Eigen::Index channels_ = 0;
  int degree_ = 3;  // 1 for linear (c2 = c3 = 0 and skipped when evaluating)
  // (4 C) x (n - 1): column i holds the blocks c0, c1, c2, c3 (C rows each) of interval i.
  Eigen::MatrixXd coef_;
  Eigen::MatrixXd slopes_;  // C x n
};

// One-shot helpers: build the interpolant and evaluate it.
Eigen::MatrixXd interpolate(InterpolationKind kind, std::span<const double> x,
                            const Eigen::Ref<const Eigen::MatrixXd>& y, std::span<const double> xq);
// Single channel.
std::vector<double> interpolate(InterpolationKind kind, std::span<const double> x,
                                std::span<const double> y, std::span<const double> xq);

}  // namespace imukit
