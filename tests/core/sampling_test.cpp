#include "imukit/core/sampling.hpp"

#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"

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
  EXPECT_EQ(s.gap_duration, 30'000'000);
  EXPECT_DOUBLE_EQ(s.mean_period_between_gaps_s, 0.041 / 5.0);  // {10,11,10,0,10} ms
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

// The median and the gap count by the definition (sorted periods), for comparison with the
// counting path analyze_sampling takes when the periods span fewer than 32,768 ns.
TEST(AnalyzeSampling, MedianAndGapsAgreeWithSortedPeriodsOnEveryPath) {
  Rng rng(31);
  // Jitter spans: 0 ns (all periods equal), a few ns and a few us (counting), 1 ms (sorting).
  for (const TimeNs jitter : {TimeNs(0), TimeNs(3), TimeNs(4000), TimeNs(1'000'000)}) {
    for (const std::size_t count :
         {std::size_t(2), std::size_t(3), std::size_t(1000), std::size_t(1001)}) {
      std::vector<TimeNs> t(count);
      TimeNs now = 1'000'000'000;
      for (std::size_t i = 0; i < count; ++i) {
        t[i] = now;
        TimeNs p = 10'000;
        if (jitter > 0) p += TimeNs(std::floor(rng.uniform() * double(jitter)));
        if (i % 97 == 5) p = 0;                // repeated stamp
        if (i % 89 == 7) p = 16'000 + jitter;  // gap (above 1.5 median periods)
        now += p;
      }
      std::vector<TimeNs> periods;
      for (std::size_t i = 0; i + 1 < count; ++i) periods.push_back(t[i + 1] - t[i]);
      std::vector<TimeNs> sorted = periods;
      std::sort(sorted.begin(), sorted.end());
      const TimeNs median = sorted[sorted.size() / 2];
      std::size_t gaps = 0, repeated = 0;
      TimeNs gap_duration = 0;
      for (TimeNs p : periods) {
        gaps += 2 * p > 3 * median, repeated += p == 0;
        if (2 * p > 3 * median) gap_duration += p;
      }
      const SamplingStats s = analyze_sampling(t);
      SCOPED_TRACE(::testing::Message() << "jitter " << jitter << " count " << count);
      EXPECT_EQ(s.median_period_s, to_seconds(median));
      EXPECT_EQ(s.min_period_s, to_seconds(sorted.front()));
      EXPECT_EQ(s.max_period_s, to_seconds(sorted.back()));
      EXPECT_EQ(s.gaps, gaps);
      EXPECT_EQ(s.gap_duration, gap_duration);
      EXPECT_EQ(s.repeated, repeated);
    }
  }
}

// Motion files' times in seconds: the median step, whatever frames are missing or rounded.
TEST(MedianStep, IsTheMiddleStepOfUnevenAndRoundedTimes) {
  EXPECT_TRUE(std::isnan(median_step_s(std::vector<double>{})));
  EXPECT_TRUE(std::isnan(median_step_s(std::vector<double>{1.0})));
  EXPECT_DOUBLE_EQ(median_step_s(std::vector<double>{0.0, 0.5}), 0.5);
  // Steps 0.1, 0.3 (two frames missing), 0.1, 0.1: the median is 0.1 to rounding.
  EXPECT_NEAR(median_step_s(std::vector<double>{0.0, 0.1, 0.4, 0.5, 0.6}), 0.1, 1e-15);
  // An even count of steps gives the upper of the two middle ones: 1, 2, 3, 4 -> 3.
  EXPECT_DOUBLE_EQ(median_step_s(std::vector<double>{0.0, 4.0, 5.0, 8.0, 10.0}), 3.0);
  // Epoch seconds printed to the microsecond at 30 Hz: 33.333 or 33.334 ms.
  std::vector<double> t;
  for (int k = 0; k < 301; ++k) t.push_back(1.7e9 + std::round(k / 30.0 * 1e6) / 1e6);
  EXPECT_NEAR(median_step_s(t), 1.0 / 30.0, 1e-6);
}

TEST(MeasuredRate, IsTheFormulaAsWrittenBitForBit) {
  // 1001 stamps 10 ms apart with 7 ns of offset at the end: 1000 / 10.000000007 s.
  std::vector<TimeNs> t;
  for (TimeNs i = 0; i <= 1000; ++i) t.push_back(1'700'000'000'000'000'000 + i * 10'000'000);
  t.back() += 7;
  const TimeNs span = t.back() - t.front();
  EXPECT_EQ(measured_rate_hz(t, "x"), 1000.0 / (static_cast<double>(span) * 1e-9));
  EXPECT_EQ(mean_period_s(t, "x"), static_cast<double>(span) * 1e-9 / 1000.0);
  EXPECT_NEAR(measured_rate_hz(t, "x"), 100.0, 1e-6);
  // analyze_sampling's mean period is the same number.
  EXPECT_EQ(analyze_sampling(t).mean_period_s, mean_period_s(t, "x"));
}

TEST(MeasuredRate, DegenerateInputIsAnErrorNamingTheStream) {
  const auto message = [](std::vector<TimeNs> t, bool rate) {
    try {
      (void)(rate ? measured_rate_hz(t, "rec.csv") : mean_period_s(t, "rec.csv"));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  for (bool rate : {true, false}) {
    EXPECT_EQ(message({}, rate), "rec.csv: fewer than 2 samples");
    EXPECT_EQ(message({5}, rate), "rec.csv: fewer than 2 samples");
    EXPECT_EQ(message({5, 5, 5}, rate), "rec.csv: the time stamps do not advance");
    EXPECT_EQ(message({9, 7}, rate), "rec.csv: the time stamps do not advance");
  }
}

}  // namespace
}  // namespace imukit
