// Time in imukit is an int64_t count of nanoseconds (since the Unix epoch for recordings, since
// the start of the motion for simulations). 2^63 ns is 292 years, so no clock in use wraps, and
// integer sample times never accumulate rounding error over hours-long sequences.
#pragma once

#include <cmath>
#include <cstdint>

namespace imukit {

using TimeNs = int64_t;

inline constexpr TimeNs kNsPerSecond = 1'000'000'000;

constexpr double to_seconds(TimeNs t) { return static_cast<double>(t) * 1e-9; }

// Nearest nanosecond; the caller keeps |seconds| below 9.2e9.
inline TimeNs from_seconds(double seconds) { return std::llround(seconds * 1e9); }

// Sample period of a rate, to the nearest nanosecond (kept for display: sample times themselves
// come from sample_time(), which does not round the period).
inline TimeNs period_ns(double rate_hz) { return std::llround(1e9 / rate_hz); }

// Time of sample `index` of a stream that starts at t0 with a constant rate: computed from the
// index, never by adding periods, and exact to the nanosecond for hours-long streams. For an
// integral rate the whole seconds are split off in integers (8.64e7 samples of a 24 h stream at
// 1 kHz would otherwise need 57 bits); other rates use the 64-bit mantissa of long double.
inline TimeNs sample_time(TimeNs t0, int64_t index, double rate_hz) {
  double whole = 0.0;
  if (std::modf(rate_hz, &whole) == 0.0 && whole >= 1.0 && whole < 4e18) {
    const auto per_second = static_cast<int64_t>(whole);
    return t0 + (index / per_second) * kNsPerSecond +
           std::llround(static_cast<double>(index % per_second) * 1e9 / rate_hz);
  }
  return t0 + std::llround(static_cast<long double>(index) * 1e9L / rate_hz);
}

// The samples of a grid at rate_hz over duration_s, both ends included: the whole periods in the
// duration, plus one. A product within 1e-6 periods of a whole number is that number: 0.29 s at
// 100 Hz is 28.999999999999996 periods in doubles, and floor() lost the last frame (review,
// 2026-11-27). Doubles' rounding stays below 1e-6 periods up to about 4e9 periods (a longer
// procedural scene, 46 days at 1 kHz, can lose its last frame to it).
inline int64_t samples_spanning(double duration_s, double rate_hz) {
  const double periods = duration_s * rate_hz;
  const double nearest = std::round(periods);
  return static_cast<int64_t>(std::abs(periods - nearest) <= 1e-6 ? nearest : std::floor(periods)) +
         1;
}

// sample_time(t0, index, rate_hz) for index after index: the same times, without the division
// per call (a stream's bookkeeping loops call it per sample). Any index may be asked for; the
// next one after a non-negative index is the cheap case.
class SampleClock {
 public:
  SampleClock(TimeNs t0, double rate_hz) : t0_(t0), rate_hz_(rate_hz) {
    double whole = 0.0;
    if (std::modf(rate_hz, &whole) == 0.0 && whole >= 1.0 && whole < 4e18)
      per_second_ = static_cast<int64_t>(whole);
  }

  TimeNs operator()(int64_t index) {
    if (per_second_ == 0) return sample_time(t0_, index, rate_hz_);
    if (index != next_ || index <= 0) {
      seconds_ = index / per_second_;
      within_ = index % per_second_;
    }
    const TimeNs t =
        t0_ + seconds_ * kNsPerSecond + std::llround(static_cast<double>(within_) * 1e9 / rate_hz_);
    // The next index's quotient and remainder (of a non-negative index: no sign cases).
    next_ = index + 1;
    if (++within_ == per_second_) within_ = 0, ++seconds_;
    return t;
  }

 private:
  TimeNs t0_;
  double rate_hz_;
  int64_t per_second_ = 0;  // the rate when it is a whole number, else 0
  int64_t next_ = 0;        // the index whose quotient and remainder are held, when > 0
  int64_t seconds_ = 0, within_ = 0;
};

}  // namespace imukit
