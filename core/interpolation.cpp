#include "imukit/core/interpolation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <utility>

#include "imukit/core/error.hpp"

namespace imukit {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Throws imukit::Error unless x and y describe a valid interpolation problem.
void validate(const char* what, std::span<const double> x, const Eigen::Ref<const MatrixXd>& y) {
  if (x.size() < 2) {
    throw Error(fmt::format("{}: needs at least 2 knots, got {}", what, x.size()));
  }
  if (static_cast<std::size_t>(y.cols()) != x.size()) {
    throw Error(fmt::format("{}: y has {} columns (one per knot) but x has {} knots", what,
                            y.cols(), x.size()));
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) {
      throw Error(fmt::format("{}: x[{}] = {} is not finite", what, i, x[i]));
    }
    if (i > 0 && !(x[i] > x[i - 1])) {
      throw Error(fmt::format("{}: x must be strictly increasing, but x[{}] = {} <= x[{}] = {}",
                              what, i, x[i], i - 1, x[i - 1]));
    }
    if (i > 0 && !std::isfinite(x[i] - x[i - 1])) {
      throw Error(fmt::format("{}: the spacing x[{}] - x[{}] overflows", what, i, i - 1));
    }
  }
  for (Index k = 0; k < y.cols(); ++k) {
    for (Index c = 0; c < y.rows(); ++c) {
      if (!std::isfinite(y(c, k))) {
        throw Error(
            fmt::format("{}: y(channel {}, knot {}) = {} is not finite", what, c, k, y(c, k)));
      }
    }
  }
}

// numpy.sign: -1, 0 or +1 (inputs are finite here).
int sign(double v) { return (v > 0.0) - (v < 0.0); }

// scipy PchipInterpolator._edge_case: one-sided three-point slope at an end, with h0, m0 the
// spacing and secant of the end interval and h1, m1 those of its neighbour.
double pchip_end_slope(double h0, double h1, double m0, double m1) {
  const double d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
  if (sign(d) != sign(m0)) return 0.0;
  if (sign(m0) != sign(m1) && std::abs(d) > 3.0 * std::abs(m0)) return 3.0 * m0;
  return d;
}

// Secants m (C x (n-1)) and spacings h (n-1).
void secants(std::span<const double> x, const Eigen::Ref<const MatrixXd>& y, VectorXd& h,
             MatrixXd& m) {
  const Index n = static_cast<Index>(x.size());
  h.resize(n - 1);
  m.resize(y.rows(), n - 1);
  for (Index i = 0; i + 1 < n; ++i) {
    h(i) = x[i + 1] - x[i];
    m.col(i) = (y.col(i + 1) - y.col(i)) / h(i);
  }
}

// Solves the tridiagonal system  dl[i-1] s[i-1] + d[i] s[i] + du[i] s[i+1] = b[i]  for every
// channel at once (b's columns are the rows of the system, each a C-vector), by Gaussian
// elimination with partial pivoting (the scheme of LAPACK's dgtsv): the not-a-knot rows are not
// diagonally dominant, so plain Thomas elimination would not be safe. O(n). b is overwritten by s.
void solve_tridiagonal(std::vector<double> dl, std::vector<double> d, std::vector<double> du,
                       MatrixXd& b) {
  const std::size_t n = d.size();
  assert(n >= 2 && dl.size() == n - 1 && du.size() == n - 1 &&
         static_cast<std::size_t>(b.cols()) == n);
  std::vector<double> du2(n, 0.0);  // fill-in of the second superdiagonal from row swaps
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (std::abs(d[i]) >= std::abs(dl[i])) {
      // No interchange; eliminate dl[i] from row i+1.
      assert(d[i] != 0.0);
      const double f = dl[i] / d[i];
      d[i + 1] -= f * du[i];
      b.col(i + 1) -= f * b.col(i);
    } else {
      // Interchange rows i and i+1, then eliminate.
      const double f = d[i] / dl[i];
      d[i] = dl[i];
      const double old_d = d[i + 1];
      d[i + 1] = du[i] - f * old_d;
      if (i + 2 < n) {
        du2[i] = du[i + 1];
        du[i + 1] = -f * du2[i];
      }
      du[i] = old_d;
      const VectorXd row_i = b.col(i);
      b.col(i) = b.col(i + 1);
      b.col(i + 1) = row_i - f * b.col(i);
    }
  }
  assert(d[n - 1] != 0.0);
  b.col(n - 1) /= d[n - 1];
  b.col(n - 2) = (b.col(n - 2) - du[n - 2] * b.col(n - 1)) / d[n - 2];
  for (std::size_t k = n - 2; k-- > 0;) {
    b.col(k) = (b.col(k) - du[k] * b.col(k + 1) - du2[k] * b.col(k + 2)) / d[k];
  }
}

}  // namespace

