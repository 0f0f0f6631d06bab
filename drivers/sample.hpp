// What every device codec produces: timestamped samples in SI units with the device's own
// sequence and clock information, and counters that account for every byte and sample lost.
//
// A Sample keeps two times: host_time, when the bytes that completed it reached the host (the
// only time a device without a clock has), and device_time, the device's own clock unwrapped to
// 64 bits and converted to ns (when the device stamps its samples). capture/ maps one to the
// other; drivers never mix them.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "imukit/core/imu_series.hpp"
#include "imukit/core/time.hpp"

namespace imukit::drivers {

// Channel bits of Sample::channels.
inline constexpr uint8_t kHasAccel = 1u << 0;
inline constexpr uint8_t kHasGyro = 1u << 1;
inline constexpr uint8_t kHasMag = 1u << 2;
inline constexpr uint8_t kHasTemperature = 1u << 3;
inline constexpr uint8_t kHasAngles = 1u << 4;

struct Sample {
  TimeNs host_time = 0;    // host receive time of the bytes that completed the sample, ns
  TimeNs device_time = 0;  // device clock, unwrapped, ns since its zero (has_device_time)
  bool has_device_time = false;
  // Cumulative sample number: the device's counter unwrapped to 64 bits when it has one (so
  // gaps show), otherwise the count of samples decoded so far.
  uint64_t sequence = 0;
  // sequence counts every sample the device made, lost ones included (its counter, or the slot
  // of a stream at a known rate): a loss is a jump in it, so a tick step beyond its step is a
  // damaged tick (capture's DeviceClock). False for a count of the samples decoded, and for a
  // counter short enough to wrap within a live loss (the Sony pads' 6 or 8 bits): a sample
  // counter has at least 16 bits.
  bool has_sample_counter = false;
  uint8_t channels = 0;           // kHas* bits
  std::array<double, 3> accel{};  // specific force, m/s^2
  std::array<double, 3> gyro{};   // angular rate, rad/s
  // Magnetic field: tesla, unless mag_arbitrary_units (Xsens reports a.u. normalised to the
  // Earth field at its calibration site; WitMotion raw LSB), which the consumer must scale.
  std::array<double, 3> mag{};
  bool mag_arbitrary_units = false;
  double temperature_c = 0.0;          // degrees Celsius
  std::array<double, 3> angles_rad{};  // device-computed Euler angles (roll, pitch, yaw), rad
  uint32_t status = 0;                 // device status word where the device sends one
  // What the device sent before scaling, where it sends counts (kHas* bits in raw_channels):
  // kept so a recording can be recalibrated later.
  uint8_t raw_channels = 0;
  std::array<int32_t, 3> raw_accel{};
  std::array<int32_t, 3> raw_gyro{};
  std::array<int32_t, 3> raw_mag{};
  int32_t raw_temperature = 0;
  // The device clock in its own ticks (unwrapped) and their rate, where it has one.
  uint64_t device_ticks = 0;
  double tick_hz = 0.0;
};

// Every loss a codec can see. Invariant (checked by the tests): bytes_received ==
// bytes_accepted + bytes_discarded + bytes_pending().
struct CodecStats {
  uint64_t bytes_received = 0;
  uint64_t bytes_accepted = 0;   // bytes of valid frames / lines / reports
  uint64_t bytes_discarded = 0;  // garbage, corrupt frames, unparseable lines
  uint64_t frames_ok = 0;        // valid frames (samples or not)
  // Checksum, length, format or framing errors. Codecs that resynchronise byte by byte
  // count the frames a stretch of rejected bytes held: WitMotion ceil(bytes / 11), Xsens one per
  // damaged frame by the length its header gives (one for bytes up to the next valid frame when
  // the preamble or the length itself is what was damaged).
  // Each sample dropped for a non-finite value (samples_non_finite) counts here too.
  uint64_t frames_corrupt = 0;
  uint64_t frames_other = 0;     // valid frames that carry no sample (acks, info, logs)
  uint64_t samples_decoded = 0;  // samples handed out
  // Samples the device made that never arrived: gaps in its sample counter, or (for devices
  // without one) frames whose loss left a sample incomplete.
  uint64_t samples_dropped = 0;
  // Samples decoded from a valid frame but holding a NaN or infinite value: never handed out,
  // counted in frames_corrupt and samples_dropped as well (Codec::feed does this for every codec).
  uint64_t samples_non_finite = 0;
  // Samples of a stream that is not this session's, discarded as the session starts: what a
  // device left streaming by an earlier session sent before the Ack of our Start (the rest of
  // its stream, and the block our Stop flushed), or ours when that Ack was lost and the start-up
  // was repeated. Not losses of this session, so not in samples_dropped.
  uint64_t samples_before_start = 0;
  uint64_t counter_resets = 0;  // counter repeated or jumped back (device restarted its stream)
  // Optional feature reports (a pad's calibration) unreadable after the reader's attempts: the
  // codec streams with its defaults (the nominal scale), as the Linux driver does.
  uint64_t feature_reports_failed = 0;
  uint64_t device_errors = 0;  // error messages the device itself sent
  // Samples of a frame behind the stream on the same counter and clock (the link repeated the
  // frame, or delivered it after later ones), not handed out again: no counter reset, and no
  // loss beyond what the skip over them already counted in samples_dropped. (imukit codec.)
  uint64_t samples_stale = 0;
};

// Unwraps a free-running counter of `bits` bits (1..63) to 64 bits with the half-range rule: a
// step of less than half the range forward is progress, anything else is a step backwards
// (reordering or a restart). The reference only moves forward, so a late value unwraps
// correctly against a newer one.
class CounterUnwrapper {
 public:
  explicit CounterUnwrapper(unsigned bits);

  // The unwrapped value of raw (only the low `bits` bits are used).
  int64_t unwrap(uint64_t raw);
  // Forward step of the last unwrap() relative to the previous reference (0 for the first
  // value; negative for a backward step).
  int64_t last_step() const { return last_step_; }
  bool started() const { return started_; }
  void reset() { started_ = false; }

 private:
  uint64_t mask_;
  int64_t half_;
  bool started_ = false;
  int64_t reference_ = 0;
  int64_t last_step_ = 0;
};

// Device ticks (unwrapped) to ns at tick_hz, exact in 128-bit integer arithmetic.
TimeNs ticks_to_ns(int64_t ticks, uint64_t tick_hz);

// Samples as an ImuSeries (the channels of its samples, which must all have the same ones, else
// imukit::Error; times from device_time when every sample has one and use_device_time, else
// host_time).
ImuSeries to_series(std::span<const Sample> samples, bool use_device_time = true);

}  // namespace imukit::drivers
