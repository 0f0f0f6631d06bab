#include "imukit/core/time.hpp"

#include <gtest/gtest.h>

namespace imukit {
namespace {

TEST(SampleTime, IsExactForIntegralRatesOverADay) {
  // 24 h at 1 kHz: sample 86,399,999 lies at 86399.999 s exactly.
  EXPECT_EQ(sample_time(0, 86'399'999, 1000.0), 86'399'999'000'000);
  // 24 h at 100 Hz, offset start.
  EXPECT_EQ(sample_time(5, 8'640'000, 100.0), 86'400'000'000'005);
  // 3 Hz: 1/3 s rounds to the nearest ns.
  EXPECT_EQ(sample_time(0, 1, 3.0), 333'333'333);
  EXPECT_EQ(sample_time(0, 2, 3.0), 666'666'667);
  EXPECT_EQ(sample_time(0, 3'000'000'001, 3.0), 1'000'000'000'333'333'333);
}

TEST(SampleTime, HandlesFractionalRates) {
  // BROAD's 285.714285 Hz: sample k at k / 285.714285 s.
  const double rate = 285.714285;
  for (int64_t k :
       {int64_t{0}, int64_t{1}, int64_t{1000}, int64_t{52'000}, int64_t{24'685'714'000}}) {
    const long double expected = static_cast<long double>(k) * 1e9L / rate;
    EXPECT_NEAR(static_cast<long double>(sample_time(0, k, rate)), expected, 0.5L) << k;
  }
}

TEST(SampleTime, NegativeIndicesMirrorPositiveOnes) {
  EXPECT_EQ(sample_time(0, -1, 1000.0), -1'000'000);
  EXPECT_EQ(sample_time(0, -1001, 1000.0), -1'001'000'000);
}

TEST(SampleClock, GivesSampleTimesExactlyInOrderAndOutOfIt) {
  for (const double rate :
       {1.0, 3.0, 100.0, 120.0, 1000.0, 1e6, 1e9, 5e8, 285.714285, 0.5, 99.9, 4e9}) {
    for (const TimeNs t0 : {TimeNs{0}, TimeNs{-7}, TimeNs{1'700'000'000'000'000'000}}) {
      SampleClock clock(t0, rate);
      // In order across several whole seconds, from a negative index on.
      for (int64_t k = -2500; k < 5000; ++k)
        ASSERT_EQ(clock(k), sample_time(t0, k, rate)) << rate << " " << t0 << " " << k;
      // Jumps, backwards and far, then in order again.
      for (const int64_t k :
           {int64_t{7}, int64_t{3}, int64_t{0}, int64_t{-1}, int64_t{999'999}, int64_t{1'000'000},
            int64_t{1'000'001}, int64_t{86'399'999}, int64_t{5}, int64_t{6}}) {
        ASSERT_EQ(clock(k), sample_time(t0, k, rate)) << rate << " " << t0 << " " << k;
      }
    }
  }
}

TEST(TimeConversions, RoundTripSeconds) {
  EXPECT_EQ(from_seconds(1.5), 1'500'000'000);
  EXPECT_EQ(from_seconds(-0.25), -250'000'000);
  EXPECT_DOUBLE_EQ(to_seconds(2'500'000'000), 2.5);
  EXPECT_EQ(period_ns(200.0), 5'000'000);
  EXPECT_EQ(period_ns(285.714285), 3'500'000);
}

// A whole number of periods in doubles' rounding keeps its last sample; a fraction does not add
// one. 0.29 * 100 is 28.999999999999996 and floor() gave 29 samples, not 30.
TEST(SamplesSpanning, CountsBothEndsThroughRounding) {
  EXPECT_EQ(samples_spanning(0.29, 100.0), 30);
  EXPECT_EQ(samples_spanning(0.1 + 0.2, 10.0), 4);  // 0.30000000000000004 s
  EXPECT_EQ(samples_spanning(0.0, 100.0), 1);
  EXPECT_EQ(samples_spanning(0.295, 100.0), 30);        // half a period more: no extra sample
  EXPECT_EQ(samples_spanning(0.29 - 1e-5, 100.0), 29);  // a thousandth of a period short
  // The largest motions imukit takes: 1e7 frames, 1e7 s at 1 Hz and 1e5 s at 100 Hz.
  EXPECT_EQ(samples_spanning(1e7, 1.0), 10'000'001);
  EXPECT_EQ(samples_spanning(99999.99, 100.0), 9'999'999 + 1);
  for (int n = 1; n < 2000; ++n) ASSERT_EQ(samples_spanning(n / 120.0, 120.0), n + 1) << n;
}

}  // namespace
}  // namespace imukit
