#include "imukit/firmware_proto/device_model.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <set>

#include "proto_test_util.hpp"

namespace imukit::proto {
namespace {

using test::Bytes;
using test::encode;
using test::OwnedFrame;
using test::TestRng;

// The sample a fake sensor returns at a tick, so tests can check which tick each sample came from.
SensorSample sample_at(uint32_t tick) {
  SensorSample s;
  for (int a = 0; a < 3; ++a) {
    s.accel[a] = static_cast<int16_t>(tick * 3u + static_cast<uint32_t>(a));
    s.gyro[a] = static_cast<int16_t>(tick * 5u + static_cast<uint32_t>(a));
    s.mag[a] = static_cast<int16_t>(tick * 7u + static_cast<uint32_t>(a));
  }
  s.temperature = static_cast<int16_t>(tick);
  return s;
}

class FakeHal final : public Hal {
 public:
  uint32_t now = 0;
  Bytes sent;
  std::set<uint32_t> failing_ticks;  // read_sensors fails for samples due at these ticks
  int refuse_next_writes = 0;
  bool refuse_configuration = false;
  bool storage_fails = false;
  Bytes storage;
  std::vector<Configure> applied;
  std::vector<uint32_t> read_ticks;

  uint32_t ticks() override { return now; }
  bool read_sensors(uint32_t tick, uint8_t, SensorSample& out) override {
    read_ticks.push_back(tick);
    if (failing_ticks.count(tick)) return false;
    out = sample_at(tick);
    return true;
  }
  bool write(const uint8_t* data, size_t n) override {
    if (refuse_next_writes > 0) {
      --refuse_next_writes;
      return false;
    }
    sent.insert(sent.end(), data, data + n);
    return true;
  }
  bool apply_configuration(const Configure& c) override {
    if (refuse_configuration) return false;
    applied.push_back(c);
    return true;
  }
  bool store_calibration(const uint8_t* blob, size_t n) override {
    if (storage_fails) return false;
    storage.assign(blob, blob + n);
    return true;
  }
  size_t load_calibration(uint8_t* out, size_t capacity) override {
    if (storage.empty() || storage.size() > capacity) return 0;
    std::memcpy(out, storage.data(), storage.size());
    return storage.size();
  }
};

// A wearable with accelerometer, gyroscope and temperature sensor, no magnetometer, clocked by a
// 32768 Hz crystal: at 100 Hz one sample period is 327.68 ticks, which exercises the remainder
// stepping.
DeviceInfo test_device() {
  DeviceInfo m;
  m.vendor.set("acme");
  m.model.set("band");
  m.serial.set("0007");
  m.firmware_major = 2;
  m.tick_hz = 32768;
  m.rate_count = 3;
  m.rates_mhz[0] = 50000;
  m.rates_mhz[1] = 100000;
  m.rates_mhz[2] = 1000000;
  m.sensor_count = 3;
  m.sensors[0] = {SensorKind::kAccelerometer, 3, 0.0f, 2, {{19.6f, 0.0006f}, {156.9f, 0.0048f}}};
  m.sensors[1] = {SensorKind::kGyroscope, 3, 0.0f, 1, {{34.9f, 0.0011f}}};
  m.sensors[2] = {SensorKind::kTemperature, 1, 25.0f, 1, {{100.0f, 0.0039f}}};
  return m;
}

Configure config_100hz(uint8_t samples_per_block) {
  Configure c;
  c.rate_mhz = 100000;
  c.channels = kChannelAccel | kChannelGyro | kChannelTemperature;
  c.range_index[0] = 1;
  c.samples_per_block = samples_per_block;
  return c;
}

// The host end of the link: numbers its requests, decodes everything the device sent.
class Host {
 public:
  Host(FakeHal& hal, DeviceModel& device) : hal_(hal), device_(device) {}

