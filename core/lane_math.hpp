// Branch-free double-precision atan2 and sincos for loops that should vectorise.
//
// libm's atan2, sin and cos are opaque calls, so a loop over them runs one element at a time.
// These are plain arithmetic and selects (no calls, no branches, no table lookups), so gcc turns
// a loop of them into vector code for whatever instruction set the function is built for, and
// every instruction set gives the same bits (no FMA contraction in this project's build). Accurate
// to a few units in the last place over the ranges stated (tests/core/lane_math_test.cpp);
// meant for hot loops such as scaling thousands of rotation angles, not as a libm replacement.
// Build the loop's file with -fno-trapping-math: otherwise gcc will not evaluate both arms of a
// select (an arm's arithmetic might raise a floating-point flag) and only AVX-512's masked
// instructions vectorise it.
#pragma once

namespace imukit::lane {

// x rounded to the nearest integer (ties to even), for |x| < 2^51, by the 1.5 * 2^52 trick:
// adding it leaves no fraction bits. Exact; vectorises on every x86 level (no roundpd needed).
[[gnu::always_inline]] inline double round_small(double x) {
  constexpr double kShift = 6755399441055744.0;  // 1.5 * 2^52
  return (x + kShift) - kShift;
}

// atan2(y, x) for y >= 0 and x >= 0, not both 0: the angle in [0, pi/2]. The smaller over the
// larger, t in [0, 1], is reduced by the nearest of the angles 0, pi/8 and pi/4 (t - c over
// 1 + t c, c its tangent) to |x| <= tan(pi/16) = 0.199, where 13 terms of the Taylor series reach
// 1e-18; two divisions, no square root. The reduction's constant c = tan(pi/8) is not exact in
// double, but atan of the double c rounds to the same double as pi/8 (to 1.2e-17).
[[gnu::always_inline]] inline double atan2_first_quadrant(double y, double x) {
  const bool swap = y > x;
  const double hi = swap ? y : x;
  const double lo = swap ? x : y;
  const double t = lo / hi;
  constexpr double kTanPiOver16 = 0.198912367379658;
  constexpr double kTan3PiOver16 = 0.6681786379192989;
  constexpr double kTanPiOver8 = 0.41421356237309503;
  const double c = t > kTan3PiOver16 ? 1.0 : t > kTanPiOver16 ? kTanPiOver8 : 0.0;
  const double base = t > kTan3PiOver16  ? 0.7853981633974483
                      : t > kTanPiOver16 ? 0.39269908169872414
                                         : 0.0;
  const double r = (t - c) / (1.0 + t * c);
  const double u = r * r;
  double p = 1.0 / 25.0;
  for (int k = 11; k >= 0; --k) p = 1.0 / (2 * k + 1) - u * p;
  const double a = base + r * p;
  constexpr double kHalfPi = 1.57079632679489661923;
  return swap ? kHalfPi - a : a;
}

struct SinCos {
  double sin, cos;
};

// sin x and cos x for |x| < 1e5. Cody-Waite reduction by pi/2 in two parts (the first has 33
// significant bits, so k * part is exact for |k| < 2^20), then Taylor polynomials on
// |r| <= pi/4 (error below 1e-19) and the quadrant by selects.
[[gnu::always_inline]] inline SinCos sincos_small(double x) {
  constexpr double kTwoOverPi = 0.636619772367581343076;
  constexpr double kPiOver2Hi = 1.57079632673412561417e+00;  // 33 bits of pi/2
  constexpr double kPiOver2Lo = 6.07710050650619224932e-11;  // pi/2 - kPiOver2Hi
  const double k = round_small(x * kTwoOverPi);
  const double r = (x - k * kPiOver2Hi) - k * kPiOver2Lo;
  const double r2 = r * r;
  // sin r = r (1 - r^2/3! + r^4/5! - ... - r^16/17!), cos r = 1 - r^2/2! + ... + r^18/18!.
  double s = 1.0, c = 1.0;
  for (int n = 17; n >= 3; n -= 2) s = 1.0 - r2 * (1.0 / (n * (n - 1))) * s;
  for (int n = 18; n >= 2; n -= 2) c = 1.0 - r2 * (1.0 / (n * (n - 1))) * c;
  s *= r;
  // Quadrant k mod 4 = 2 h + o (h, o in {0, 1}); floors of whole numbers over 2 and 4 by
  // rounding. sin x = (-1)^h (o ? cos r : sin r), cos x = (-1)^(h xor o) (o ? sin r : cos r),
  // the choices as exact products with 0 and 1 rather than branches.
  const double q = k - 4.0 * round_small(0.25 * k - 0.375);
  const double h = round_small(0.5 * q - 0.25);
  const double o = q - 2.0 * h;
  const double sin_sign = 1.0 - 2.0 * h;
  const double cos_sign = 1.0 - 2.0 * ((h + o) - 2.0 * (h * o));
  return {sin_sign * (s * (1.0 - o) + c * o), cos_sign * (c * (1.0 - o) + s * o)};
}

}  // namespace imukit::lane
