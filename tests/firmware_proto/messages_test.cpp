#include "imukit/firmware_proto/messages.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <functional>

#include "proto_test_util.hpp"

namespace imukit::proto {
namespace {

using test::Bytes;
using test::encode;
using test::from_hex;
using test::OwnedFrame;
using test::same;
using test::TestRng;
using test::to_hex;

// ---- golden frames ----------------------------------------------------------------------------
// Each expected encoding below was written from the layouts in docs/protocol.md (section "Golden
// frames" lists the same hex) and checked with the independent Python reference printed there
// (bitwise CRC, naive COBS), not with this library.

DeviceInfo golden_device_info() {
  DeviceInfo m;
  m.vendor.set("imukit");
  m.model.set("GF-1");
  m.serial.set("42");
  m.firmware_major = 1;
  m.firmware_minor = 2;
  m.firmware_patch = 3;
  m.tick_hz = 1000000;
  m.rate_count = 2;
  m.rates_mhz[0] = 100000;   // 100 Hz
  m.rates_mhz[1] = 1000000;  // 1 kHz
  m.sensor_count = 3;
  m.sensors[0].kind = SensorKind::kAccelerometer;
  m.sensors[0].axes = 3;
  m.sensors[0].offset = 0.0f;
  m.sensors[0].range_count = 2;
  m.sensors[0].ranges[0] = {16.0f, 0.00048828125f};  // 2^-11 m/s^2 per LSB
  m.sensors[0].ranges[1] = {128.0f, 0.00390625f};    // 2^-8
  m.sensors[1].kind = SensorKind::kGyroscope;
  m.sensors[1].axes = 3;
  m.sensors[1].offset = 0.0f;
  m.sensors[1].range_count = 1;
  m.sensors[1].ranges[0] = {8.0f, 0.000244140625f};  // 2^-12 rad/s per LSB
  m.sensors[2].kind = SensorKind::kTemperature;
  m.sensors[2].axes = 1;
  m.sensors[2].offset = 25.0f;
  m.sensors[2].range_count = 1;
  m.sensors[2].ranges[0] = {128.0f, 0.00390625f};
  return m;
}

Configure golden_configure() {
  Configure m;
  m.rate_mhz = 1000000;
  m.channels = kChannelAccel | kChannelGyro | kChannelTemperature;
  m.range_index[0] = 1;
  m.samples_per_block = 8;
  return m;
}

CalibrationBlob golden_blob() {
  CalibrationBlob b;
  b.format_version = 1;
  b.size = 4;
  const uint8_t data[4] = {0xDE, 0xAD, 0xBE, 0xEF};
  std::memcpy(b.data, data, 4);
  b.seal();
  return b;
}

SampleBlock golden_block_all_channels() {
  SampleBlock m;
  m.sample_index = 64;
  m.first_tick = 640000;
  m.count = 2;
  m.channels = kChannelMaskAll;
  const int16_t accel[2][3] = {{100, -200, 16384}, {101, -199, 16380}};
  const int16_t gyro[2][3] = {{0, 1, -1}, {2, -2, 0}};
  const int16_t mag[2][3] = {{300, -300, 0}, {301, -299, 1}};
  std::memcpy(m.accel, accel, sizeof accel);
  std::memcpy(m.gyro, gyro, sizeof gyro);
  std::memcpy(m.mag, mag, sizeof mag);
  m.temperature[0] = 512;
  m.temperature[1] = 513;
  return m;
}

SampleBlock golden_block_accel_gyro() {
  SampleBlock m;
  m.sample_index = 7;
  m.first_tick = 4294967000u;
  m.count = 1;
  m.channels = kChannelAccel | kChannelGyro;
  m.accel[0][0] = -1;
  m.accel[0][1] = 0;
  m.accel[0][2] = 255;
  m.gyro[0][0] = 256;
  m.gyro[0][1] = -256;
  m.gyro[0][2] = 32767;
  return m;
}

Log golden_log() {
  Log m;
  m.level = LogLevel::kInfo;
  m.tick = 123456;
  m.size = 5;
  std::memcpy(m.text, "hello", 5);
  return m;
}

// Decodes a golden frame with a fresh decoder; exactly one frame must come out.
OwnedFrame decode_one(const Bytes& wire) {
  FrameDecoder decoder;
  std::vector<OwnedFrame> frames;
  decoder.feed(wire.data(), wire.size(), [&](const Frame& f) {
    frames.push_back({f.type, f.sequence, Bytes(f.payload, f.payload + f.payload_size)});
  });
  EXPECT_EQ(frames.size(), 1u);
  EXPECT_EQ(decoder.stats().frames_ok, 1u);
  EXPECT_EQ(decoder.stats().bytes_discarded, 0u);
  return frames.empty() ? OwnedFrame{} : frames[0];
}

template <class M>
void expect_golden(const M& m, uint16_t sequence, const char* hex) {
  const Bytes wire = from_hex(hex);
  EXPECT_EQ(to_hex(encode(m, sequence)), to_hex(wire));
  const OwnedFrame f = decode_one(wire);
  EXPECT_EQ(f.type, static_cast<uint8_t>(M::kType));
  EXPECT_EQ(f.sequence, sequence);
  Frame view{kProtocolVersion, f.type, f.sequence, f.payload.data(), f.payload.size()};
  M parsed;
  ASSERT_EQ(parse_message(view, parsed), ParseStatus::kOk);
  if constexpr (requires { same(m, parsed); }) {
    EXPECT_TRUE(same(m, parsed));
  }
}

TEST(GoldenFrames, GetDeviceInfo) {
  expect_golden(GetDeviceInfo{}, 0, "03 01 01 01 05 01 73 63 30 00");
}

TEST(GoldenFrames, Configure) {
  expect_golden(golden_configure(), 1,
                "04 01 02 01 04 40 42 0f 03 0b 01 01 01 06 08 4b 75 f5 2d 00");
}

TEST(GoldenFrames, StartAndStop) {
  expect_golden(Start{}, 2, "04 01 03 02 05 e2 11 49 58 00");
  expect_golden(Stop{}, 3, "04 01 04 03 05 fc ed 1b 3f 00");
}

TEST(GoldenFrames, Ping) {
  Ping m;
  m.host_time = 0x0123456789ABCDEFull;
  expect_golden(m, 4, "04 01 05 04 0d ef cd ab 89 67 45 23 01 64 bb 8a 11 00");
}

TEST(GoldenFrames, CalibrationReadAndWrite) {
  expect_golden(CalibrationRead{}, 5, "04 01 06 05 05 c3 ee bb 19 00");
  CalibrationWrite w;
  w.blob = golden_blob();
  EXPECT_EQ(w.blob.crc, 0xD8734D9Bu);  // CRC-32C of 01 04 00 de ad be ef
  expect_golden(w, 6, "04 01 07 06 03 01 04 0d de ad be ef 9b 4d 73 d8 53 99 22 dd 00");
}

TEST(GoldenFrames, DeviceInfo) {
  expect_golden(golden_device_info(), 0,
                "03 01 81 01 13 06 69 6d 75 6b 69 74 04 47 46 2d 31 02 34 32 01 02 03 04 40 42 "
                "0f 05 02 a0 86 01 04 40 42 0f 02 03 02 03 01 01 01 02 02 01 03 80 41 01 01 02 "
                "3a 01 01 02 43 01 05 80 3b 01 03 01 01 01 02 01 01 01 02 41 01 05 80 39 03 01 "
                "01 04 c8 41 01 01 01 02 43 01 07 80 3b e1 40 60 6a 00");
}

TEST(GoldenFrames, SampleBlockWithEveryChannel) {
  expect_golden(golden_block_all_channels(), 6,
                "04 01 82 06 02 40 01 01 01 03 c4 09 04 02 0f 64 03 38 ff 02 40 01 02 01 07 ff "
                "ff 2c 01 d4 fe 01 01 03 02 65 06 39 ff fc 3f 02 03 fe ff 01 06 2d 01 d5 fe 01 "
                "07 01 02 f7 be 04 ed 00");
}

TEST(GoldenFrames, SampleBlockWithAccelAndGyroAtSequenceWrap) {
  expect_golden(golden_block_accel_gyro(), 65535,
                "06 01 82 ff ff 07 01 01 09 d8 fe ff ff 01 03 ff ff 01 02 ff 01 02 01 08 ff ff "
                "7f f5 8e 76 08 00");
}

TEST(GoldenFrames, Pong) {
  Pong m;
  m.host_time = 0x0123456789ABCDEFull;
  m.rx_tick = 1000;
  m.tx_tick = 1012;
  expect_golden(m, 1,
                "04 01 83 01 0b ef cd ab 89 67 45 23 01 e8 03 01 03 f4 03 01 05 d5 6a 96 a8 00");
}

TEST(GoldenFrames, CalibrationData) {
  CalibrationData m;
  m.blob = golden_blob();
  expect_golden(m, 2, "04 01 84 02 03 01 04 0d de ad be ef 9b 4d 73 d8 47 a0 fc 78 00");
}

TEST(GoldenFrames, AckAndNack) {
  Ack ack;
  ack.request_type = static_cast<uint8_t>(MessageType::kConfigure);
  ack.request_sequence = 1;
  expect_golden(ack, 3, "04 01 85 03 03 02 01 05 93 d7 0e 86 00");
  Nack nack;
  nack.request_type = static_cast<uint8_t>(MessageType::kConfigure);
  nack.request_sequence = 1;
  nack.code = NackCode::kUnsupportedRate;
  expect_golden(nack, 4, "04 01 86 04 03 02 01 06 04 8f 4c d5 2a 00");
}

TEST(GoldenFrames, Log) {
  expect_golden(golden_log(), 5, "04 01 87 05 05 01 40 e2 01 0b 05 68 65 6c 6c 6f 53 64 d5 e5 00");
}

// ---- round trips ------------------------------------------------------------------------------

// One random instance of each message type per round; all go into one stream that is fed to the
// decoder in random chunk sizes, and every frame must parse back to the message that was sent.
TEST(Messages, RoundTripEveryMessageThroughRandomChunks) {
  TestRng rng(10);
  for (size_t max_chunk : {1u, 3u, 17u, 700u, 5000u}) {
    Bytes stream;
    std::vector<std::function<void(const Frame&)>> checks;
    uint16_t seq = static_cast<uint16_t>(rng.bits());
    const uint16_t first_seq = seq;
    auto add = [&](const auto& m) {
      using M = std::decay_t<decltype(m)>;
      const Bytes wire = encode(m, seq++);
      ASSERT_FALSE(wire.empty());
      stream.insert(stream.end(), wire.begin(), wire.end());
      checks.push_back([m](const Frame& f) {
        M parsed;
        ASSERT_EQ(parse_message(f, parsed), ParseStatus::kOk);
        if constexpr (requires { same(m, parsed); }) {
          EXPECT_TRUE(same(m, parsed));
        } else {
          (void)m;  // messages without fields: parsing is all there is to check
        }
      });
    };
    for (int round = 0; round < 40; ++round) {
      add(GetDeviceInfo{});
      add(random_device_info(rng));
      add(random_configure(rng));
      add(Start{});
      add(Stop{});
      add(random_ping(rng));
      add(random_pong(rng));
      add(CalibrationRead{});
      CalibrationWrite w;
      w.blob = random_blob(rng);
      add(w);
      CalibrationData d;
      d.blob = random_blob(rng);
      add(d);
      add(random_ack(rng));
      add(random_nack(rng));
      add(random_log(rng));
      const uint8_t channels = static_cast<uint8_t>(1 + rng.below(15));
      add(random_sample_block(rng, static_cast<uint8_t>(1 + rng.below(kMaxBlockSamples)),
                              channels));
    }
    FrameDecoder decoder;
    size_t index = 0;
    size_t pos = 0;
    while (pos < stream.size()) {
      const size_t chunk = std::min<size_t>(stream.size() - pos, 1 + rng.below(max_chunk));
      decoder.feed(stream.data() + pos, chunk, [&](const Frame& f) {
        ASSERT_LT(index, checks.size());
        EXPECT_EQ(f.sequence, static_cast<uint16_t>(first_seq + index));
        checks[index++](f);
      });
      pos += chunk;
    }
    EXPECT_EQ(index, checks.size()) << "max chunk " << max_chunk;
    EXPECT_EQ(decoder.stats().frames_ok, checks.size());
    EXPECT_EQ(decoder.stats().frames_rejected(), 0u);
    EXPECT_EQ(decoder.stats().sequence_gaps, 0u);
    EXPECT_EQ(decoder.stats().bytes_accepted, stream.size());
  }
}

TEST(Messages, LargestSampleBlockFillsButFitsOneFrame) {
  TestRng rng(11);
  const SampleBlock m = random_sample_block(rng, kMaxBlockSamples, kChannelMaskAll);
  const Bytes wire = encode(m, 0);
  ASSERT_FALSE(wire.empty());
  const OwnedFrame f = decode_one(wire);
  EXPECT_EQ(f.payload.size(), 10u + 32u * 20u);  // 650 of the 651 payload bytes
  EXPECT_LE(wire.size(), kMaxFrameSize);
}

// ---- bounds -----------------------------------------------------------------------------------

// The payload of message m, serialised.
template <class M>
Bytes payload_of(const M& m) {
  Bytes p(kMaxPayloadSize);
  ByteWriter w(p.data(), p.size());
  EXPECT_TRUE(write_payload(w, m));
  p.resize(w.size());
  return p;
}

template <class M>
ParseStatus parse(const Bytes& p) {
  M m;
  return read_payload(p.data(), p.size(), m);
}

// Every proper prefix and every one-byte extension of a valid payload is rejected as kBadLength,
// without reading outside the given bytes (each prefix is copied to its own exact-size buffer so
// ASan sees any overrun).
template <class M>
void expect_exact_length(const M& m) {
  const Bytes p = payload_of(m);
  ASSERT_EQ(parse<M>(p), ParseStatus::kOk);
  for (size_t n = 0; n < p.size(); ++n) {
    const Bytes prefix(p.begin(), p.begin() + n);
    EXPECT_EQ(parse<M>(prefix), ParseStatus::kBadLength) << "prefix of " << n << " bytes";
  }
  Bytes longer = p;
  longer.push_back(0);
  EXPECT_EQ(parse<M>(longer), ParseStatus::kBadLength);
}

TEST(Messages, EveryPayloadHasAnExactLength) {
  TestRng rng(12);
  for (int i = 0; i < 20; ++i) {
    expect_exact_length(random_device_info(rng));
    expect_exact_length(random_configure(rng));
    expect_exact_length(random_ping(rng));
    expect_exact_length(random_pong(rng));
    CalibrationWrite w;
    w.blob = random_blob(rng);
    expect_exact_length(w);
    expect_exact_length(random_ack(rng));
    expect_exact_length(random_nack(rng));
    expect_exact_length(random_log(rng));
    expect_exact_length(random_sample_block(rng, static_cast<uint8_t>(1 + rng.below(32)),
                                            static_cast<uint8_t>(1 + rng.below(15))));
  }
  for (const Bytes& one : {Bytes{0}, Bytes{1, 2}}) {
    EXPECT_EQ(parse<GetDeviceInfo>(one), ParseStatus::kBadLength);
    EXPECT_EQ(parse<Start>(one), ParseStatus::kBadLength);
    EXPECT_EQ(parse<Stop>(one), ParseStatus::kBadLength);
    EXPECT_EQ(parse<CalibrationRead>(one), ParseStatus::kBadLength);
  }
}

// Length and count fields beyond their bounds are rejected before they are used, whether or not
// enough bytes follow to satisfy them.
TEST(Messages, RejectsOversizedLengthAndCountFields) {
  // Log: text length 201..255 (bound 200).
  for (int len : {201, 255}) {
    Bytes p = {1, 0, 0, 0, 0, static_cast<uint8_t>(len)};
    EXPECT_EQ(parse<Log>(p), ParseStatus::kBadValue);
    p.resize(p.size() + len, 'x');
    EXPECT_EQ(parse<Log>(p), ParseStatus::kBadValue);
  }
  // Sample block: count 0, 33, 255; channel mask 0 or with reserved bits.
  for (uint8_t count : {0, 33, 255}) {
    Bytes p(10 + 6 * size_t{count}, 1);
    std::fill(p.begin(), p.begin() + 8, 0);
    p[8] = count;
    p[9] = kChannelAccel;
    EXPECT_EQ(parse<SampleBlock>(p), ParseStatus::kBadValue) << int(count);
  }
  for (uint8_t channels : {0x00, 0x10, 0x81}) {
    Bytes p(10 + 20, 1);
    std::fill(p.begin(), p.begin() + 8, 0);
    p[8] = 1;
    p[9] = channels;
    EXPECT_EQ(parse<SampleBlock>(p), ParseStatus::kBadValue) << int(channels);
  }
  // Sample block: a count that the payload does not hold.
  {
    Bytes p(10 + 20 * 31, 1);
    p[8] = 32;
    p[9] = kChannelMaskAll;
    EXPECT_EQ(parse<SampleBlock>(p), ParseStatus::kBadLength);
  }
  // Calibration blob: data size 513 and 65535 (bound 512) in a payload of that length; in a
  // shorter one the length is wrong first (review of 2026-11-27), as check_blob says.
  for (uint16_t size : {513, 65535}) {
    Bytes p = {1, static_cast<uint8_t>(size), static_cast<uint8_t>(size >> 8)};
    EXPECT_EQ(parse<CalibrationWrite>(p), ParseStatus::kBadLength);
    p.resize(3 + 600, 7);
    EXPECT_EQ(parse<CalibrationData>(p), ParseStatus::kBadLength);
    p.resize(3 + size_t{size} + 4, 7);
    EXPECT_EQ(parse<CalibrationWrite>(p), ParseStatus::kBadValue);
    EXPECT_EQ(parse<CalibrationData>(p), ParseStatus::kBadValue);
    EXPECT_EQ(check_blob(p.data(), p.size()), ParseStatus::kBadValue);
  }
  // Device info: text size 33, rate count 0 and 9, sensor count 0 and 5, range count 9.
  const Bytes info = payload_of(golden_device_info());
  {
    Bytes p = info;
    p[0] = 33;  // vendor length
    EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
    p[0] = 255;
    EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  }
  // Offsets in the golden payload: texts 7 + 5 + 3 bytes, firmware 4, tick 4 -> rate count at 23.
  const size_t rate_count_at = 7 + 5 + 3 + 4 + 4;
  ASSERT_EQ(info[rate_count_at], 2);
  for (uint8_t v : {0, 9, 255}) {
    Bytes p = info;
    p[rate_count_at] = v;
    EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue) << int(v);
  }
  const size_t sensor_count_at = rate_count_at + 1 + 2 * 4;
  ASSERT_EQ(info[sensor_count_at], 3);
  for (uint8_t v : {0, 5, 255}) {
    Bytes p = info;
    p[sensor_count_at] = v;
    EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue) << int(v);
  }
  const size_t range_count_at = sensor_count_at + 1 + 1 + 1 + 4;
  ASSERT_EQ(info[range_count_at], 2);
  for (uint8_t v : {0, 9, 255}) {
    Bytes p = info;
    p[range_count_at] = v;
    EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue) << int(v);
  }
}

