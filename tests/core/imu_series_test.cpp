#include "imukit/core/imu_series.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"

namespace imukit {
namespace {

ImuSeries make_series(std::size_t n) {
  ImuSeries s = ImuSeries::with_channels(n, true, true, false, true);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    s.t[i] = static_cast<TimeNs>(i) * 5'000'000;
    s.accel.col(c) = Eigen::Vector3d(double(i), 2.0 * double(i), 9.81);
    s.gyro.col(c) = Eigen::Vector3d(0.1 * double(i), 0.0, -0.1 * double(i));
    s.temperature_c[c] = 20.0 + 0.01 * double(i);
  }
  return s;
}

TEST(ImuSeries, ReportsItsChannels) {
  const ImuSeries s = make_series(4);
  EXPECT_EQ(s.size(), 4u);
  EXPECT_TRUE(s.has_accel());
  EXPECT_TRUE(s.has_gyro());
  EXPECT_FALSE(s.has_mag());
  EXPECT_TRUE(s.has_temperature());
  EXPECT_NO_THROW(s.validate());
}

TEST(ImuSeries, SliceSharesMemoryAndSeesTheRightSamples) {
  const ImuSeries s = make_series(10);
  const ImuSeriesView v = s.slice(3, 4);
  ASSERT_EQ(v.size(), 4u);
  EXPECT_EQ(v.t.front(), 15'000'000);
  EXPECT_EQ(v.accel.data(), s.accel.data() + 9);  // no copy
  EXPECT_DOUBLE_EQ(v.accel(1, 0), 6.0);
  EXPECT_DOUBLE_EQ(v.gyro(2, 3), -0.6);
  EXPECT_DOUBLE_EQ(v.temperature_c[1], 20.04);
  EXPECT_FALSE(v.has_mag());
  const ImuSeriesView inner = v.slice(1, 2);
  EXPECT_EQ(inner.t.front(), 20'000'000);
  EXPECT_DOUBLE_EQ(inner.accel(0, 1), 5.0);
  const ImuSeries copy = inner.copy();
  EXPECT_EQ(copy.size(), 2u);
  EXPECT_DOUBLE_EQ(copy.accel(0, 1), 5.0);
  EXPECT_FALSE(copy.has_mag());
}

TEST(ImuSeries, EmptySliceIsValid) {
  const ImuSeries s = make_series(3);
  EXPECT_EQ(s.slice(3, 0).size(), 0u);
}

TEST(ImuSeries, ValidateRejectsMismatchedChannels) {
  ImuSeries s = make_series(5);
  s.gyro.conservativeResize(3, 4);
  EXPECT_THROW(s.validate(), Error);
}

TEST(ImuSeries, ValidateRejectsTimeGoingBackwards) {
  ImuSeries s = make_series(5);
  s.t[3] = s.t[2] - 1;
  try {
    s.validate();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace imukit
