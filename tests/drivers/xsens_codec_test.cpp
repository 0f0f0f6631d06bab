#include "imukit/drivers/xsens_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>

#include "support/test_data.hpp"
#include "test_util.hpp"

namespace imukit::drivers {
namespace {

std::vector<uint8_t> hex_bytes(const std::string& text) {
  std::vector<uint8_t> out;
  std::istringstream in(text);
  std::string tok;
  while (in >> tok) out.push_back(static_cast<uint8_t>(std::stoul(tok, nullptr, 16)));
  return out;
}

// One "Raw Data" block of mtmanager_packets.md with the "Decoded Info" MT Manager printed for it.
struct GoldenPacket {
  std::vector<uint8_t> payload;
  std::string decoded;
};

std::vector<GoldenPacket> read_golden(const std::filesystem::path& file) {
  const std::string text = imukit::testing::read_file(file);
  std::vector<GoldenPacket> out;
  std::size_t pos = 0;
  for (;;) {
    const std::size_t raw = text.find("## Raw Data", pos);
    if (raw == std::string::npos) break;
    const std::size_t a = text.find("```", raw) + 3;
    const std::size_t b = text.find("```", a);
    const std::size_t dec = text.find("## Decoded Info", b);
    const std::size_t c = text.find("```", dec) + 3;
    const std::size_t d = text.find("```", c);
    out.push_back({hex_bytes(text.substr(a, b - a)), text.substr(c, d - c)});
    pos = d + 3;
  }
  return out;
}

std::optional<double> field(const std::string& decoded, const std::string& name) {
  std::smatch m;
  if (std::regex_search(decoded, m, std::regex(name + ":\\s*(-?[0-9.]+)"))) return std::stod(m[1]);
  return std::nullopt;
}

std::optional<int64_t> item(const std::string& decoded, const std::string& name) {
  std::smatch m;
  if (std::regex_search(decoded, m, std::regex("\\(" + name + ", [0-9]+ bytes, ([0-9]+)\\)"))) {
    return std::stoll(m[1]);
  }
  return std::nullopt;
}

TEST(XsensCodec, DecodesRealPacketsAsMtManagerDid) {
  IMUKIT_REQUIRE_DATA(data);
  const auto golden = read_golden(data / "xsens_packets" / "mtmanager_packets.md");
  ASSERT_EQ(golden.size(), 6u);
  int with_mag = 0, with_temp = 0;
  for (const GoldenPacket& g : golden) {
    XsensCodec codec;
    std::vector<Sample> out;
    const auto frame = xsens_frame(xsens::kMidMtData2, g.payload);
    codec.feed(frame, 0, out);
    SCOPED_TRACE(g.decoded.substr(0, 60));
    EXPECT_EQ(codec.stats().frames_ok, 1u);
    EXPECT_EQ(codec.stats().frames_corrupt, 0u);
    XsensPacket pk;
    ASSERT_TRUE(parse_mtdata2(g.payload, pk));
    ASSERT_TRUE(pk.packet_counter.has_value());
    EXPECT_EQ(*pk.packet_counter, *item(g.decoded, "PacketCounter"));
    EXPECT_EQ(*pk.sample_time_fine, *item(g.decoded, "SampleTimeFine"));
    // MT Manager prints the float32 values to 8 decimals: agree within half a unit of the last.
    constexpr double kTol = 5.1e-9;
    const auto acc = field(g.decoded, "accX");
    if (!acc) {  // Packet 6 carries only orientation: no sample for imukit
      EXPECT_TRUE(out.empty());
      continue;
    }
    ASSERT_EQ(out.size(), 1u);
    const Sample& s = out[0];
    EXPECT_EQ(s.sequence, static_cast<uint64_t>(*pk.packet_counter));
    EXPECT_EQ(s.device_time, *pk.sample_time_fine * int64_t{100'000});  // 10 kHz ticks
    const char* acc_names[] = {"accX", "accY", "accZ"};
    const char* gyr_names[] = {"gyrX", "gyrY", "gyrZ"};
    const char* mag_names[] = {"magX", "magY", "magZ"};
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(s.accel[k], *field(g.decoded, acc_names[k]), kTol);
      EXPECT_NEAR(s.gyro[k], *field(g.decoded, gyr_names[k]), kTol);
    }
    if (auto mx = field(g.decoded, "magX")) {
      ++with_mag;
      ASSERT_TRUE(s.channels & kHasMag);
      EXPECT_TRUE(s.mag_arbitrary_units);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.mag[k], *field(g.decoded, mag_names[k]), kTol);
    } else {
      EXPECT_FALSE(s.channels & kHasMag);
    }
    if (auto t = field(g.decoded, "Temp")) {
      ++with_temp;
      ASSERT_TRUE(s.channels & kHasTemperature);
      EXPECT_NEAR(s.temperature_c, *t, kTol);
    }
    // StatusWord printed as 32 bits, most significant first.
    std::smatch m;
    ASSERT_TRUE(std::regex_search(g.decoded, m, std::regex("StatusWord, 4 bytes, ([01]{32})")));
    EXPECT_EQ(s.status, std::stoul(m[1], nullptr, 2));
  }
  EXPECT_EQ(with_mag, 4);
  EXPECT_EQ(with_temp, 1);
}

TEST(XsensCodec, BuildsTheConfigurationMtManagerSent) {
  // "Configuration Example" of mtmanager_packets.md: the bytes MT Manager wrote.
  EXPECT_EQ(xsens_frame(xsens::kMidGoToConfig, {}), hex_bytes("FA FF 30 00 D1"));
  EXPECT_EQ(xsens_frame(xsens::kMidGoToMeasurement, {}), hex_bytes("FA FF 10 00 F1"));
  const XsensOutput outputs[] = {{0x1020, 0xFFFF}, {0x1060, 0xFFFF}, {0x2010, 400},
                                 {0x4020, 400},    {0x4010, 400},    {0x4030, 400},
                                 {0x8020, 400},    {0x8030, 400},    {0xC020, 100},
                                 {0x0810, 10},     {0x3010, 50},     {0xE020, 0xFFFF}};
  const auto frame =
      xsens_frame(xsens::kMidSetOutputConfiguration, xsens_output_configuration(outputs));
  EXPECT_EQ(frame,
            hex_bytes("FA FF C0 30 10 20 FF FF 10 60 FF FF 20 10 01 90 40 20 01 90 40 10 01 90 "
                      "40 30 01 90 80 20 01 90 80 30 01 90 C0 20 00 64 08 10 00 0A 30 10 00 "
                      "32 E0 20 FF FF 99"));
}

TEST(XsensCodec, QueuesConfigurationAtStartAndReadsAcks) {
  XsensCodec codec(XsensCodecOptions{100, 50});
  codec.start(0);
  const auto sent = codec.take_outgoing();
  auto expected = xsens_frame(xsens::kMidGoToConfig, {});
  const XsensOutput outputs[] = {{0x1020, 0xFFFF}, {0x1060, 0xFFFF}, {0x4020, 100},   {0x8020, 100},
                                 {0xC020, 50},     {0x0810, 50},     {0xE020, 0xFFFF}};
  auto cfg = xsens_frame(0xC0, xsens_output_configuration(outputs));
  expected.insert(expected.end(), cfg.begin(), cfg.end());
  auto meas = xsens_frame(0x10, {});
  expected.insert(expected.end(), meas.begin(), meas.end());
  EXPECT_EQ(sent, expected);
  // Responses recorded in the md file: GoToConfigAck, OutputConfiguration, InitMTResults.
  std::vector<Sample> out;
  codec.feed(
      hex_bytes(
          "FA FF 31 00 D0  FA FF C1 08 10 20 FF FF 10 60 FF FF 9C  FA FF 03 04 03 70 03 F8 8C"),
      0, out);
  EXPECT_EQ(codec.stats().frames_ok, 3u);
  EXPECT_EQ(codec.stats().frames_corrupt, 0u);
  EXPECT_EQ(codec.messages(), (std::vector<uint8_t>{0x31, 0xC1, 0x03}));
  EXPECT_TRUE(out.empty());
}

// A synthetic stream: MTData2 with counter, time, acceleration, rate of turn (float32).
std::vector<uint8_t> synthetic_packet(uint16_t counter, uint32_t time, float base) {
  std::vector<uint8_t> p;
  auto u16 = [&](uint16_t v) {
    p.push_back(static_cast<uint8_t>(v >> 8));
    p.push_back(static_cast<uint8_t>(v));
  };
  auto f32 = [&](float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    for (int i = 3; i >= 0; --i) p.push_back(static_cast<uint8_t>(b >> (8 * i)));
  };
  u16(0x1020);
  p.push_back(2);
  u16(counter);
  u16(0x1060);
  p.push_back(4);
  u16(static_cast<uint16_t>(time >> 16));
  u16(static_cast<uint16_t>(time));
  u16(0x4020);
  p.push_back(12);
  f32(base);
  f32(base + 1);
  f32(base + 2);
  u16(0x8020);
  p.push_back(12);
  f32(-base);
  f32(0.5f);
  f32(0.25f);
  return xsens_frame(xsens::kMidMtData2, p);
}

TEST(XsensCodec, SplitAnywhereGivesTheSameSamplesAndUnwrapsCounters) {
  std::vector<uint8_t> stream;
  const int n = 3000;
  for (int i = 0; i < n; ++i) {
    const auto f = synthetic_packet(static_cast<uint16_t>(65000 + i), 0xFFFFF000u + 100u * i,
                                    static_cast<float>(i % 97));
    stream.insert(stream.end(), f.begin(), f.end());
  }
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    Rng rng(seed);
    XsensCodec codec;
    const auto out = testing::feed_split(codec, stream, rng, 1 + 40 * seed);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(out[i].sequence, 65000u + i);
      // SampleTimeFine wraps at 2^32 after 16 packets; unwrapped it keeps counting.
      EXPECT_EQ(out[i].device_time, (int64_t{0xFFFFF000} + 100 * i) * 100'000);
      EXPECT_EQ(out[i].accel[2], static_cast<float>(i % 97) + 2.0f);
    }
    EXPECT_EQ(codec.stats().samples_dropped, 0u);
    EXPECT_EQ(codec.stats().frames_corrupt, 0u);
    testing::expect_byte_accounting(codec);
  }
}

TEST(XsensCodec, NonFiniteSamplesAreDroppedAndCountedAsCorrupt) {
  // Checksums are fine; the floats are NaN, +inf and -inf in packets 10, 11 and 12.
  std::vector<uint8_t> stream;
  for (int i = 0; i < 100; ++i) {
    float base = 1.0f;
    if (i == 10) base = std::numeric_limits<float>::quiet_NaN();
    if (i == 11) base = std::numeric_limits<float>::infinity();
    if (i == 12) base = -std::numeric_limits<float>::infinity();
    const auto f = synthetic_packet(static_cast<uint16_t>(i), 100u * i, base);
    stream.insert(stream.end(), f.begin(), f.end());
  }
  XsensCodec codec;
  Rng rng(3);
  const auto out = testing::feed_split(codec, stream, rng, 50);
  const CodecStats& s = codec.stats();
  ASSERT_EQ(out.size(), 97u);
  EXPECT_EQ(s.samples_non_finite, 3u);
  EXPECT_EQ(s.frames_corrupt, 3u);
  EXPECT_EQ(s.samples_dropped, 3u);
  EXPECT_EQ(s.samples_decoded, 97u);
  EXPECT_EQ(s.frames_ok, 100u);
  for (const Sample& x : out) {
    EXPECT_TRUE(x.sequence < 10 || x.sequence > 12) << x.sequence;
    EXPECT_EQ(x.accel[0], 1.0);
  }
  testing::expect_byte_accounting(codec);
}

TEST(XsensCodec, CorruptionIsDetectedAndEveryLostPacketCounted) {
  std::vector<uint8_t> stream;
  std::vector<std::size_t> starts;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    starts.push_back(stream.size());
    const auto f = synthetic_packet(static_cast<uint16_t>(i * 1), 1000u * i, 1.0f);
    stream.insert(stream.end(), f.begin(), f.end());
  }
  Rng rng(42);
  // Corrupt one byte in 150 distinct packets, never the first or the last: a counter can only
  // show a loss between two packets that arrived.
  std::set<int> hit;
  while (hit.size() < 150) hit.insert(1 + static_cast<int>(rng.uniform_index(n - 2)));
  for (int i : hit) {
    const std::size_t size = starts[i + 1] - starts[i];
    const std::size_t at = starts[i] + rng.uniform_index(size);
    stream[at] ^= static_cast<uint8_t>(1 + rng.uniform_index(255));
  }
  XsensCodec codec;
  const auto out = testing::feed_split(codec, stream, rng, 100);
  const CodecStats& s = codec.stats();
  EXPECT_EQ(out.size(), static_cast<std::size_t>(n) - hit.size());
  EXPECT_EQ(s.samples_decoded + s.samples_dropped, static_cast<uint64_t>(n));
  EXPECT_GE(s.frames_corrupt, 1u);
  testing::expect_byte_accounting(codec);
  // Every sample that came through is intact (the checksum caught the damage).
  for (const Sample& x : out) {
    EXPECT_FALSE(hit.count(static_cast<int>(x.sequence)));
    EXPECT_EQ(x.device_time, static_cast<int64_t>(x.sequence) * 1000 * 100'000);
  }
}

// Corrupt frames count frames, not stretches of damage: three packets in a row with a bad
// checksum are three, and a packet whose preamble was damaged is one more.
TEST(XsensCodec, EveryDamagedFrameIsCountedOnce) {
  std::vector<uint8_t> stream;
  for (int i = 0; i < 1000; ++i) {
    auto f = synthetic_packet(static_cast<uint16_t>(i), 100u * i, 1.0f);
    if (i == 100 || i == 101 || i == 102) f.back() ^= 1;
    if (i == 500) f[0] = 0xFB;
    stream.insert(stream.end(), f.begin(), f.end());
  }
  XsensCodec codec;
  Rng rng(8);
  const auto out = testing::feed_split(codec, stream, rng, 300);
  const CodecStats& s = codec.stats();
  EXPECT_EQ(out.size(), 996u);
  EXPECT_EQ(s.frames_corrupt, 4u);
  EXPECT_EQ(s.samples_dropped, 4u);
  EXPECT_EQ(s.frames_ok, 996u);
  testing::expect_byte_accounting(codec);
}

TEST(XsensCodec, ExtendedLengthFramesDecode) {
  // 300-byte MTData2: counter, acceleration, and an item the codec skips (quaternion id 0x2010
  // repeated as padding), so LEN is 0xFF followed by a 2-byte length.
  std::vector<uint8_t> p = {0x10, 0x20, 2, 0x12, 0x34, 0x40, 0x20, 12};
  for (float f : {1.5f, -2.0f, 9.75f}) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    for (int i = 3; i >= 0; --i) p.push_back(static_cast<uint8_t>(b >> (8 * i)));
  }
  while (p.size() + 19 <= 300) {
    p.insert(p.end(), {0x20, 0x10, 16});
    p.insert(p.end(), 16, 0x3F);
  }
  const auto frame = xsens_frame(xsens::kMidMtData2, p);
  ASSERT_EQ(frame[3], 0xFF);
  EXPECT_EQ((frame[4] << 8) | frame[5], static_cast<int>(p.size()));
  XsensCodec codec;
  Rng rng(2);
  std::vector<uint8_t> two = frame;
  two.insert(two.end(), frame.begin(), frame.end());
  const auto out = testing::feed_split(codec, two, rng, 7);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].sequence, 0x1234u);
  EXPECT_EQ(out[0].accel[2], 9.75);
  EXPECT_EQ(codec.stats().counter_resets, 1u);  // the same counter twice is counted
  testing::expect_byte_accounting(codec);
}