TEST(Messages, RejectsBadEnumsAndValues) {
  EXPECT_EQ(parse<Nack>(Bytes{2, 1, 0, 0}), ParseStatus::kBadValue);       // code 0
  EXPECT_EQ(parse<Nack>(Bytes{2, 1, 0, 13}), ParseStatus::kBadValue);      // code 13
  EXPECT_EQ(parse<Log>(Bytes{4, 0, 0, 0, 0, 0}), ParseStatus::kBadValue);  // level 4
  EXPECT_EQ(parse<Configure>(Bytes{1, 0, 0, 0, 0x10, 0, 0, 0, 0, 1}), ParseStatus::kBadValue);

  const Bytes info = payload_of(golden_device_info());
  const size_t first_kind_at = 7 + 5 + 3 + 4 + 4 + 1 + 8 + 1;
  ASSERT_EQ(info[first_kind_at], 0);
  Bytes p = info;
  p[first_kind_at] = 4;  // no such sensor kind
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  p = info;
  p[first_kind_at] = 1;  // a second gyroscope
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  p = info;
  p[first_kind_at + 1] = 1;  // accelerometer with one axis
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  p = info;
  // First range's full scale := NaN (0x7FC00000 little-endian).
  const size_t full_scale_at = first_kind_at + 1 + 1 + 4 + 1;
  p[full_scale_at] = 0x00;
  p[full_scale_at + 1] = 0x00;
  p[full_scale_at + 2] = 0xC0;
  p[full_scale_at + 3] = 0x7F;
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  p = info;
  p[full_scale_at + 3] = 0xC1;  // -16.0: a full scale must be positive
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
  p = info;
  p[7 + 5 + 3 + 4] = 0;  // tick_hz = 0
  p[7 + 5 + 3 + 5] = 0;
  p[7 + 5 + 3 + 6] = 0;
  p[7 + 5 + 3 + 7] = 0;
  EXPECT_EQ(parse<DeviceInfo>(p), ParseStatus::kBadValue);
}