  template <class M>
  uint16_t send(const M& m) {
    const uint16_t seq = seq_++;
    const Bytes wire = encode(m, seq);
    EXPECT_FALSE(wire.empty());
    device_.on_bytes(wire.data(), wire.size());
    return seq;
  }
  uint16_t send_raw(uint8_t type, const Bytes& payload) {
    const uint16_t seq = seq_++;
    const Bytes wire = test::encode_raw(type, seq, payload);
    device_.on_bytes(wire.data(), wire.size());
    return seq;
  }
  // Frames the device wrote since the last call.
  std::vector<OwnedFrame> received() {
    std::vector<OwnedFrame> frames;
    decoder_.feed(hal_.sent.data(), hal_.sent.size(), [&](const Frame& f) {
      frames.push_back({f.type, f.sequence, Bytes(f.payload, f.payload + f.payload_size)});
    });
    hal_.sent.clear();
    return frames;
  }
  const DecoderStats& stats() const { return decoder_.stats(); }

 private:
  FakeHal& hal_;
  DeviceModel& device_;
  FrameDecoder decoder_;
  uint16_t seq_ = 100;
};

template <class M>
M parse_as(const OwnedFrame& f) {
  M m;
  Frame view{kProtocolVersion, f.type, f.sequence, f.payload.data(), f.payload.size()};
  EXPECT_EQ(parse_message(view, m), ParseStatus::kOk) << "type 0x" << std::hex << int(f.type);
  return m;
}

void expect_ack(const OwnedFrame& f, MessageType request, uint16_t seq) {
  ASSERT_EQ(f.type, static_cast<uint8_t>(MessageType::kAck));
  const Ack a = parse_as<Ack>(f);
  EXPECT_EQ(a.request_type, static_cast<uint8_t>(request));
  EXPECT_EQ(a.request_sequence, seq);
}

void expect_nack(const OwnedFrame& f, MessageType request, uint16_t seq, NackCode code) {
  ASSERT_EQ(f.type, static_cast<uint8_t>(MessageType::kNack));
  const Nack n = parse_as<Nack>(f);
  EXPECT_EQ(n.request_type, static_cast<uint8_t>(request));
  EXPECT_EQ(n.request_sequence, seq);
  EXPECT_EQ(static_cast<int>(n.code), static_cast<int>(code));
}

struct Fixture {
  FakeHal hal;
  DeviceModel device{hal, test_device()};
  Host host{hal, device};
};

TEST(DeviceModel, AnswersDeviceInfo) {
  Fixture f;
  EXPECT_TRUE(f.device.valid_info());
  f.host.send(GetDeviceInfo{});
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_EQ(frames[0].type, static_cast<uint8_t>(MessageType::kDeviceInfo));
  EXPECT_TRUE(test::same(parse_as<DeviceInfo>(frames[0]), test_device()));
  EXPECT_EQ(frames[0].sequence, 0);
}

TEST(DeviceModel, AcksAndAppliesAValidConfiguration) {
  Fixture f;
  const uint16_t seq = f.host.send(config_100hz(4));
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u);
  expect_ack(frames[0], MessageType::kConfigure, seq);
  ASSERT_EQ(f.hal.applied.size(), 1u);
  EXPECT_TRUE(test::same(f.hal.applied[0], config_100hz(4)));
  EXPECT_TRUE(test::same(f.device.configuration(), config_100hz(4)));
}

TEST(DeviceModel, NacksEachKindOfBadConfigurationAndKeepsTheOldOne) {
  Fixture f;
  struct Case {
    Configure config;
    NackCode code;
  };
  std::vector<Case> cases;
  Configure c = config_100hz(4);
  c.rate_mhz = 200000;  // not listed
  cases.push_back({c, NackCode::kUnsupportedRate});
  c = config_100hz(4);
  c.channels = 0;
  cases.push_back({c, NackCode::kNoSensorsEnabled});
  c = config_100hz(4);
  c.channels |= kChannelMag;  // the device has no magnetometer
  cases.push_back({c, NackCode::kUnsupportedSensor});
  c = config_100hz(4);
  c.range_index[0] = 2;  // the accelerometer has 2 ranges
  cases.push_back({c, NackCode::kUnsupportedRange});
  c = config_100hz(4);
  c.range_index[1] = 1;  // the gyroscope has 1
  cases.push_back({c, NackCode::kUnsupportedRange});
  c = config_100hz(0);
  cases.push_back({c, NackCode::kInvalidBlockSize});
  c = config_100hz(33);
  cases.push_back({c, NackCode::kInvalidBlockSize});
  for (const Case& k : cases) {
    const uint16_t seq = f.host.send(k.config);
    const auto frames = f.host.received();
    ASSERT_EQ(frames.size(), 1u);
    expect_nack(frames[0], MessageType::kConfigure, seq, k.code);
  }
  // Range index of a disabled sensor is ignored.
  c = config_100hz(4);
  c.channels = kChannelAccel;
  c.range_index[1] = 9;
  uint16_t seq = f.host.send(c);
  expect_ack(f.host.received().at(0), MessageType::kConfigure, seq);
  // The sensor refuses.
  f.hal.refuse_configuration = true;
  seq = f.host.send(config_100hz(16));
  expect_nack(f.host.received().at(0), MessageType::kConfigure, seq, NackCode::kHardwareError);
  EXPECT_TRUE(test::same(f.device.configuration(), c));
  // Malformed: one byte short.
  seq = f.host.send_raw(static_cast<uint8_t>(MessageType::kConfigure), Bytes(9, 1));
  expect_nack(f.host.received().at(0), MessageType::kConfigure, seq, NackCode::kMalformed);
  EXPECT_EQ(f.device.stats().nacks_sent, cases.size() + 2);
}

TEST(DeviceModel, NacksUnknownTypesAndDeviceMessagesFromTheHost) {
  Fixture f;
  uint16_t seq = f.host.send_raw(0x40, {});
  expect_nack(f.host.received().at(0), static_cast<MessageType>(0x40), seq,
              NackCode::kUnknownMessage);
  seq = f.host.send_raw(static_cast<uint8_t>(MessageType::kSampleBlock), Bytes(30, 1));
  expect_nack(f.host.received().at(0), MessageType::kSampleBlock, seq, NackCode::kUnknownMessage);
  seq = f.host.send_raw(static_cast<uint8_t>(MessageType::kStart), {1});
  expect_nack(f.host.received().at(0), MessageType::kStart, seq, NackCode::kMalformed);
  EXPECT_EQ(f.device.state(), DeviceState::kIdle);
}

// Streams for a while with irregular poll intervals and checks every sample: cumulative index
// without gaps, block sizes, the tick of each block's first sample against the exact formula
// start + floor(i * tick_hz * 1000 / rate_mhz) (mod 2^32, starting just before the clock wraps),
// and that every sample carries the values the sensor gave for that tick.
TEST(DeviceModel, StreamsContinuousBlocksAtTheConfiguredRate) {
  Fixture f;
  TestRng rng(30);
  const uint32_t start = 0xFFFF0000u;  // the 32-bit tick wraps during the run
  f.hal.now = start - 1000;
  const uint16_t cfg = f.host.send(config_100hz(5));
  f.hal.now = start;
  const uint16_t go = f.host.send(Start{});
  auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 2u);
  expect_ack(frames[0], MessageType::kConfigure, cfg);
  expect_ack(frames[1], MessageType::kStart, go);
  EXPECT_EQ(f.device.state(), DeviceState::kStreaming);

