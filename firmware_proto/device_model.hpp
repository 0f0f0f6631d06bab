// DeviceModel: the device side of the imukit wire protocol v1, the state machine a firmware runs
// (and the host's mock device runs too), behind a small hardware abstraction (Hal).
//
// States: idle and streaming. Requests from the host (GetDeviceInfo, Configure, Start, Stop, Ping,
// CalibrationRead, CalibrationWrite) are answered as docs/protocol.md specifies: DeviceInfo, Pong,
// CalibrationData, Ack or Nack with a reason. While streaming, poll() takes every sample that is
// due on the device clock and sends them in SampleBlocks of the configured size.
//
// Sample timing: sample i of a streaming session (i counts from 0 at Start) is due at device tick
//   start_tick + floor(i * tick_hz * 1000 / rate_mhz)   (mod 2^32),
// stepped exactly with an integer remainder (no drift, no floating point). A sample whose sensor
// read fails is skipped: the block so far is sent, and the index still advances, so the host sees
// the gap in SampleBlock::sample_index. A frame the link refuses is dropped whole and its sequence
// number is still used, so the host sees that gap too.
//
// Driven step by step: on_bytes() with what the link received, poll() as often as convenient. No
// threads, no heap, no real time: the clock is whatever Hal::ticks() says, so a host test or mock
// can run it against simulated time.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace imukit::proto {

// One reading of every channel (only the enabled channels are used), raw sensor counts.
struct SensorSample {
  int16_t accel[3] = {};
  int16_t gyro[3] = {};
  int16_t mag[3] = {};
  int16_t temperature = 0;
};

// What a firmware port (or the host mock) provides. The destructor is protected and non-virtual:
// the model never deletes a Hal, and a virtual destructor would drag operator delete into
// freestanding builds.
class Hal {
 public:
  // Free-running device clock at DeviceInfo::tick_hz, wrapping at 2^32.
  virtual uint32_t ticks() = 0;
  // Reads the enabled channels for the sample due at `tick`; false if the read failed.
  virtual bool read_sensors(uint32_t tick, uint8_t channels, SensorSample& out) = 0;
  // Sends a whole frame; false if the link cannot take it now (the frame is then dropped).
  virtual bool write(const uint8_t* data, size_t n) = 0;
  // Programs the sensors (rate, ranges, channels); false if the hardware refuses.
  virtual bool apply_configuration(const Configure& config) = 0;
  // Persists a serialised calibration blob (write_blob format); false on a storage failure.
  virtual bool store_calibration(const uint8_t* blob, size_t n) = 0;
  // Copies the stored blob into out; returns its size, or 0 when nothing is stored.
  virtual size_t load_calibration(uint8_t* out, size_t capacity) = 0;

 protected:
  ~Hal() = default;
};

enum class DeviceState : uint8_t { kIdle = 0, kStreaming = 1 };

// Sample accounting: samples_taken == samples_sent + samples_dropped + sensor_read_errors +
// DeviceModel::pending_samples() at all times.
struct DeviceStats {
  uint32_t requests = 0;       // valid frames received from the host
  uint32_t samples_taken = 0;  // sample indices used, all streaming sessions together
  uint32_t nacks_sent = 0;
  uint32_t blocks_sent = 0;
  uint32_t samples_sent = 0;
  uint32_t frames_dropped = 0;      // frames the Hal refused to write
  uint32_t samples_dropped = 0;     // samples in refused sample blocks
  uint32_t sensor_read_errors = 0;  // samples skipped because read_sensors failed
};

class DeviceModel {
 public:
  // info describes the device (copied). After construction the configuration is the default:
  // first listed rate, every sensor on, range index 0 for each, 8 samples per block.
  DeviceModel(Hal& hal, const DeviceInfo& info);

  // Bytes received from the host. rx_tick stamps any Ping completed in them (pass the tick at
  // which the bytes arrived, e.g. from the UART interrupt); without it Hal::ticks() is read when
  // each frame completes.
  void on_bytes(const uint8_t* data, size_t n, uint32_t rx_tick);
  void on_bytes(const uint8_t* data, size_t n);

  // Takes every sample due by Hal::ticks() and sends full blocks. Call at least once per 2^31
  // ticks while streaming.
  void poll();

  // Sends a Log message (text cut at kMaxLogText bytes). False if the link refused it.
  bool log(LogLevel level, const char* text);

  DeviceState state() const { return state_; }
  const Configure& configuration() const { return config_; }
  const DeviceInfo& info() const { return info_; }
  // Index of the next sample to be taken in this streaming session.
  uint32_t next_sample_index() const { return next_index_; }
  // Tick at which that sample is due.
  uint32_t next_sample_tick() const { return next_tick_; }
  // Samples read but not yet sent (the block being filled).
  uint32_t pending_samples() const { return block_.count; }
  const DeviceStats& stats() const { return stats_; }
  const DecoderStats& link_stats() const { return rx_.stats(); }
  bool valid_info() const { return info_valid_; }

 private:
  void handle(const Frame& frame, uint32_t rx_tick);
  void handle_configure(const Frame& frame);
  void handle_start(const Frame& frame);
  void handle_stop(const Frame& frame);
  void handle_calibration_write(const Frame& frame);
  void handle_calibration_read(const Frame& frame);
  // Returns 0 when the configuration is acceptable, else the NackCode value.
  uint8_t check(const Configure& c) const;
  bool apply(const Configure& c);
  void take_sample();
  void flush_block();
  template <class M>
  bool send(const M& m);
  bool send_raw(MessageType type, const uint8_t* payload, size_t size);
  bool transmit(size_t frame_size);  // writes tx_[0, frame_size)
  void ack(const Frame& frame);
  void nack(const Frame& frame, NackCode code);

  Hal& hal_;
  DeviceInfo info_;
  bool info_valid_ = false;
  Configure config_;
  bool config_applied_ = false;
  DeviceState state_ = DeviceState::kIdle;

  FrameDecoder rx_;
  uint16_t tx_sequence_ = 0;
  uint8_t tx_[kMaxFrameSize];
  uint8_t blob_[kMaxCalibrationBlobSize];  // the stored calibration on its way to the host

  SampleBlock block_;
  uint32_t next_index_ = 0;
  uint32_t next_tick_ = 0;
  uint32_t period_ticks_ = 0;  // floor(tick_hz * 1000 / rate_mhz)
  uint32_t period_rem_ = 0;    // (tick_hz * 1000) mod rate_mhz
  uint32_t rem_acc_ = 0;       // accumulated remainder, < rate_mhz
  DeviceStats stats_;
};

}  // namespace imukit::proto
