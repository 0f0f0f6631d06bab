// What the timestamps of a stream say about its sampling: the measured rate (not the nominal
// one), jitter, gaps and repeated stamps. Used wherever a rate matters (Allan deviation,
// resampling, `imukit info`), so the nominal-versus-measured rate pitfall is handled once.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "imukit/core/time.hpp"

namespace imukit {

struct SamplingStats {
  std::size_t samples = 0;
  TimeNs duration = 0;         // last minus first time
  double mean_period_s = 0.0;  // duration / (samples - 1)
  double mean_rate_hz = 0.0;   // 1 / mean_period_s
  double median_period_s = 0.0;
  double min_period_s = 0.0;
  double max_period_s = 0.0;
  double period_std_s = 0.0;  // standard deviation of the periods (jitter)
  std::size_t gaps = 0;       // periods longer than 1.5 median periods
  TimeNs gap_duration = 0;    // the sum of those periods
  // The mean of the other periods: the sampling period of a stream with samples missing (the
  // mean over the whole span counts each gap as periods that have no sample).
  double mean_period_between_gaps_s = 0.0;
  // The largest distance of a stamp from the uniform grid through the first and last ones
  // (t_0 + i mean period): a stream sampled uniformly with jittered or rounded stamps stays
  // within its jitter of it, one with samples missing drifts off by their periods.
  double max_offset_from_mean_grid_s = 0.0;
  std::size_t repeated = 0;  // periods of zero (equal time stamps)

  // True when the periods differ from the median by more than `tolerance` (relative) anywhere:
  // the stream is not uniformly sampled, and methods that assume it should say so.
  bool is_uniform(double tolerance = 0.01) const;
  // Samples are missing: there are gaps, and they move the stamps off the uniform grid by more
  // than two median periods. Long periods balanced by short ones (stamps rounded to 1 ms at
  // 800 Hz: periods of 1 and 2 ms; or jitter) are no gaps in the sampling, and a handful of
  // missing samples changes the mean period by no more than their count over n.
  bool samples_missing() const;
};

// Needs non-decreasing times; fewer than 2 samples give zero periods and rates.
SamplingStats analyze_sampling(std::span<const TimeNs> t);

// The median step between consecutive times in seconds, as motion files give them (the upper
// one of the two middle steps for an even count; NaN for fewer than 2 times). Frames missing
// from a motion are steps of two or more of it.
double median_step_s(std::span<const double> times_s);

// The mean period (t.back() - t.front()) / (n - 1) in s and the measured rate
// (n - 1) / (t.back() - t.front()) in Hz of n time stamps, each computed exactly as written (the
// rate is not 1 / period: the two round differently). Wherever a stream's rate is measured, it
// is one of these, so degenerate input fails the same way everywhere: imukit::Error
// "<what>: fewer than 2 samples" or "<what>: the time stamps do not advance".
// (analyze_sampling keeps its own mean_rate_hz = 1 / mean_period_s, zero for such input.)
double mean_period_s(std::span<const TimeNs> t, std::string_view what);
double measured_rate_hz(std::span<const TimeNs> t, std::string_view what);

// The rates imukit takes, of sensor samples and motion frames alike (a simulation, an Allan
// deviation): one an hour (a BVH's or a quaternion CSV's longest frame time, 3600 s) to 1 MHz.
// Below about 1e-10 Hz a period no longer fits int64 nanoseconds (9.2e18 ns): sample times
// overflowed and counting the samples never ended (found in review, 2026-11-26).
struct RateLimits {
  static constexpr double min_hz = 1.0 / 3600.0;
  static constexpr double max_hz = 1e6;
  static constexpr const char* text = "[1/3600 (one an hour), 1e6] Hz";
};
inline bool rate_within_limits(double rate_hz) {
  return rate_hz >= RateLimits::min_hz && rate_hz <= RateLimits::max_hz;
}
// Throws imukit::Error "<what> <rate> Hz is outside [1/3600 ..., 1e6] Hz" unless the rate is
// within RateLimits.
void check_rate(double rate_hz, const std::string& what);
// check_rate for the rate of a period measured from int64 ns time stamps: the period is taken
// to the nanosecond first, so a 1 MHz stream's mean period (1000 ns, a bit short of 1e-6 s in
// binary) does not read as 1e6 Hz plus a rounding. period_s > 0.
void check_period(double period_s, const std::string& what);

}  // namespace imukit