TEST(Messages, CalibrationBlobCarriesItsOwnChecksum) {
  CalibrationWrite w;
  w.blob = golden_blob();
  Bytes p = payload_of(w);
  EXPECT_EQ(parse<CalibrationWrite>(p), ParseStatus::kOk);
  EXPECT_EQ(check_blob(p.data(), p.size()), ParseStatus::kOk);
  for (size_t n = 0; n < p.size(); ++n) {
    const Bytes prefix(p.begin(), p.begin() + static_cast<ptrdiff_t>(n));
    EXPECT_EQ(check_blob(prefix.data(), prefix.size()), parse<CalibrationWrite>(prefix)) << n;
  }
  for (size_t i = 0; i < p.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes q = p;
      q[i] ^= static_cast<uint8_t>(1 << bit);
      const ParseStatus s = parse<CalibrationWrite>(q);
      EXPECT_NE(s, ParseStatus::kOk) << "byte " << i << " bit " << bit;
      EXPECT_EQ(check_blob(q.data(), q.size()), s) << "byte " << i << " bit " << bit;
    }
  }
  w.blob.format_version = 0;  // reserved: never a valid layout
  w.blob.seal();
  Bytes out(64);
  ByteWriter bw(out.data(), out.size());
  EXPECT_FALSE(write_payload(bw, w));
}

