#include "imukit/firmware_proto/device_model.hpp"

#include <string.h>

namespace imukit::proto {

DeviceModel::DeviceModel(Hal& hal, const DeviceInfo& info) : hal_(hal), info_(info) {
  ByteWriter probe(tx_, sizeof tx_);
  info_valid_ = write_payload(probe, info_);
  config_.rate_mhz = info_.rate_count > 0 ? info_.rates_mhz[0] : 0;
  config_.channels = info_.channels();
  config_.samples_per_block = 8;
}

template <class M>
bool DeviceModel::send(const M& m) {
  const size_t n = encode_message(m, tx_sequence_, tx_, sizeof tx_);
  return n > 0 && transmit(n);  // n == 0: m invalid, nothing sent, no sequence number used
}

bool DeviceModel::send_raw(MessageType type, const uint8_t* payload, size_t size) {
  const size_t n =
      encode_frame(static_cast<uint8_t>(type), tx_sequence_, payload, size, tx_, sizeof tx_);
  return n > 0 && transmit(n);
}

bool DeviceModel::transmit(size_t n) {
  ++tx_sequence_;  // used even if the link refuses, so the host counts the loss
  if (!hal_.write(tx_, n)) {
    ++stats_.frames_dropped;
    return false;
  }
  return true;
}

void DeviceModel::ack(const Frame& frame) {
  Ack a;
  a.request_type = frame.type;
  a.request_sequence = frame.sequence;
  send(a);
}

void DeviceModel::nack(const Frame& frame, NackCode code) {
  Nack n;
  n.request_type = frame.type;
  n.request_sequence = frame.sequence;
  n.code = code;
  ++stats_.nacks_sent;
  send(n);
}

void DeviceModel::on_bytes(const uint8_t* data, size_t n, uint32_t rx_tick) {
  rx_.feed(data, n, [&](const Frame& frame) { handle(frame, rx_tick); });
}

void DeviceModel::on_bytes(const uint8_t* data, size_t n) {
  rx_.feed(data, n, [&](const Frame& frame) { handle(frame, hal_.ticks()); });
}

void DeviceModel::handle(const Frame& frame, uint32_t rx_tick) {
  ++stats_.requests;
  switch (static_cast<MessageType>(frame.type)) {
    case MessageType::kGetDeviceInfo: {
      GetDeviceInfo m;
      if (parse_message(frame, m) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
      if (!send(info_)) {
        if (!info_valid_) nack(frame, NackCode::kHardwareError);
      }
      return;
    }
    case MessageType::kConfigure:
      return handle_configure(frame);
    case MessageType::kStart:
      return handle_start(frame);
    case MessageType::kStop:
      return handle_stop(frame);
    case MessageType::kPing: {
      Ping ping;
      if (parse_message(frame, ping) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
      Pong pong;
      pong.host_time = ping.host_time;
      pong.rx_tick = rx_tick;
      pong.tx_tick = hal_.ticks();
      send(pong);
      return;
    }
    case MessageType::kCalibrationRead:
      return handle_calibration_read(frame);
    case MessageType::kCalibrationWrite:
      return handle_calibration_write(frame);
    default:
      // Unknown codes and device-to-host types sent by the host.
      return nack(frame, NackCode::kUnknownMessage);
  }
}

uint8_t DeviceModel::check(const Configure& c) const {
  bool rate_listed = false;
  for (uint8_t i = 0; i < info_.rate_count && i < kMaxRates; ++i) {
    rate_listed = rate_listed || info_.rates_mhz[i] == c.rate_mhz;
  }
  // The sample period must be at least one tick and small enough for the signed tick comparison
  // in poll() (2^30 ticks; `1u << 30` was undefined where int is 16 bits, review 2026-11-27).
  if (!rate_listed || !info_.rate_fits_clock(c.rate_mhz)) {
    return static_cast<uint8_t>(NackCode::kUnsupportedRate);
  }
  if (c.channels == 0) return static_cast<uint8_t>(NackCode::kNoSensorsEnabled);
  if ((c.channels & ~info_.channels()) != 0) {
    return static_cast<uint8_t>(NackCode::kUnsupportedSensor);
  }
  for (uint8_t kind = 0; kind < kMaxSensors; ++kind) {
    if ((c.channels & (1u << kind)) == 0) continue;
    const SensorInfo* s = info_.find(static_cast<SensorKind>(kind));
    if (s == nullptr || c.range_index[kind] >= s->range_count) {
      return static_cast<uint8_t>(NackCode::kUnsupportedRange);
    }
  }
  if (c.samples_per_block < 1 || c.samples_per_block > kMaxBlockSamples) {
    return static_cast<uint8_t>(NackCode::kInvalidBlockSize);
  }
  return 0;
}

bool DeviceModel::apply(const Configure& c) {
  if (!hal_.apply_configuration(c)) return false;
  config_ = c;
  config_applied_ = true;
  const uint64_t ticks_scaled = static_cast<uint64_t>(info_.tick_hz) * 1000u;
  period_ticks_ = static_cast<uint32_t>(ticks_scaled / c.rate_mhz);
  period_rem_ = static_cast<uint32_t>(ticks_scaled % c.rate_mhz);
  return true;
}

void DeviceModel::handle_configure(const Frame& frame) {
  Configure c;
  if (parse_message(frame, c) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
  if (state_ == DeviceState::kStreaming) return nack(frame, NackCode::kBadState);
  if (const uint8_t code = check(c); code != 0) return nack(frame, static_cast<NackCode>(code));
  if (!apply(c)) return nack(frame, NackCode::kHardwareError);
  ack(frame);
}

void DeviceModel::handle_start(const Frame& frame) {
  Start m;
  if (parse_message(frame, m) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
  if (state_ == DeviceState::kStreaming) return nack(frame, NackCode::kBadState);
  if (!config_applied_) {
    // The default configuration has not reached the sensors yet.
    if (const uint8_t code = check(config_); code != 0) {
      return nack(frame, static_cast<NackCode>(code));
    }
    if (!apply(config_)) return nack(frame, NackCode::kHardwareError);
  }
  state_ = DeviceState::kStreaming;
  next_index_ = 0;
  next_tick_ = hal_.ticks();
  rem_acc_ = 0;
  block_.count = 0;
  ack(frame);
}

void DeviceModel::handle_stop(const Frame& frame) {
  Stop m;
  if (parse_message(frame, m) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
  if (state_ == DeviceState::kStreaming) {
    flush_block();  // samples taken so far go out before the Ack, so the Ack ends the stream
    state_ = DeviceState::kIdle;
  }
  ack(frame);
}

void DeviceModel::handle_calibration_write(const Frame& frame) {
  // The payload is the serialised blob: checked, then stored byte for byte.
  const ParseStatus status = check_blob(frame.payload, frame.payload_size);
  if (status == ParseStatus::kBadLength) return nack(frame, NackCode::kMalformed);
  // Writing flash can stall the CPU for milliseconds: not while samples are due.
  if (state_ == DeviceState::kStreaming) return nack(frame, NackCode::kBadState);
  if (status != ParseStatus::kOk) return nack(frame, NackCode::kCalibrationInvalid);
  if (!hal_.store_calibration(frame.payload, frame.payload_size)) {
    return nack(frame, NackCode::kStorageError);
  }
  ack(frame);
}

void DeviceModel::handle_calibration_read(const Frame& frame) {
  CalibrationRead m;
  if (parse_message(frame, m) != ParseStatus::kOk) return nack(frame, NackCode::kMalformed);
  const size_t n = hal_.load_calibration(blob_, sizeof blob_);
  if (n == 0) return nack(frame, NackCode::kNoCalibration);
  // Storage may have rotted: only a blob that still checks out goes back to the host.
  if (n > sizeof blob_ || check_blob(blob_, n) != ParseStatus::kOk) {
    return nack(frame, NackCode::kCalibrationInvalid);
  }
  send_raw(MessageType::kCalibrationData, blob_, n);
}

void DeviceModel::flush_block() {
  if (block_.count == 0) return;
  if (send(block_)) {
    ++stats_.blocks_sent;
    stats_.samples_sent += block_.count;
  } else {
    stats_.samples_dropped += block_.count;
  }
  block_.count = 0;
}

void DeviceModel::take_sample() {
  const uint32_t tick = next_tick_;
  ++stats_.samples_taken;
  SensorSample s;
  if (hal_.read_sensors(tick, config_.channels, s)) {
    if (block_.count == 0) {
      block_.sample_index = next_index_;
      block_.first_tick = tick;
      block_.channels = config_.channels;
    }
    const uint8_t i = block_.count++;
    memcpy(block_.accel[i], s.accel, sizeof s.accel);
    memcpy(block_.gyro[i], s.gyro, sizeof s.gyro);
    memcpy(block_.mag[i], s.mag, sizeof s.mag);
    block_.temperature[i] = s.temperature;
    if (block_.count >= config_.samples_per_block) flush_block();
  } else {
    // A block holds consecutive samples only: close it, the gap shows in the next sample_index.
    ++stats_.sensor_read_errors;
    flush_block();
  }
  ++next_index_;
  // Exact stepping of floor(i * tick_hz * 1000 / rate_mhz): whole ticks plus a remainder.
  // rem_acc_ + period_rem_ can exceed 2^32 for rates above 2^31 mHz (found in review), so the
  // sum is compared and reduced without being formed; period_rem_ < rate_mhz.
  next_tick_ += period_ticks_;
  const uint32_t room = config_.rate_mhz - period_rem_;
  if (rem_acc_ >= room) {
    rem_acc_ -= room;
    ++next_tick_;
  } else {
    rem_acc_ += period_rem_;
  }
}

void DeviceModel::poll() {
  if (state_ != DeviceState::kStreaming) return;
  const uint32_t now = hal_.ticks();
  while (state_ == DeviceState::kStreaming && static_cast<int32_t>(now - next_tick_) >= 0) {
    take_sample();
  }
}

bool DeviceModel::log(LogLevel level, const char* text) {
  Log m;
  m.level = level;
  m.tick = hal_.ticks();
  size_t n = strlen(text);
  if (n > kMaxLogText) n = kMaxLogText;
  memcpy(m.text, text, n);
  m.size = static_cast<uint8_t>(n);
  return send(m);
}

}  // namespace imukit::proto
