// MockDevice: an imukit-protocol device on the host. It runs firmware_proto's DeviceModel (the
// same state machine a firmware runs) behind a Hal whose sensors read a core SignalSource through
// a core HardwareModel (ImuErrorGenerator), and whose link can drop frames, flip bits, delay,
// jitter, stall and disconnect. To the host it is a ByteTransport, so the ImukitCodec and the
// DeviceReader talk to it exactly as to a serial device.
//
// Clocks: the true (source) time t starts at 0 when the mock is made. The device clock runs at
// tick_hz * (1 + drift_ppm 1e-6) and wraps at 2^32 ticks. Host time is the mock's epoch plus t.
// In virtual time each read() advances t in steps of 1 ms until bytes are due (or the read's
// timeout has passed in virtual time), so a test runs deterministically and as fast as the CPU
// allows; in real time read() sleeps until bytes are due.
//
// Link: every frame the device writes is dropped whole with probability `drop`; each byte that
// survives has one random bit flipped with probability `flip`; it reaches the host at
// send time + latency + U(0, jitter) (never before the previous frame: a serial link keeps order).
// Bytes the host writes reach the device after the same latency and jitter (a symmetric link,
// which is what a time-sync ping assumes when it halves the round trip).
// A stall holds everything sent in [stall_at, stall_at + stall) back until the stall ends. After
// disconnect_after samples the device is gone: read() reports the end of the stream.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <optional>

#include "imukit/core/hardware_model.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/signal_source.hpp"
#include "imukit/drivers/transport.hpp"
#include "imukit/firmware_proto/device_model.hpp"

namespace imukit::drivers {

struct MockOptions {
  double rate_hz = 400.0;
  uint64_t seed = 1;
  HardwareModel hardware;         // ideal by default
  double drop = 0.0;              // frame drop probability
  double flip = 0.0;              // per-byte probability of one flipped bit
  double drift_ppm = 0.0;         // device clock error
  double latency_us = 0.0;        // constant link delay
  double jitter_us = 0.0;         // extra uniform delay in [0, jitter]
  double stall_ms = 0.0;          // one stall of this length...
  double stall_at_s = 1.0;        // ...starting here (true time)
  uint64_t disconnect_after = 0;  // samples; 0 = never
  bool virtual_time = true;
  // A device that cannot be commanded (URI commands=false: the codec only decodes): at power-on
  // it sends its DeviceInfo, then streams in its default configuration (rate_hz, every sensor,
  // 8 samples per block), as firmware that starts by itself does.
  bool streams_from_power_on = false;
  TimeNs epoch = 1'700'000'000'000'000'000;  // host time at t = 0 in virtual time
  uint32_t tick_hz = 1'000'000;
  double accel_range_g = 16.0;
  double gyro_range_dps = 2000.0;
};

// What a mock drew for the errors that stay fixed over a run (its "power-on" state): the
// constant bias of each triad (turn-on bias, plus hard iron for a magnetometer). Lets a test or
// `imukit demo` compare what characterize and calibrate estimate with the truth.
struct MockTruth {
  bool drawn = false;  // false until the device was configured (or produced its first sample)
  Eigen::Vector3d accelerometer_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyroscope_bias = Eigen::Vector3d::Zero();
};

class MockDevice : public ByteTransport, private proto::Hal {
 public:
  MockDevice(std::shared_ptr<SignalSource> source, MockOptions options);
  ~MockDevice() override;

  ReadResult read(std::span<uint8_t> buf, int timeout_ms) override;
  void write(std::span<const uint8_t> bytes) override;
  std::string describe() const override;
  TimeNs now() const override;
  bool virtual_time() const override { return opt_.virtual_time; }

  const proto::DeviceModel& model() const { return *model_; }
  const proto::DeviceInfo& info() const { return info_; }
  // What the link did (for tests that check every loss was counted).
  uint64_t frames_dropped() const { return frames_dropped_; }
  uint64_t samples_in_dropped_frames() const { return samples_in_dropped_; }
  uint64_t bytes_flipped() const { return bytes_flipped_; }
  uint64_t samples_made() const { return samples_made_; }
  // True time (ns since the mock started).
  TimeNs true_time() const { return t_; }
  const MockOptions& options() const { return opt_; }
  // Updated each time the device draws its errors (at every configuration); the handle stays
  // valid after the device is gone, so a caller can keep it while a session owns the device.
  std::shared_ptr<const MockTruth> truth() const { return truth_; }

 private:
  // proto::Hal
  uint32_t ticks() override;
  bool read_sensors(uint32_t tick, uint8_t channels, proto::SensorSample& out) override;
  bool write(const uint8_t* data, std::size_t n) override;
  bool apply_configuration(const proto::Configure& config) override;
  bool store_calibration(const uint8_t* blob, std::size_t n) override;
  std::size_t load_calibration(uint8_t* out, std::size_t capacity) override;

  void power_on_stream();
  void advance_to(TimeNs t);
  void draw_errors(double rate_hz);
  TimeNs device_ticks_at(TimeNs t) const;

  std::shared_ptr<SignalSource> source_;
  MockOptions opt_;
  Rng link_rng_;
  Rng sensor_rng_;
  proto::DeviceInfo info_;
  std::unique_ptr<proto::DeviceModel> model_;
  std::optional<ImuErrorGenerator> errors_;
  std::shared_ptr<MockTruth> truth_ = std::make_shared<MockTruth>();
  double configured_rate_hz_ = 0;
  TimeNs t_ = 0;           // true time now
  TimeNs real_start_ = 0;  // host clock at t = 0 (real time)
  struct Pending {
    TimeNs due;  // true time the bytes reach the host
    std::vector<uint8_t> bytes;
  };
  std::deque<Pending> pending_;  // device -> host
  std::deque<Pending> inbound_;  // host -> device
  Rng uplink_rng_;
  TimeNs last_due_ = 0;
  uint64_t frames_dropped_ = 0;
  uint64_t samples_in_dropped_ = 0;
  uint64_t bytes_flipped_ = 0;
  uint64_t samples_made_ = 0;
  bool gone_ = false;
  bool flushed_after_gone_ = false;
  std::vector<uint8_t> calibration_;
  Eigen::Matrix3Xd f_, w_;
};

// Mock URIs: `mock:static` and `mock:poses` with the keys of docs/devices.md (rate, seed,
// profile, drop, flip, drift_ppm, latency_us, jitter_us, stall_ms, stall_at_s,
// disconnect_after, clock=virtual|real, quat=w,x,y,z for static, hold_s/move_s/poses for
// poses, gravity; and the codec's commands=false, which makes it stream from power-on). Throws
// imukit::Error naming the key for a bad value.
std::unique_ptr<MockDevice> make_mock_device(const std::string& kind,
                                             const std::map<std::string, std::string>& keys);

}  // namespace imukit::drivers