  const uint32_t run_ticks = 32768 * 30;  // 30 s at 100 Hz: 3000 samples
  while (f.hal.now - start < run_ticks) {
    f.hal.now += static_cast<uint32_t>(rng.below(2000));
    f.device.poll();
  }
  const uint32_t stop_tick = f.hal.now;
  const uint16_t halt = f.host.send(Stop{});
  frames = f.host.received();
  ASSERT_FALSE(frames.empty());
  expect_ack(frames.back(), MessageType::kStop, halt);
  frames.pop_back();

  const uint64_t elapsed = static_cast<uint32_t>(stop_tick - start);
  const uint64_t expected_samples = elapsed * 100000 / (32768ull * 1000) + 1;  // i = 0 at start
  uint32_t index = 0;
  for (size_t b = 0; b < frames.size(); ++b) {
    ASSERT_EQ(frames[b].type, static_cast<uint8_t>(MessageType::kSampleBlock));
    const SampleBlock block = parse_as<SampleBlock>(frames[b]);
    EXPECT_EQ(block.sample_index, index);
    const uint32_t due = start + static_cast<uint32_t>(uint64_t{index} * 32768 * 1000 / 100000);
    EXPECT_EQ(block.first_tick, due) << "block " << b;
    EXPECT_EQ(block.channels, kChannelAccel | kChannelGyro | kChannelTemperature);
    if (b + 1 < frames.size()) {
      EXPECT_EQ(block.count, 5);
    }
    for (uint8_t i = 0; i < block.count; ++i) {
      const uint32_t tick = start + static_cast<uint32_t>(uint64_t{index + i} * 32768000 / 100000);
      const SensorSample s = sample_at(tick);
      EXPECT_EQ(block.accel[i][2], s.accel[2]);
      EXPECT_EQ(block.gyro[i][0], s.gyro[0]);
      EXPECT_EQ(block.temperature[i], s.temperature);
    }
    index += block.count;
  }
  EXPECT_EQ(index, expected_samples);
  EXPECT_EQ(f.device.stats().samples_sent, expected_samples);
  EXPECT_EQ(f.hal.read_ticks.size(), expected_samples);
  EXPECT_EQ(f.host.stats().sequence_gaps, 0u);
  EXPECT_EQ(f.device.state(), DeviceState::kIdle);
  // Idle: no more samples however long we wait.
  f.hal.now += 100000;
  f.device.poll();
  EXPECT_TRUE(f.host.received().empty());
}