TEST(Messages, WritersRefuseValuesTheProtocolDoesNotAllow) {
  TestRng rng(13);
  SampleBlock block = random_sample_block(rng, 4, kChannelAccel);
  block.count = 33;
  EXPECT_TRUE(encode(block, 0).empty());
  block.count = 0;
  EXPECT_TRUE(encode(block, 0).empty());
  block.count = 4;
  block.channels = 0;
  EXPECT_TRUE(encode(block, 0).empty());
  Log log = golden_log();
  log.size = 201;
  EXPECT_TRUE(encode(log, 0).empty());
  DeviceInfo info = golden_device_info();
  info.sensors[1].kind = SensorKind::kAccelerometer;  // duplicate kind
  EXPECT_TRUE(encode(info, 0).empty());
  info = golden_device_info();
  info.rate_count = 0;
  EXPECT_TRUE(encode(info, 0).empty());
  // Every listed rate's period is 1 to 2^30 ticks, what Configure takes: a 1 kHz tick listing
  // 2 kHz was valid, and the device then refused its own rate (review, 2026-11-27).
  info = golden_device_info();
  info.tick_hz = 1000;
  info.rates_mhz[1] = 1'000'000;  // 1 kHz: one tick, the fastest
  EXPECT_FALSE(encode(info, 0).empty());
  info.rates_mhz[1] = 2'000'000;  // 2 kHz: half a tick
  EXPECT_TRUE(encode(info, 0).empty());
  info = golden_device_info();  // 1 MHz tick
  info.rates_mhz[0] = 1;        // 1 mHz: 10^9 ticks, under 2^30 = 1.07e9
  EXPECT_FALSE(encode(info, 0).empty());
  info.tick_hz = 2'000'000;  // 2 * 10^9 ticks: beyond
  info.rates_mhz[1] = 100'000;
  EXPECT_TRUE(encode(info, 0).empty());
  Configure c = golden_configure();
  c.channels = 0x20;
  EXPECT_TRUE(encode(c, 0).empty());
}

TEST(Messages, ParseMessageChecksTheType) {
  Ack ack;
  const Bytes wire = encode(ack, 9);
  const OwnedFrame f = decode_one(wire);
  Frame view{kProtocolVersion, f.type, f.sequence, f.payload.data(), f.payload.size()};
  Nack nack;
  EXPECT_EQ(parse_message(view, nack), ParseStatus::kWrongType);
  EXPECT_EQ(parse_message(view, ack), ParseStatus::kOk);
}

}  // namespace
}  // namespace imukit::proto