Interpolant::Interpolant(std::vector<double> x, Index channels, int degree)
    : x_(std::move(x)), channels_(channels), degree_(degree) {}

void Interpolant::set_hermite(const Eigen::Ref<const MatrixXd>& y, const MatrixXd& m, MatrixXd d) {
  const Index n = static_cast<Index>(x_.size());
  const Index cc = channels_;
  coef_.resize(4 * cc, n - 1);
  for (Index i = 0; i + 1 < n; ++i) {
    // The cubic Hermite form of scipy's CubicHermiteSpline, in s = x - x_i, with the secant m:
    // c1 = d_i, c2 = (m - d_i)/h - t, c3 = t/h where t = (d_i + d_i+1 - 2 m)/h. One reciprocal
    // per interval instead of three divisions per value (this loop dominated construction);
    // it moves results by at most an ulp or two against scipy's divisions.
    const double inv_h = 1.0 / (x_[i + 1] - x_[i]);
    const double* yi = y.col(i).data();
    const double* mi = m.col(i).data();
    const double* d0 = d.col(i).data();
    const double* d1 = d.col(i + 1).data();
    double* c0 = coef_.col(i).data();
    double* c1 = c0 + cc;
    double* c2 = c1 + cc;
    double* c3 = c2 + cc;
    for (Index c = 0; c < cc; ++c) {
      const double t = (d0[c] + d1[c] - 2.0 * mi[c]) * inv_h;
      c0[c] = yi[c];
      c1[c] = d0[c];
      c2[c] = (mi[c] - d0[c]) * inv_h - t;
      c3[c] = t * inv_h;
    }
  }
  if (!coef_.allFinite()) {
    // Only reachable with extreme data (e.g. spacings near the smallest double); never return NaN.
    throw Error("interpolation: the data's range overflows double precision");
  }
  slopes_ = std::move(d);
}

Interpolant Interpolant::linear(std::span<const double> x, const Eigen::Ref<const MatrixXd>& y) {
  validate("linear interpolation", x, y);
  Interpolant out({x.begin(), x.end()}, y.rows(), 1);
  VectorXd h;
  MatrixXd m;
  secants(x, y, h, m);
  const Index n = static_cast<Index>(x.size());
  out.coef_.setZero(4 * y.rows(), n - 1);
  out.coef_.topRows(y.rows()) = y.leftCols(n - 1);
  out.coef_.middleRows(y.rows(), y.rows()) = m;
  if (!out.coef_.allFinite()) throw Error("linear interpolation: the data's range overflows");
  out.slopes_.resize(y.rows(), n);
  out.slopes_.leftCols(n - 1) = m;
  out.slopes_.col(n - 1) = m.col(n - 2);
  return out;
}

Interpolant Interpolant::pchip(std::span<const double> x, const Eigen::Ref<const MatrixXd>& y) {
  validate("PCHIP interpolation", x, y);
  Interpolant out({x.begin(), x.end()}, y.rows(), 3);
  VectorXd h;
  MatrixXd m;
  secants(x, y, h, m);
  const Index n = static_cast<Index>(x.size());
  MatrixXd d(y.rows(), n);
  if (n == 2) {
    // scipy: two points give the straight line.
    d.col(0) = m.col(0);
    d.col(1) = m.col(0);
  } else {
    for (Index k = 1; k + 1 < n; ++k) {
      // Fritsch & Butland (1984) weighted harmonic mean.
      const double w1 = 2.0 * h(k) + h(k - 1);
      const double w2 = h(k) + 2.0 * h(k - 1);
      const double* mp = m.col(k - 1).data();
      const double* mn = m.col(k).data();
      double* dk = d.col(k).data();
      for (Index c = 0; c < y.rows(); ++c) {
        // Written without branches (random signs would mispredict half the time: & and | do
        // not short-circuit, so the loop is if-converted and vectorised); secants are replaced
        // by 1 where the result is discarded, so nothing divides by zero. (w1 + w2) / (w1/a +
        // w2/b) is scipy's 1 / ((w1/a + w2/b) / (w1 + w2)) with one rounding fewer.
        const bool same_strict_sign =
            ((mp[c] > 0.0) & (mn[c] > 0.0)) | ((mp[c] < 0.0) & (mn[c] < 0.0));
        const double a = same_strict_sign ? mp[c] : 1.0;
        const double b = same_strict_sign ? mn[c] : 1.0;
        const double harmonic_mean = (w1 + w2) / (w1 / a + w2 / b);
        dk[c] = same_strict_sign ? harmonic_mean : 0.0;
      }
    }
    for (Index c = 0; c < y.rows(); ++c) {
      d(c, 0) = pchip_end_slope(h(0), h(1), m(c, 0), m(c, 1));
      d(c, n - 1) = pchip_end_slope(h(n - 2), h(n - 3), m(c, n - 2), m(c, n - 3));
    }
  }
  out.set_hermite(y, m, std::move(d));
  return out;
}