TEST(DeviceModel, SampleTicksFollowTheFormulaAtRatesAboveTwoToThe31MilliHertz) {
  // Found in review: the remainder's sum wrapped in 32 bits for rates above 2^31 mHz, so 8 of the
  // first 10 ticks were early (0, 1, 2, ... for 0, 1, 3, 5, ...).
  DeviceInfo info = test_device();
  info.tick_hz = 8589934;
  info.rates_mhz[0] = 4294967295u;
  FakeHal hal;
  DeviceModel device{hal, info};
  Host host{hal, device};
  Configure c = config_100hz(10);
  c.rate_mhz = info.rates_mhz[0];
  host.send(c);
  host.send(Start{});
  ASSERT_EQ(device.state(), DeviceState::kStreaming);
  for (uint32_t t = 0; t < 4000; ++t) {
    hal.now = t;
    device.poll();
  }
  ASSERT_GE(hal.read_ticks.size(), 1000u);
  for (uint64_t i = 0; i < hal.read_ticks.size(); ++i) {
    EXPECT_EQ(hal.read_ticks[i], i * 8589934000ull / 4294967295ull) << "sample " << i;
    if (::testing::Test::HasFailure()) break;
  }
}

TEST(DeviceModel, StopSendsThePartialBlockBeforeTheAck) {
  Fixture f;
  f.host.send(config_100hz(32));
  f.host.send(Start{});
  f.host.received();
  f.hal.now += 328 * 6;  // samples 0..6 are due (7 samples)
  f.device.poll();
  EXPECT_TRUE(f.host.received().empty());  // the block of 32 is not full
  const uint16_t halt = f.host.send(Stop{});
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(parse_as<SampleBlock>(frames[0]).count, 7);
  expect_ack(frames[1], MessageType::kStop, halt);
  // Stop while idle is acknowledged too (the host's goal, a stopped device, holds).
  const uint16_t again = f.host.send(Stop{});
  expect_ack(f.host.received().at(0), MessageType::kStop, again);
}

TEST(DeviceModel, RefusesReconfigurationAndRestartWhileStreaming) {
  Fixture f;
  f.host.send(Start{});
  f.host.received();
  uint16_t seq = f.host.send(config_100hz(4));
  expect_nack(f.host.received().at(0), MessageType::kConfigure, seq, NackCode::kBadState);
  seq = f.host.send(Start{});
  expect_nack(f.host.received().at(0), MessageType::kStart, seq, NackCode::kBadState);
  EXPECT_EQ(f.device.state(), DeviceState::kStreaming);
}

TEST(DeviceModel, StartWithoutConfigureUsesTheDefaultConfiguration) {
  Fixture f;
  f.host.send(Start{});
  ASSERT_EQ(f.hal.applied.size(), 1u);
  const Configure& c = f.hal.applied[0];
  EXPECT_EQ(c.rate_mhz, 50000u);  // first listed rate
  EXPECT_EQ(c.channels, kChannelAccel | kChannelGyro | kChannelTemperature);
  EXPECT_EQ(c.samples_per_block, 8);
  f.host.received();
  f.hal.now += 32768 * 7 / 50 * 1 + 1;  // past sample 7 at 50 Hz (655.36 ticks each)
  f.device.poll();
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(parse_as<SampleBlock>(frames[0]).count, 8);
}

