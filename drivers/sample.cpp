#include "imukit/drivers/sample.hpp"

#include <fmt/core.h>

#include <cassert>

#include "imukit/core/error.hpp"

namespace imukit::drivers {

CounterUnwrapper::CounterUnwrapper(unsigned bits) {
  assert(bits >= 1 && bits <= 63);
  mask_ = (uint64_t{1} << bits) - 1;
  half_ = int64_t{1} << (bits - 1);
}

int64_t CounterUnwrapper::unwrap(uint64_t raw) {
  raw &= mask_;
  if (!started_) {
    started_ = true;
    reference_ = static_cast<int64_t>(raw);
    last_step_ = 0;
    return reference_;
  }
  // Difference modulo 2^bits, mapped into [-half, half): the half-range rule.
  int64_t delta = static_cast<int64_t>((raw - static_cast<uint64_t>(reference_)) & mask_);
  if (delta >= half_) delta -= static_cast<int64_t>(mask_) + 1;
  last_step_ = delta;
  const int64_t value = reference_ + delta;
  if (delta > 0) reference_ = value;
  return value;
}

TimeNs ticks_to_ns(int64_t ticks, uint64_t tick_hz) {
  // Whole seconds and the remainder separately, so nothing overflows for tick_hz < 9.2e9 (the
  // remainder times 1e9 stays below 2^63) and the result is exact to the nearest ns.
  assert(tick_hz > 0 && tick_hz < 9'000'000'000ULL);
  const auto hz = static_cast<int64_t>(tick_hz);
  int64_t whole = ticks / hz;
  int64_t rem = ticks % hz;
  if (rem < 0) {
    rem += hz;
    whole -= 1;
  }
  return whole * kNsPerSecond + (rem * kNsPerSecond + hz / 2) / hz;
}

ImuSeries to_series(std::span<const Sample> samples, bool use_device_time) {
  // The channels an ImuSeries holds (a WitMotion sample's angles are not among them).
  constexpr uint8_t kSeriesChannels = kHasAccel | kHasGyro | kHasMag | kHasTemperature;
  const uint8_t ch = samples.empty() ? 0 : samples.front().channels;
  bool device = use_device_time;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    device = device && samples[i].has_device_time;
    // A channel missing from some samples (an Xsens sending its magnetometer at 100 Hz beside
    // 400 Hz inertial data) would read as zeros there (found in review, 2026-11-27).
    if ((samples[i].channels ^ ch) & kSeriesChannels) {
      throw Error(
          fmt::format("to_series: sample {} has channels {:#x}, sample 0 {:#x}; a series "
                      "holds samples of one channel set",
                      i, samples[i].channels, ch));
    }
  }
  ImuSeries out = ImuSeries::with_channels(samples.size(), ch & kHasAccel, ch & kHasGyro,
                                           ch & kHasMag, ch & kHasTemperature);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    out.t[i] = device ? s.device_time : s.host_time;
    for (int k = 0; k < 3; ++k) {
      if (out.has_accel()) out.accel(k, static_cast<Eigen::Index>(i)) = s.accel[k];
      if (out.has_gyro()) out.gyro(k, static_cast<Eigen::Index>(i)) = s.gyro[k];
      if (out.has_mag()) out.mag(k, static_cast<Eigen::Index>(i)) = s.mag[k];
    }
    if (out.has_temperature()) out.temperature_c[static_cast<Eigen::Index>(i)] = s.temperature_c;
  }
  return out;
}

}  // namespace imukit::drivers