Interpolant Interpolant::cubic_spline(std::span<const double> x,
                                      const Eigen::Ref<const MatrixXd>& y) {
  validate("cubic spline interpolation", x, y);
  Interpolant out({x.begin(), x.end()}, y.rows(), 3);
  VectorXd h;
  MatrixXd m;
  secants(x, y, h, m);
  const Index n = static_cast<Index>(x.size());
  MatrixXd s(y.rows(), n);
  if (n == 2) {
    // scipy replaces not-a-knot by first derivative = secant at both ends: the straight line.
    s.col(0) = m.col(0);
    s.col(1) = m.col(0);
  } else if (n == 3) {
    // Not-a-knot at the single interior knot: the parabola through the three points,
    // p(x) = y0 + m0 (x - x0) + c (x - x0)(x - x1) with c = (m1 - m0) / (h0 + h1);
    // its slopes at the knots are m0 - c h0, m0 + c h0 and m1 + c h1.
    const VectorXd c = (m.col(1) - m.col(0)) / (h(0) + h(1));
    s.col(0) = m.col(0) - c * h(0);
    s.col(1) = m.col(0) + c * h(0);
    s.col(2) = m.col(1) + c * h(1);
  } else {
    // Slopes s_i of the C2 spline (de Boor, A Practical Guide to Splines, ch. IV):
    //   h_i s_{i-1} + 2 (h_{i-1} + h_i) s_i + h_{i-1} s_{i+1} = 3 (h_i m_{i-1} + h_{i-1} m_i),
    // closed by not-a-knot rows (continuity of the third derivative at x_1 and x_n-2):
    //   h_1 s_0 + (h_0 + h_1) s_1 = ((h_0 + 2 (h_0 + h_1)) h_1 m_0 + h_0^2 m_1) / (h_0 + h_1)
    // and its mirror image at the right end (the rows scipy's CubicSpline builds).
    const std::size_t nn = static_cast<std::size_t>(n);
    std::vector<double> dl(nn - 1), diag(nn), du(nn - 1);
    for (Index i = 1; i + 1 < n; ++i) {
      dl[i - 1] = h(i);
      diag[i] = 2.0 * (h(i - 1) + h(i));
      du[i] = h(i - 1);
      s.col(i) = 3.0 * (h(i) * m.col(i - 1) + h(i - 1) * m.col(i));
    }
    const double d0 = x[2] - x[0];
    diag[0] = h(1);
    du[0] = d0;
    s.col(0) = ((h(0) + 2.0 * d0) * h(1) * m.col(0) + h(0) * h(0) * m.col(1)) / d0;
    const double dn = x[nn - 1] - x[nn - 3];
    dl[nn - 2] = dn;
    diag[nn - 1] = h(n - 3);
    s.col(n - 1) =
        (h(n - 2) * h(n - 2) * m.col(n - 3) + (2.0 * dn + h(n - 2)) * h(n - 3) * m.col(n - 2)) / dn;
    solve_tridiagonal(std::move(dl), std::move(diag), std::move(du), s);
  }
  out.set_hermite(y, m, std::move(s));
  return out;
}

