// What the timestamps of a stream say about its sampling: the measured rate (not the nominal
// one), jitter, gaps and repeated stamps. Used wherever a rate matters (Allan deviation,
// resampling, `imukit info`), so the nominal-versus-measured rate pitfall is handled once.
#pragma once

#include <cstdint>
#include <span>

#include "core/time.hpp"

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
  std::size_t repeated = 0;   // periods of zero (equal time stamps)

  // True when the periods differ from the median by more than `tolerance` (relative) anywhere:
  // the stream is not uniformly sampled, and methods that assume it should say so.
  bool is_uniform(double tolerance = 0.01) const;
};

// Needs non-decreasing times; fewer than 2 samples give zero periods and rates.
SamplingStats analyze_sampling(std::span<const TimeNs> t);

}  // namespace imukit