TEST(XsensCodec, ReadsFixedPointAndDoublePrecision) {
  // Acceleration as fp1220 (id 0x4021) and rate of turn as float64 (id 0x8023).
  std::vector<uint8_t> p = {0x40, 0x21, 12};
  for (int32_t v : {1 << 20, -(3 << 19), 5}) {
    for (int i = 3; i >= 0; --i)
      p.push_back(static_cast<uint8_t>(static_cast<uint32_t>(v) >> (8 * i)));
  }
  p.insert(p.end(), {0x80, 0x23, 24});
  for (double d : {0.1, -2.5, 1e-3}) {
    uint64_t b;
    std::memcpy(&b, &d, 8);
    for (int i = 7; i >= 0; --i) p.push_back(static_cast<uint8_t>(b >> (8 * i)));
  }
  XsensPacket pk;
  ASSERT_TRUE(parse_mtdata2(p, pk));
  EXPECT_EQ((*pk.acceleration)[0], 1.0);
  EXPECT_EQ((*pk.acceleration)[1], -1.5);
  EXPECT_EQ((*pk.acceleration)[2], 5.0 / 1048576.0);
  EXPECT_EQ((*pk.rate_of_turn)[0], 0.1);
  EXPECT_EQ((*pk.rate_of_turn)[1], -2.5);
  // A size that does not fit the precision is malformed.
  p[2] = 11;
  EXPECT_FALSE(parse_mtdata2(p, pk));

  // Fixed point 16.32 (id 0x4022): each value a big-endian 32-bit fraction, then a big-endian
  // signed 16-bit integer part (found in review, 2026-11-27: untested; the two swapped passed).
  // -1.5 is integer -2 and fraction 0.5; 9.80665 is 9 and 0.80665 * 2^32 (rounded).
  std::vector<uint8_t> q = {0x40, 0x22, 18};
  const auto fp1632 = [&](uint32_t fraction, int16_t whole) {
    for (int i = 3; i >= 0; --i) q.push_back(static_cast<uint8_t>(fraction >> (8 * i)));
    q.push_back(static_cast<uint8_t>(static_cast<uint16_t>(whole) >> 8));
    q.push_back(static_cast<uint8_t>(whole));
  };
  const auto g_fraction = static_cast<uint32_t>(std::llround(0.80665 * 4294967296.0));
  fp1632(0x80000000u, -2);
  fp1632(g_fraction, 9);
  fp1632(1u, 300);
  XsensPacket fixed;
  ASSERT_TRUE(parse_mtdata2(q, fixed));
  EXPECT_EQ((*fixed.acceleration)[0], -1.5);
  EXPECT_EQ((*fixed.acceleration)[1], 9.0 + g_fraction / 4294967296.0);
  EXPECT_NEAR((*fixed.acceleration)[1], 9.80665, 1e-9);
  EXPECT_EQ((*fixed.acceleration)[2], 300.0 + 1.0 / 4294967296.0);
}

}  // namespace
}  // namespace imukit::drivers
