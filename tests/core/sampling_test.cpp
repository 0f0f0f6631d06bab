#include "core/sampling.hpp"

#include <gtest/gtest.h>
#include <cmath>
#include <vector>

namespace imukit {
namespace {

TEST(AnalyzeSampling, MeasuresRateJitterGapsAndRepeats) {
  // 10 ms nominal, one 11 ms period, one 30 ms gap, one repeated stamp.
  const std::vector<TimeNs> t = {0,          10'000'000, 21'000'000, 31'000'000,
                                 61'000'000, 61'000'000, 71'000'000};
  const SamplingStats s = analyze_sampling(t);
  EXPECT_EQ(s.samples, 7u);
  EXPECT_EQ(s.duration, 71'000'000);
  EXPECT_DOUBLE_EQ(s.mean_period_s, 0.071 / 6.0);
  EXPECT_DOUBLE_EQ(s.median_period_s, 0.010);
  EXPECT_DOUBLE_EQ(s.min_period_s, 0.0);
  EXPECT_DOUBLE_EQ(s.max_period_s, 0.030);
  EXPECT_EQ(s.gaps, 1u);
  EXPECT_EQ(s.repeated, 1u);
  EXPECT_FALSE(s.is_uniform());
  // Population std of {10,11,10,30,0,10} ms about their mean 71/6 ms.
  const double m = 71.0 / 6.0;
  const double var =
      ((10 - m) * (10 - m) * 3 + (11 - m) * (11 - m) + (30 - m) * (30 - m) + m * m) / 6.0;
  EXPECT_NEAR(s.period_std_s, std::sqrt(var) * 1e-3, 1e-15);
}

TEST(AnalyzeSampling, UniformStreamOverADayKeepsNanosecondPrecision) {
  std::vector<TimeNs> t(8'640'001);
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i] = sample_time(1'700'000'000'000'000'000, static_cast<int64_t>(i), 100.0);
  }
  const SamplingStats s = analyze_sampling(t);
  EXPECT_DOUBLE_EQ(s.mean_rate_hz, 100.0);
  EXPECT_EQ(s.period_std_s, 0.0);
  EXPECT_TRUE(s.is_uniform(1e-12));
  EXPECT_EQ(s.gaps, 0u);
}

TEST(AnalyzeSampling, ShortStreamsHaveNoPeriods) {
  EXPECT_EQ(analyze_sampling(std::vector<TimeNs>{}).samples, 0u);
  const SamplingStats one = analyze_sampling(std::vector<TimeNs>{5});
  EXPECT_EQ(one.samples, 1u);
  EXPECT_EQ(one.mean_rate_hz, 0.0);
}

}  // namespace
}  // namespace imukit