Interpolant Interpolant::make(InterpolationKind kind, std::span<const double> x,
                              const Eigen::Ref<const MatrixXd>& y) {
  switch (kind) {
    case InterpolationKind::linear:
      return linear(x, y);
    case InterpolationKind::pchip:
      return pchip(x, y);
    case InterpolationKind::cubic_spline_not_a_knot:
      return cubic_spline(x, y);
  }
  assert(false && "unknown InterpolationKind");
  return linear(x, y);
}

std::size_t Interpolant::find_interval(double xq, std::size_t hint) const {
  const std::size_t last = x_.size() - 2;
  // Sorted queries mostly stay in the same interval or move to the next one.
  if (hint <= last && (hint == 0 || xq >= x_[hint]) && (hint == last || xq < x_[hint + 1])) {
    return hint;
  }
  if (hint < last && xq >= x_[hint + 1] && (hint + 1 == last || xq < x_[hint + 2])) {
    return hint + 1;
  }
  // Interval index = number of interior knots x_1 .. x_n-2 that are <= xq.
  const auto first = x_.begin() + 1;
  const auto end = x_.end() - 1;
  return static_cast<std::size_t>(std::upper_bound(first, end, xq) - first);
}

template <int Order>
void Interpolant::evaluate_impl(std::span<const double> xq, Eigen::Ref<MatrixXd> out) const {
  assert(out.rows() == channels_ && static_cast<std::size_t>(out.cols()) == xq.size());
  const Index cc = channels_;
  std::size_t hint = 0;
  for (std::size_t j = 0; j < xq.size(); ++j) {
    const double q = xq[j];
    if (!std::isfinite(q)) {
      throw Error(fmt::format("interpolation: query xq[{}] = {} is not finite", j, q));
    }
    const std::size_t i = find_interval(q, hint);
    hint = i;
    const double s = q - x_[i];
    const double* c0 = coef_.col(static_cast<Index>(i)).data();
    const double* c1 = c0 + cc;
    const double* c2 = c1 + cc;
    const double* c3 = c2 + cc;
    double* o = out.col(static_cast<Index>(j)).data();
    if constexpr (Order == 0) {
      if (degree_ == 1) {
        for (Index c = 0; c < cc; ++c) o[c] = c0[c] + s * c1[c];
      } else {
        for (Index c = 0; c < cc; ++c) o[c] = c0[c] + s * (c1[c] + s * (c2[c] + s * c3[c]));
      }
    } else if constexpr (Order == 1) {
      for (Index c = 0; c < cc; ++c) o[c] = c1[c] + s * (2.0 * c2[c] + 3.0 * s * c3[c]);
    } else if constexpr (Order == 2) {
      for (Index c = 0; c < cc; ++c) o[c] = 2.0 * c2[c] + 6.0 * s * c3[c];
    } else {
      for (Index c = 0; c < cc; ++c) o[c] = 6.0 * c3[c];
    }
  }
}

void Interpolant::evaluate(std::span<const double> xq, Eigen::Ref<MatrixXd> out) const {
  evaluate_impl<0>(xq, out);
}

MatrixXd Interpolant::operator()(std::span<const double> xq) const {
  MatrixXd out(channels_, static_cast<Index>(xq.size()));
  evaluate_impl<0>(xq, out);
  return out;
}

void Interpolant::evaluate_derivative(std::span<const double> xq, int order,
                                      Eigen::Ref<MatrixXd> out) const {
  switch (order) {
    case 0:
      return evaluate_impl<0>(xq, out);
    case 1:
      return evaluate_impl<1>(xq, out);
    case 2:
      return evaluate_impl<2>(xq, out);
    case 3:
      return evaluate_impl<3>(xq, out);
    default:
      assert(false && "derivative order must be 0..3");
  }
}

MatrixXd interpolate(InterpolationKind kind, std::span<const double> x,
                     const Eigen::Ref<const MatrixXd>& y, std::span<const double> xq) {
  return Interpolant::make(kind, x, y)(xq);
}

std::vector<double> interpolate(InterpolationKind kind, std::span<const double> x,
                                std::span<const double> y, std::span<const double> xq) {
  const Eigen::Map<const MatrixXd> y_row(y.data(), 1, static_cast<Index>(y.size()));
  const Interpolant f = Interpolant::make(kind, x, y_row);
  std::vector<double> out(xq.size());
  Eigen::Map<MatrixXd> out_row(out.data(), 1, static_cast<Index>(out.size()));
  f.evaluate(xq, out_row);
  return out;
}

}  // namespace imukit