TEST(DeviceModel, SkipsFailedSensorReadsVisiblyInTheSampleIndex) {
  Fixture f;
  f.host.send(config_100hz(4));
  f.host.send(Start{});
  f.host.received();
  // Samples 2 and 9 fail.
  auto tick_of = [](uint32_t i) { return static_cast<uint32_t>(uint64_t{i} * 32768000 / 100000); };
  f.hal.failing_ticks = {tick_of(2), tick_of(9)};
  f.hal.now = tick_of(15);
  f.device.poll();
  const auto frames = f.host.received();
  std::vector<std::pair<uint32_t, uint8_t>> blocks;  // (first index, count)
  for (const auto& fr : frames) {
    const SampleBlock b = parse_as<SampleBlock>(fr);
    blocks.emplace_back(b.sample_index, b.count);
    EXPECT_EQ(b.first_tick, tick_of(b.sample_index));
  }
  // 0-1 | (2 fails) 3-6 | 7-8 | (9 fails) 10-13 | 14-15 pending
  const std::vector<std::pair<uint32_t, uint8_t>> expected = {{0, 2}, {3, 4}, {7, 2}, {10, 4}};
  EXPECT_EQ(blocks, expected);
  EXPECT_EQ(f.device.stats().sensor_read_errors, 2u);
  EXPECT_EQ(f.device.next_sample_index(), 16u);
  EXPECT_EQ(f.device.pending_samples(), 2u);  // 14 and 15
  const DeviceStats& s = f.device.stats();
  EXPECT_EQ(s.samples_taken, 16u);
  EXPECT_EQ(s.samples_sent + s.samples_dropped + s.sensor_read_errors + f.device.pending_samples(),
            s.samples_taken);
}

TEST(DeviceModel, AFrameTheLinkRefusesShowsAsASequenceAndSampleGap) {
  Fixture f;
  f.host.send(config_100hz(4));
  f.host.send(Start{});
  f.host.received();
  auto tick_of = [](uint32_t i) { return static_cast<uint32_t>(uint64_t{i} * 32768000 / 100000); };
  f.hal.now = tick_of(3);
  f.device.poll();  // block 0..3 sent
  f.hal.refuse_next_writes = 1;
  f.hal.now = tick_of(7);
  f.device.poll();  // block 4..7 refused
  f.hal.now = tick_of(11);
  f.device.poll();  // block 8..11 sent
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(parse_as<SampleBlock>(frames[0]).sample_index, 0u);
  EXPECT_EQ(parse_as<SampleBlock>(frames[1]).sample_index, 8u);
  EXPECT_EQ(f.host.stats().sequence_gaps, 1u);
  EXPECT_EQ(f.host.stats().frames_missed, 1u);
  EXPECT_EQ(f.device.stats().frames_dropped, 1u);
  EXPECT_EQ(f.device.stats().samples_dropped, 4u);
  EXPECT_EQ(f.device.stats().samples_sent, 8u);
  EXPECT_EQ(f.device.stats().samples_taken, 12u);
  EXPECT_EQ(f.device.pending_samples(), 0u);
}

TEST(DeviceModel, PongCarriesReceiveAndTransmitTicks) {
  Fixture f;
  Ping ping;
  ping.host_time = 0x1122334455667788ull;
  const Bytes wire = encode(ping, 7);
  f.hal.now = 5000;
  f.device.on_bytes(wire.data(), wire.size(), 4321);  // bytes arrived at tick 4321
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u);
  const Pong pong = parse_as<Pong>(frames[0]);
  EXPECT_EQ(pong.host_time, 0x1122334455667788ull);
  EXPECT_EQ(pong.rx_tick, 4321u);
  EXPECT_EQ(pong.tx_tick, 5000u);
  // Without an explicit receive tick the clock is read when the frame completes.
  f.hal.now = 6000;
  f.host.send(ping);
  const Pong second = parse_as<Pong>(f.host.received().at(0));
  EXPECT_EQ(second.rx_tick, 6000u);
  EXPECT_EQ(second.tx_tick, 6000u);
}

