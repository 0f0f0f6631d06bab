#include "proto_test_util.hpp"

#include <gtest/gtest.h>
#include <algorithm>

#include <cstring>

namespace imukit::proto::test {

Bytes from_hex(const std::string& hex) {
  Bytes out;
  int nibbles = 0;
  uint8_t value = 0;
  for (char c : hex) {
    if (c == ' ' || c == '\n') continue;
    int v;
    if (c >= '0' && c <= '9') {
      v = c - '0';
    } else if (c >= 'a' && c <= 'f') {
      v = c - 'a' + 10;
    } else if (c >= 'A' && c <= 'F') {
      v = c - 'A' + 10;
    } else {
      ADD_FAILURE() << "bad hex character '" << c << "'";
      return {};
    }
    value = static_cast<uint8_t>(value << 4 | v);
    if (++nibbles % 2 == 0) out.push_back(value);
  }
  EXPECT_EQ(nibbles % 2, 0) << "odd number of hex digits";
  return out;
}

std::string to_hex(const uint8_t* data, size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (size_t i = 0; i < n; ++i) {
    if (i) s += ' ';
    s += digits[data[i] >> 4];
    s += digits[data[i] & 15];
  }
  return s;
}

namespace {

void random_text(TestRng& rng, Text& t) {
  t.size = static_cast<uint8_t>(rng.below(kMaxTextSize + 1));
  for (uint8_t i = 0; i < t.size; ++i) t.chars[i] = static_cast<char>(0x20 + rng.below(95));
}

float random_positive(TestRng& rng) {
  return static_cast<float>(1 + rng.below(1 << 20)) / static_cast<float>(1 << (rng.below(24)));
}

bool same_floats(float a, float b) { return std::memcmp(&a, &b, 4) == 0; }

}  // namespace

DeviceInfo random_device_info(TestRng& rng) {
  DeviceInfo m;
  random_text(rng, m.vendor);
  random_text(rng, m.model);
  random_text(rng, m.serial);
  m.firmware_major = rng.byte();
  m.firmware_minor = rng.byte();
  m.firmware_patch = static_cast<uint16_t>(rng.bits());
  m.tick_hz = static_cast<uint32_t>(1 + rng.below(0xFFFFFFFFu));
  m.rate_count = static_cast<uint8_t>(1 + rng.below(kMaxRates));
  // Rates whose sample period is 1 to 2^30 ticks (DeviceInfo::rate_fits_clock).
  const uint64_t ticks_scaled = uint64_t{m.tick_hz} * 1000u;
  const uint64_t fastest = std::min<uint64_t>(ticks_scaled, 0xFFFFFFFFu);
  const uint64_t slowest = std::max<uint64_t>(1, (ticks_scaled + (uint64_t{1} << 30) - 1) >> 30);
  for (uint8_t i = 0; i < m.rate_count; ++i) {
    m.rates_mhz[i] = static_cast<uint32_t>(slowest + rng.below(fastest - slowest + 1));
  }
  // A random non-empty subset of kinds, in random order.
  uint8_t kinds[4] = {0, 1, 2, 3};
  for (int i = 3; i > 0; --i) std::swap(kinds[i], kinds[rng.below(i + 1)]);
  m.sensor_count = static_cast<uint8_t>(1 + rng.below(kMaxSensors));
  for (uint8_t i = 0; i < m.sensor_count; ++i) {
    SensorInfo& s = m.sensors[i];
    s.kind = static_cast<SensorKind>(kinds[i]);
    s.axes = axes_of(s.kind);
    s.offset = rng.below(2) ? 0.0f : -random_positive(rng);
    s.range_count = static_cast<uint8_t>(1 + rng.below(kMaxRanges));
    for (uint8_t k = 0; k < s.range_count; ++k) {
      s.ranges[k].full_scale = random_positive(rng);
      s.ranges[k].scale = random_positive(rng);
    }
  }
  return m;
}

Configure random_configure(TestRng& rng) {
  Configure m;
  m.rate_mhz = static_cast<uint32_t>(rng.bits());
  m.channels = static_cast<uint8_t>(rng.below(16));
  for (uint8_t& r : m.range_index) r = rng.byte();
  m.samples_per_block = rng.byte();
  return m;
}

Ping random_ping(TestRng& rng) {
  Ping m;
  m.host_time = rng.bits();
  return m;
}

Pong random_pong(TestRng& rng) {
  Pong m;
  m.host_time = rng.bits();
  m.rx_tick = static_cast<uint32_t>(rng.bits());
  m.tx_tick = static_cast<uint32_t>(rng.bits());
  return m;
}

CalibrationBlob random_blob(TestRng& rng) {
  CalibrationBlob b;
  b.format_version = static_cast<uint8_t>(1 + rng.below(255));
  b.size = static_cast<uint16_t>(rng.below(kMaxCalibrationData + 1));
  for (uint16_t i = 0; i < b.size; ++i) b.data[i] = rng.byte();
  b.seal();
  return b;
}

Ack random_ack(TestRng& rng) {
  Ack m;
  m.request_type = rng.byte();
  m.request_sequence = static_cast<uint16_t>(rng.bits());
  return m;
}

Nack random_nack(TestRng& rng) {
  Nack m;
  m.request_type = rng.byte();
  m.request_sequence = static_cast<uint16_t>(rng.bits());
  m.code = static_cast<NackCode>(1 + rng.below(12));
  return m;
}

Log random_log(TestRng& rng) {
  Log m;
  m.level = static_cast<LogLevel>(rng.below(4));
  m.tick = static_cast<uint32_t>(rng.bits());
  m.size = static_cast<uint8_t>(rng.below(kMaxLogText + 1));
  for (uint8_t i = 0; i < m.size; ++i) m.text[i] = static_cast<char>(rng.byte());
  return m;
}

SampleBlock random_sample_block(TestRng& rng, uint8_t count, uint8_t channels) {
  SampleBlock m;
  m.sample_index = static_cast<uint32_t>(rng.bits());
  m.first_tick = static_cast<uint32_t>(rng.bits());
  m.count = count;
  m.channels = channels;
  for (uint8_t i = 0; i < count; ++i) {
    for (int a = 0; a < 3; ++a) {
      m.accel[i][a] = rng.imu_value();
      m.gyro[i][a] = rng.imu_value();
      m.mag[i][a] = rng.imu_value();
    }
    m.temperature[i] = rng.imu_value();
  }
  return m;
}

bool same(const DeviceInfo& a, const DeviceInfo& b) {
  if (!(a.vendor == b.vendor) || !(a.model == b.model) || !(a.serial == b.serial)) return false;
  if (a.firmware_major != b.firmware_major || a.firmware_minor != b.firmware_minor ||
      a.firmware_patch != b.firmware_patch || a.tick_hz != b.tick_hz ||
      a.rate_count != b.rate_count || a.sensor_count != b.sensor_count) {
    return false;
  }
  for (uint8_t i = 0; i < a.rate_count; ++i) {
    if (a.rates_mhz[i] != b.rates_mhz[i]) return false;
  }
  for (uint8_t i = 0; i < a.sensor_count; ++i) {
    const SensorInfo& x = a.sensors[i];
    const SensorInfo& y = b.sensors[i];
    if (x.kind != y.kind || x.axes != y.axes || !same_floats(x.offset, y.offset) ||
        x.range_count != y.range_count) {
      return false;
    }
    for (uint8_t k = 0; k < x.range_count; ++k) {
      if (!same_floats(x.ranges[k].full_scale, y.ranges[k].full_scale) ||
          !same_floats(x.ranges[k].scale, y.ranges[k].scale)) {
        return false;
      }
    }
  }
  return true;
}

bool same(const Configure& a, const Configure& b) {
  return a.rate_mhz == b.rate_mhz && a.channels == b.channels &&
         std::memcmp(a.range_index, b.range_index, sizeof a.range_index) == 0 &&
         a.samples_per_block == b.samples_per_block;
}

bool same(const Ping& a, const Ping& b) { return a.host_time == b.host_time; }

bool same(const Pong& a, const Pong& b) {
  return a.host_time == b.host_time && a.rx_tick == b.rx_tick && a.tx_tick == b.tx_tick;
}

bool same(const CalibrationBlob& a, const CalibrationBlob& b) {
  return a.format_version == b.format_version && a.size == b.size && a.crc == b.crc &&
         std::memcmp(a.data, b.data, a.size) == 0;
}

bool same(const Ack& a, const Ack& b) {
  return a.request_type == b.request_type && a.request_sequence == b.request_sequence;
}

bool same(const Nack& a, const Nack& b) {
  return a.request_type == b.request_type && a.request_sequence == b.request_sequence &&
         a.code == b.code;
}

bool same(const Log& a, const Log& b) {
  return a.level == b.level && a.tick == b.tick && a.size == b.size &&
         std::memcmp(a.text, b.text, a.size) == 0;
}

bool same(const SampleBlock& a, const SampleBlock& b) {
  if (a.sample_index != b.sample_index || a.first_tick != b.first_tick || a.count != b.count ||
      a.channels != b.channels) {
    return false;
  }
  for (uint8_t i = 0; i < a.count; ++i) {
    if ((a.channels & kChannelAccel) && std::memcmp(a.accel[i], b.accel[i], 6) != 0) return false;
    if ((a.channels & kChannelGyro) && std::memcmp(a.gyro[i], b.gyro[i], 6) != 0) return false;
    if ((a.channels & kChannelMag) && std::memcmp(a.mag[i], b.mag[i], 6) != 0) return false;
    if ((a.channels & kChannelTemperature) && a.temperature[i] != b.temperature[i]) return false;
  }
  return true;
}

std::vector<OwnedFrame> feed_chunked(FrameDecoder& decoder, const Bytes& data, TestRng& rng,
                                     size_t max_chunk) {
  std::vector<OwnedFrame> frames;
  size_t pos = 0;
  while (pos < data.size()) {
    const size_t chunk = std::min<size_t>(data.size() - pos, 1 + rng.below(max_chunk));
    decoder.feed(data.data() + pos, chunk, [&](const Frame& f) {
      frames.push_back({f.type, f.sequence, Bytes(f.payload, f.payload + f.payload_size)});
    });
    pos += chunk;
  }
  return frames;
}

Bytes encode_raw(uint8_t type, uint16_t sequence, const Bytes& payload) {
  Bytes out(kMaxFrameSize);
  const size_t n =
      encode_frame(type, sequence, payload.data(), payload.size(), out.data(), out.size());
  out.resize(n);
  return out;
}

}  // namespace imukit::proto::test
