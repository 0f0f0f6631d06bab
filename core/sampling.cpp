#include "core/sampling.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace imukit {

bool SamplingStats::is_uniform(double tolerance) const {
  if (samples < 3) return true;
  return max_period_s <= median_period_s * (1.0 + tolerance) &&
         min_period_s >= median_period_s * (1.0 - tolerance);
}

SamplingStats analyze_sampling(std::span<const TimeNs> t) {
  SamplingStats s;
  s.samples = t.size();
  if (t.size() < 2) return s;
  s.duration = t.back() - t.front();
  const std::size_t n = t.size() - 1;
  std::vector<TimeNs> periods(n);
  for (std::size_t i = 0; i < n; ++i) periods[i] = t[i + 1] - t[i];
  s.mean_period_s = to_seconds(s.duration) / static_cast<double>(n);
  s.mean_rate_hz = s.mean_period_s > 0 ? 1.0 / s.mean_period_s : 0.0;
  // Jitter about the mean in integer ns first, so a long stream keeps full precision.
  double sum_sq = 0.0;
  const double mean_ns = static_cast<double>(s.duration) / static_cast<double>(n);
  for (TimeNs p : periods) {
    const double d = static_cast<double>(p) - mean_ns;
    sum_sq += d * d;
    if (p == 0) ++s.repeated;
  }
  s.period_std_s = std::sqrt(sum_sq / static_cast<double>(n)) * 1e-9;
  const auto [lo, hi] = std::minmax_element(periods.begin(), periods.end());
  s.min_period_s = to_seconds(*lo);
  s.max_period_s = to_seconds(*hi);
  std::nth_element(periods.begin(), periods.begin() + static_cast<std::ptrdiff_t>(n / 2),
                   periods.end());
  const TimeNs median = periods[n / 2];
  s.median_period_s = to_seconds(median);
  for (TimeNs p : periods) {
    if (2 * p > 3 * median) ++s.gaps;
  }
  return s;
}

}  // namespace imukit