TEST(DeviceModel, StoresAndReturnsCalibrationAndRejectsBadBlobs) {
  Fixture f;
  uint16_t seq = f.host.send(CalibrationRead{});
  expect_nack(f.host.received().at(0), MessageType::kCalibrationRead, seq,
              NackCode::kNoCalibration);

  TestRng rng(31);
  CalibrationWrite w;
  w.blob = test::random_blob(rng);
  seq = f.host.send(w);
  expect_ack(f.host.received().at(0), MessageType::kCalibrationWrite, seq);
  // Stored exactly as serialised on the wire.
  Bytes serialised(kMaxCalibrationBlobSize);
  ByteWriter bw(serialised.data(), serialised.size());
  ASSERT_TRUE(write_blob(bw, w.blob));
  serialised.resize(bw.size());
  EXPECT_EQ(f.hal.storage, serialised);

  seq = f.host.send(CalibrationRead{});
  auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_EQ(frames[0].type, static_cast<uint8_t>(MessageType::kCalibrationData));
  EXPECT_TRUE(test::same(parse_as<CalibrationData>(frames[0]).blob, w.blob));

  // A blob whose CRC does not match is refused and the stored one kept.
  CalibrationWrite bad = w;
  bad.blob.data[0] ^= 1;
  seq = f.host.send(bad);
  expect_nack(f.host.received().at(0), MessageType::kCalibrationWrite, seq,
              NackCode::kCalibrationInvalid);
  EXPECT_EQ(f.hal.storage, serialised);

  // A blob cut short is malformed, not merely invalid, also where its size field is beyond the
  // largest blob (review of 2026-11-27: size 768 in a 7-byte payload was CALIBRATION_INVALID).
  seq = f.host.send_raw(static_cast<uint8_t>(MessageType::kCalibrationWrite), {1, 4, 0, 0xDE});
  expect_nack(f.host.received().at(0), MessageType::kCalibrationWrite, seq, NackCode::kMalformed);
  seq =
      f.host.send_raw(static_cast<uint8_t>(MessageType::kCalibrationWrite), {1, 0, 3, 0, 0, 0, 0});
  expect_nack(f.host.received().at(0), MessageType::kCalibrationWrite, seq, NackCode::kMalformed);

  // Storage failure.
  f.hal.storage_fails = true;
  seq = f.host.send(w);
  expect_nack(f.host.received().at(0), MessageType::kCalibrationWrite, seq,
              NackCode::kStorageError);
  f.hal.storage_fails = false;

  // Corruption in the device's storage is caught on the way back.
  f.hal.storage[f.hal.storage.size() / 2] ^= 0x40;
  seq = f.host.send(CalibrationRead{});
  expect_nack(f.host.received().at(0), MessageType::kCalibrationRead, seq,
              NackCode::kCalibrationInvalid);

  // Not while streaming.
  f.host.send(Start{});
  f.host.received();
  seq = f.host.send(w);
  expect_nack(f.host.received().at(0), MessageType::kCalibrationWrite, seq, NackCode::kBadState);
}

TEST(DeviceModel, IgnoresLineNoiseBetweenRequests) {
  Fixture f;
  TestRng rng(32);
  Bytes noise(300);
  for (auto& b : noise) b = rng.byte();
  noise.push_back(0);
  f.device.on_bytes(noise.data(), noise.size());
  const uint16_t seq = f.host.send(GetDeviceInfo{});
  const auto frames = f.host.received();
  ASSERT_EQ(frames.size(), 1u) << "noise must not produce answers";
  EXPECT_EQ(frames[0].type, static_cast<uint8_t>(MessageType::kDeviceInfo));
  (void)seq;
  EXPECT_EQ(f.device.stats().requests, 1u);
  EXPECT_EQ(f.device.link_stats().bytes_discarded, noise.size());
}

TEST(DeviceModel, SendsLogText) {
  Fixture f;
  f.hal.now = 777;
  EXPECT_TRUE(f.device.log(LogLevel::kWarning, "battery low"));
  const Log log = parse_as<Log>(f.host.received().at(0));
  EXPECT_EQ(log.level, LogLevel::kWarning);
  EXPECT_EQ(log.tick, 777u);
  EXPECT_EQ(std::string(log.text, log.size), "battery low");
  const std::string long_text(300, 'x');
  EXPECT_TRUE(f.device.log(LogLevel::kInfo, long_text.c_str()));
  EXPECT_EQ(parse_as<Log>(f.host.received().at(0)).size, kMaxLogText);
}

}  // namespace
}  // namespace imukit::proto
