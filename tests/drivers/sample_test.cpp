#include "imukit/drivers/sample.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"

namespace imukit::drivers {
namespace {

TEST(CounterUnwrapper, ContinuesAcrossWraps) {
  CounterUnwrapper u(16);
  EXPECT_EQ(u.unwrap(65530), 65530);
  EXPECT_EQ(u.unwrap(65535), 65535);
  EXPECT_EQ(u.unwrap(3), 65539);  // wrapped: +4
  EXPECT_EQ(u.last_step(), 4);
  EXPECT_EQ(u.unwrap(10), 65546);
}

TEST(CounterUnwrapper, HalfRangeRuleDecidesDirection) {
  CounterUnwrapper u(8);
  EXPECT_EQ(u.unwrap(100), 100);
  // 127 ahead is forward (< half range = 128).
  EXPECT_EQ(u.unwrap(227), 227);
  EXPECT_EQ(u.last_step(), 127);
  // 128 "ahead" is taken as 128 behind.
  EXPECT_EQ(u.unwrap(99), 99);
  EXPECT_EQ(u.last_step(), -128);
  // A late value never moves the reference back: the next forward value unwraps against 227.
  EXPECT_EQ(u.unwrap(230), 230);
  EXPECT_EQ(u.last_step(), 3);
}

TEST(CounterUnwrapper, LateValueBeforeAWrapUnwrapsBelowTheReference) {
  CounterUnwrapper u(6);
  u.unwrap(62);
  EXPECT_EQ(u.unwrap(1), 65);   // wrapped forward by 3
  EXPECT_EQ(u.unwrap(63), 63);  // a late one from before the wrap
  EXPECT_EQ(u.last_step(), -2);
  EXPECT_EQ(u.unwrap(2), 66);
}

TEST(TicksToNs, IsExactAndRoundsToNearest) {
  EXPECT_EQ(ticks_to_ns(1'000'000, 1'000'000), 1'000'000'000);
  EXPECT_EQ(ticks_to_ns(1, 3'000'000), 333);  // 333.33 ns
  EXPECT_EQ(ticks_to_ns(2, 3'000'000), 667);  // 666.67 ns
  EXPECT_EQ(ticks_to_ns(-1, 3'000'000), -333);
  // 2^40 ticks of a 10 kHz clock: 109951162.7776 s, exact in integers.
  EXPECT_EQ(ticks_to_ns(int64_t{1} << 40, 10'000), (int64_t{1} << 40) * 100'000);
}

TEST(ToSeries, UsesDeviceTimeWhenEverySampleHasIt) {
  std::vector<Sample> s(2);
  for (int i = 0; i < 2; ++i) {
    s[i].host_time = 1000 + i;
    s[i].device_time = 50 + 10 * i;
    s[i].has_device_time = true;
    s[i].channels = kHasAccel | kHasGyro;
    s[i].accel = {1.0 * i, 2, 3};
    s[i].gyro = {4, 5, 6.0 * i};
  }
  ImuSeries a = to_series(s);
  EXPECT_EQ(a.t, (std::vector<TimeNs>{50, 60}));
  EXPECT_EQ(a.accel(0, 1), 1.0);
  EXPECT_EQ(a.gyro(2, 1), 6.0);
  EXPECT_FALSE(a.has_mag());
  s[1].has_device_time = false;
  EXPECT_EQ(to_series(s).t, (std::vector<TimeNs>{1000, 1001}));
  s[1].channels |= kHasAngles;  // not a channel of a series: no matter
  EXPECT_EQ(to_series(s).size(), 2u);
  s[1].channels |= kHasMag;  // its magnetometer would be zeros in sample 0
  EXPECT_THROW(to_series(s), Error);
}

}  // namespace
}  // namespace imukit::drivers
