#include "imukit/firmware_proto/messages.hpp"

#include <string.h>

#include "imukit/firmware_proto/crc32c.hpp"

namespace imukit::proto {
namespace {

// Finite (not NaN, not infinite) by its bit pattern, so no <math.h> is needed.
bool finite(float v) {
  uint32_t bits;
  memcpy(&bits, &v, 4);
  return (bits & 0x7F800000u) != 0x7F800000u;
}

bool valid_text(const Text& t) { return t.size <= kMaxTextSize; }

bool valid_sensor(const SensorInfo& s) {
  if (static_cast<uint8_t>(s.kind) > static_cast<uint8_t>(SensorKind::kTemperature)) return false;
  if (s.axes != axes_of(s.kind) || !finite(s.offset)) return false;
  if (s.range_count < 1 || s.range_count > kMaxRanges) return false;
  for (uint8_t i = 0; i < s.range_count; ++i) {
    const SensorRange& r = s.ranges[i];
    if (!finite(r.full_scale) || !finite(r.scale) || !(r.full_scale > 0) || !(r.scale > 0)) {
      return false;
    }
  }
  return true;
}

bool valid_device_info(const DeviceInfo& m) {
  if (!valid_text(m.vendor) || !valid_text(m.model) || !valid_text(m.serial)) return false;
  if (m.tick_hz == 0 || m.rate_count < 1 || m.rate_count > kMaxRates) return false;
  // Each rate fits the clock, as Configure requires (a 1 kHz tick listing 2 kHz was a DeviceInfo
  // whose own rate the device then refused; review, 2026-11-27).
  for (uint8_t i = 0; i < m.rate_count; ++i) {
    if (!m.rate_fits_clock(m.rates_mhz[i])) return false;
  }
  if (m.sensor_count < 1 || m.sensor_count > kMaxSensors) return false;
  uint8_t seen = 0;
  for (uint8_t i = 0; i < m.sensor_count; ++i) {
    if (!valid_sensor(m.sensors[i])) return false;
    const uint8_t bit = channel_bit(m.sensors[i].kind);
    if (seen & bit) return false;  // one sensor per kind: the sample block has one slot each
    seen |= bit;
  }
  return true;
}

bool valid_block(const SampleBlock& m) {
  return m.count >= 1 && m.count <= kMaxBlockSamples && m.channels != 0 &&
         (m.channels & ~kChannelMaskAll) == 0;
}

void write_text(ByteWriter& w, const Text& t) {
  w.u8(t.size);
  w.bytes(t.chars, t.size);
}

bool read_text(ByteReader& r, Text& t) {
  t.size = r.u8();
  if (t.size > kMaxTextSize) return false;
  r.bytes(t.chars, t.size);
  return true;
}

// Status of a parse whose fields were all read: kBadLength for a short or long payload.
ParseStatus finish(const ByteReader& r) {
  return r.done() ? ParseStatus::kOk : ParseStatus::kBadLength;
}

ParseStatus read_empty(size_t n) { return n == 0 ? ParseStatus::kOk : ParseStatus::kBadLength; }

}  // namespace

void Text::set(const char* s) {
  size_t n = strlen(s);
  if (n > kMaxTextSize) n = kMaxTextSize;
  memcpy(chars, s, n);
  size = static_cast<uint8_t>(n);
}

bool operator==(const Text& a, const Text& b) {
  return a.size == b.size && a.size <= kMaxTextSize && memcmp(a.chars, b.chars, a.size) == 0;
}

const SensorInfo* DeviceInfo::find(SensorKind kind) const {
  for (uint8_t i = 0; i < sensor_count && i < kMaxSensors; ++i) {
    if (sensors[i].kind == kind) return &sensors[i];
  }
  return nullptr;
}

uint8_t DeviceInfo::channels() const {
  uint8_t mask = 0;
  for (uint8_t i = 0; i < sensor_count && i < kMaxSensors; ++i) {
    if (static_cast<uint8_t>(sensors[i].kind) <= 3) mask |= channel_bit(sensors[i].kind);
  }
  return mask;
}

uint32_t CalibrationBlob::compute_crc() const {
  const uint8_t head[3] = {format_version, static_cast<uint8_t>(size),
                           static_cast<uint8_t>(size >> 8)};
  const size_t n = size <= kMaxCalibrationData ? size : kMaxCalibrationData;
  return crc32c_extend(crc32c(head, 3), data, n);
}

// ---- writers ----------------------------------------------------------------------------------

bool write_payload(ByteWriter& w, const GetDeviceInfo&) { return w.ok(); }
bool write_payload(ByteWriter& w, const Start&) { return w.ok(); }
bool write_payload(ByteWriter& w, const Stop&) { return w.ok(); }
bool write_payload(ByteWriter& w, const CalibrationRead&) { return w.ok(); }

bool write_payload(ByteWriter& w, const DeviceInfo& m) {
  if (!valid_device_info(m)) {
    w.fail();
    return false;
  }
  write_text(w, m.vendor);
  write_text(w, m.model);
  write_text(w, m.serial);
  w.u8(m.firmware_major);
  w.u8(m.firmware_minor);
  w.u16(m.firmware_patch);
  w.u32(m.tick_hz);
  w.u8(m.rate_count);
  for (uint8_t i = 0; i < m.rate_count; ++i) w.u32(m.rates_mhz[i]);
  w.u8(m.sensor_count);
  for (uint8_t i = 0; i < m.sensor_count; ++i) {
    const SensorInfo& s = m.sensors[i];
    w.u8(static_cast<uint8_t>(s.kind));
    w.u8(s.axes);
    w.f32(s.offset);
    w.u8(s.range_count);
    for (uint8_t k = 0; k < s.range_count; ++k) {
      w.f32(s.ranges[k].full_scale);
      w.f32(s.ranges[k].scale);
    }
  }
  return w.ok();
}

bool write_payload(ByteWriter& w, const Configure& m) {
  if ((m.channels & ~kChannelMaskAll) != 0) {
    w.fail();
    return false;
  }
  w.u32(m.rate_mhz);
  w.u8(m.channels);
  for (uint8_t index : m.range_index) w.u8(index);
  w.u8(m.samples_per_block);
  return w.ok();
}

bool write_payload(ByteWriter& w, const Ping& m) {
  w.u64(m.host_time);
  return w.ok();
}

bool write_payload(ByteWriter& w, const Pong& m) {
  w.u64(m.host_time);
  w.u32(m.rx_tick);
  w.u32(m.tx_tick);
  return w.ok();
}

bool write_blob(ByteWriter& w, const CalibrationBlob& b) {
  if (b.format_version == 0 || b.size > kMaxCalibrationData) {
    w.fail();
    return false;
  }
  w.u8(b.format_version);
  w.u16(b.size);
  w.bytes(b.data, b.size);
  w.u32(b.crc);  // as stored: a corrupt blob stays detectably corrupt
  return w.ok();
}

bool write_payload(ByteWriter& w, const CalibrationWrite& m) { return write_blob(w, m.blob); }
bool write_payload(ByteWriter& w, const CalibrationData& m) { return write_blob(w, m.blob); }

bool write_payload(ByteWriter& w, const Ack& m) {
  w.u8(m.request_type);
  w.u16(m.request_sequence);
  return w.ok();
}

bool write_payload(ByteWriter& w, const Nack& m) {
  w.u8(m.request_type);
  w.u16(m.request_sequence);
  w.u8(static_cast<uint8_t>(m.code));
  return w.ok();
}

bool write_payload(ByteWriter& w, const Log& m) {
  if (static_cast<uint8_t>(m.level) > static_cast<uint8_t>(LogLevel::kError) ||
      m.size > kMaxLogText) {
    w.fail();
    return false;
  }
  w.u8(static_cast<uint8_t>(m.level));
  w.u32(m.tick);
  w.u8(m.size);
  w.bytes(m.text, m.size);
  return w.ok();
}

bool write_payload(ByteWriter& w, const SampleBlock& m) {
  if (!valid_block(m)) {
    w.fail();
    return false;
  }
  w.u32(m.sample_index);
  w.u32(m.first_tick);
  w.u8(m.count);
  w.u8(m.channels);
  for (uint8_t i = 0; i < m.count; ++i) {
    if (m.channels & kChannelAccel) {
      for (int16_t v : m.accel[i]) w.i16(v);
    }
    if (m.channels & kChannelGyro) {
      for (int16_t v : m.gyro[i]) w.i16(v);
    }
    if (m.channels & kChannelMag) {
      for (int16_t v : m.mag[i]) w.i16(v);
    }
    if (m.channels & kChannelTemperature) w.i16(m.temperature[i]);
  }
  return w.ok();
}

// ---- parsers ----------------------------------------------------------------------------------

ParseStatus read_payload(const uint8_t*, size_t n, GetDeviceInfo&) { return read_empty(n); }
ParseStatus read_payload(const uint8_t*, size_t n, Start&) { return read_empty(n); }
ParseStatus read_payload(const uint8_t*, size_t n, Stop&) { return read_empty(n); }
ParseStatus read_payload(const uint8_t*, size_t n, CalibrationRead&) { return read_empty(n); }

ParseStatus read_payload(const uint8_t* p, size_t n, DeviceInfo& m) {
  ByteReader r(p, n);
  if (!read_text(r, m.vendor) || !read_text(r, m.model) || !read_text(r, m.serial)) {
    return r.ok() ? ParseStatus::kBadValue : ParseStatus::kBadLength;
  }
  m.firmware_major = r.u8();
  m.firmware_minor = r.u8();
  m.firmware_patch = r.u16();
  m.tick_hz = r.u32();
  m.rate_count = r.u8();
  if (!r.ok()) return ParseStatus::kBadLength;
  if (m.rate_count < 1 || m.rate_count > kMaxRates) return ParseStatus::kBadValue;
  for (uint8_t i = 0; i < m.rate_count; ++i) m.rates_mhz[i] = r.u32();
  m.sensor_count = r.u8();
  if (!r.ok()) return ParseStatus::kBadLength;
  if (m.sensor_count < 1 || m.sensor_count > kMaxSensors) return ParseStatus::kBadValue;
  for (uint8_t i = 0; i < m.sensor_count; ++i) {
    SensorInfo& s = m.sensors[i];
    const uint8_t kind = r.u8();
    if (kind > static_cast<uint8_t>(SensorKind::kTemperature)) {
      return r.ok() ? ParseStatus::kBadValue : ParseStatus::kBadLength;
    }
    s.kind = static_cast<SensorKind>(kind);
    s.axes = r.u8();
    s.offset = r.f32();
    s.range_count = r.u8();
    if (!r.ok()) return ParseStatus::kBadLength;
    if (s.range_count < 1 || s.range_count > kMaxRanges) return ParseStatus::kBadValue;
    for (uint8_t k = 0; k < s.range_count; ++k) {
      s.ranges[k].full_scale = r.f32();
      s.ranges[k].scale = r.f32();
    }
  }
  if (!r.done()) return ParseStatus::kBadLength;
  return valid_device_info(m) ? ParseStatus::kOk : ParseStatus::kBadValue;
}

ParseStatus read_payload(const uint8_t* p, size_t n, Configure& m) {
  ByteReader r(p, n);
  m.rate_mhz = r.u32();
  m.channels = r.u8();
  for (uint8_t& index : m.range_index) index = r.u8();
  m.samples_per_block = r.u8();
  if (!r.done()) return ParseStatus::kBadLength;
  if ((m.channels & ~kChannelMaskAll) != 0) return ParseStatus::kBadValue;
  return ParseStatus::kOk;
}

ParseStatus read_payload(const uint8_t* p, size_t n, Ping& m) {
  ByteReader r(p, n);
  m.host_time = r.u64();
  return finish(r);
}

ParseStatus read_payload(const uint8_t* p, size_t n, Pong& m) {
  ByteReader r(p, n);
  m.host_time = r.u64();
  m.rx_tick = r.u32();
  m.tx_tick = r.u32();
  return finish(r);
}

ParseStatus check_blob(const uint8_t* p, size_t n) {
  if (n < 3) return ParseStatus::kBadLength;
  const size_t size = static_cast<size_t>(p[1] | p[2] << 8);
  // The length first: a payload that is not 3 + size + 4 bytes is malformed whatever its size
  // field says (review of 2026-11-27: a 7-byte payload saying 768 was answered as invalid data).
  if (n != 3 + size + 4) return ParseStatus::kBadLength;
  if (size > kMaxCalibrationData) return ParseStatus::kBadValue;
  if (p[0] == 0) return ParseStatus::kBadValue;
  const uint32_t stored = static_cast<uint32_t>(p[n - 4]) | static_cast<uint32_t>(p[n - 3]) << 8 |
                          static_cast<uint32_t>(p[n - 2]) << 16 |
                          static_cast<uint32_t>(p[n - 1]) << 24;
  return crc32c(p, n - 4) == stored ? ParseStatus::kOk : ParseStatus::kBadChecksum;
}

ParseStatus read_blob(const uint8_t* p, size_t n, CalibrationBlob& b) {
  ByteReader r(p, n);
  b.format_version = r.u8();
  b.size = r.u16();
  if (!r.ok()) return ParseStatus::kBadLength;
  if (n != 3 + size_t{b.size} + 4)
    return ParseStatus::kBadLength;  // the length first, as check_blob
  if (b.size > kMaxCalibrationData) return ParseStatus::kBadValue;
  r.bytes(b.data, b.size);
  b.crc = r.u32();
  if (!r.done()) return ParseStatus::kBadLength;
  if (b.format_version == 0) return ParseStatus::kBadValue;
  return b.crc == b.compute_crc() ? ParseStatus::kOk : ParseStatus::kBadChecksum;
}

ParseStatus read_payload(const uint8_t* p, size_t n, CalibrationWrite& m) {
  return read_blob(p, n, m.blob);
}
ParseStatus read_payload(const uint8_t* p, size_t n, CalibrationData& m) {
  return read_blob(p, n, m.blob);
}

ParseStatus read_payload(const uint8_t* p, size_t n, Ack& m) {
  ByteReader r(p, n);
  m.request_type = r.u8();
  m.request_sequence = r.u16();
  return finish(r);
}

ParseStatus read_payload(const uint8_t* p, size_t n, Nack& m) {
  ByteReader r(p, n);
  m.request_type = r.u8();
  m.request_sequence = r.u16();
  const uint8_t code = r.u8();
  if (!r.done()) return ParseStatus::kBadLength;
  if (code < static_cast<uint8_t>(NackCode::kUnknownMessage) ||
      code > static_cast<uint8_t>(NackCode::kStorageError)) {
    return ParseStatus::kBadValue;
  }
  m.code = static_cast<NackCode>(code);
  return ParseStatus::kOk;
}

ParseStatus read_payload(const uint8_t* p, size_t n, Log& m) {
  ByteReader r(p, n);
  const uint8_t level = r.u8();
  m.tick = r.u32();
  m.size = r.u8();
  if (!r.ok()) return ParseStatus::kBadLength;
  if (level > static_cast<uint8_t>(LogLevel::kError) || m.size > kMaxLogText) {
    return ParseStatus::kBadValue;
  }
  m.level = static_cast<LogLevel>(level);
  r.bytes(m.text, m.size);
  return finish(r);
}

ParseStatus read_payload(const uint8_t* p, size_t n, SampleBlock& m) {
  if (n < kSampleBlockHeaderSize) return ParseStatus::kBadLength;
  ByteReader r(p, kSampleBlockHeaderSize);
  m.sample_index = r.u32();
  m.first_tick = r.u32();
  m.count = r.u8();
  m.channels = r.u8();
  if (!valid_block(m)) return ParseStatus::kBadValue;
  // Bound the sample data once, then read it without per-field checks (the hot path on a host).
  const size_t stride = sample_size(m.channels);
  if (n - kSampleBlockHeaderSize != stride * m.count) return ParseStatus::kBadLength;
  const uint8_t* s = p + kSampleBlockHeaderSize;
  auto i16 = [](const uint8_t* q) { return static_cast<int16_t>(q[0] | q[1] << 8); };
  for (uint8_t i = 0; i < m.count; ++i) {
    if (m.channels & kChannelAccel) {
      for (int a = 0; a < 3; ++a, s += 2) m.accel[i][a] = i16(s);
    }
    if (m.channels & kChannelGyro) {
      for (int a = 0; a < 3; ++a, s += 2) m.gyro[i][a] = i16(s);
    }
    if (m.channels & kChannelMag) {
      for (int a = 0; a < 3; ++a, s += 2) m.mag[i][a] = i16(s);
    }
    if (m.channels & kChannelTemperature) {
      m.temperature[i] = i16(s);
      s += 2;
    }
  }
  return ParseStatus::kOk;
}

}  // namespace imukit::proto
