#include "imukit/drivers/text_codec.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"
#include "imukit/core/units.hpp"

#include <numbers>
#include <set>

#include "test_util.hpp"

namespace imukit::drivers {
namespace {

std::vector<uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

TEST(TextCodec, ReadsCsvAndWhitespaceWithStatedUnits) {
  TextCodec codec(
      text_codec_options({{"time_unit", "ms"}, {"accel_unit", "g"}, {"gyro_unit", "dps"}}));
  std::vector<Sample> out;
  codec.feed(bytes("time,ax,ay,az,gx,gy,gz\r\n10,0,0,1,90,0,-180\r\n  20  0.5 0 1 0 0 0\n"), 7,
             out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].device_time, 10'000'000);
  EXPECT_EQ(out[1].device_time, 20'000'000);
  EXPECT_DOUBLE_EQ(out[0].accel[2], 9.80665);
  EXPECT_DOUBLE_EQ(out[0].gyro[0], std::numbers::pi / 2);
  EXPECT_DOUBLE_EQ(out[0].gyro[2], -std::numbers::pi);
  EXPECT_DOUBLE_EQ(out[1].accel[0], 0.5 * 9.80665);
  EXPECT_EQ(out[1].sequence, 1u);
  EXPECT_EQ(codec.stats().frames_other, 1u);  // the header
  EXPECT_EQ(codec.stats().frames_corrupt, 0u);
  testing::expect_byte_accounting(codec);
}

// A serial port opened while the board streams starts inside a line: "45,..." (the tail of
// "12345,...") read as a sample at t = 45 (review, 2026-11-27). Where the transport may start
// mid-stream the first line is discarded, a dropped sample if it parses as one.
TEST(TextCodec, OnATransportThatMayStartMidStreamTheFirstLineIsNeverData) {
  const std::string stream =
      "45,0,0,9.8,0,0,0\n12346,0,0,9.8,0,0,0\n12347,0,0,9.8,0,0,0\n12348,0,0,9.8,0,0,0\n";
  for (const bool mid : {false, true}) {
    TextCodec codec(text_codec_options({{"time_unit", "ms"}}));
    codec.set_may_start_mid_stream(mid);
    std::vector<Sample> out;
    codec.feed(bytes(stream), 0, out);
    ASSERT_EQ(out.size(), mid ? 3u : 4u);
    EXPECT_EQ(out.front().device_time, mid ? 12'346'000'000 : 45'000'000);
    EXPECT_EQ(codec.stats().samples_dropped, mid ? 1u : 0u);
    EXPECT_EQ(codec.stats().bytes_discarded, mid ? 17u : 0u);
    EXPECT_EQ(codec.stats().frames_corrupt, 0u);
    testing::expect_byte_accounting(codec);
  }
  // A header cut or whole: discarded, no sample lost.
  TextCodec codec(text_codec_options({{"time_unit", "ms"}}));
  codec.set_may_start_mid_stream(true);
  std::vector<Sample> out;
  codec.feed(bytes("\r\nx,ay,az,gx,gy,gz\n1,0,0,9.8,0,0,0\n"), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(codec.stats().samples_dropped, 0u);
  testing::expect_byte_accounting(codec);
}

// Found in review (2026-11-27): a blank line before the header (a sketch's Serial.println())
// took the first line's place, so the header counted as a corrupt frame and a dropped sample;
// and times went through a double, 68 ns off at 1.7e9 s.
TEST(TextCodec, BlankLinesBeforeTheHeaderAndTimesToTheNanosecond) {
  TextCodec codec(text_codec_options({{"time_unit", "s"}}));
  std::vector<Sample> out;
  codec.feed(bytes("\r\n\nt,ax,ay,az,gx,gy,gz\r\n1700000000.1234567,0,0,1,0,0,0\r\n"
                   "1700000000.123456789,0,0,1,0,0,0\n"),
             0, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].device_time, 1'700'000'000'123'456'700);
  EXPECT_EQ(out[1].device_time, 1'700'000'000'123'456'789);
  EXPECT_EQ(codec.stats().frames_corrupt, 0u);
  EXPECT_EQ(codec.stats().samples_dropped, 0u);
  EXPECT_EQ(codec.stats().frames_other, 3u);  // two blank lines and the header
  testing::expect_byte_accounting(codec);
  TextCodec us(text_codec_options({{"time_unit", "us"}}));
  out.clear();
  us.feed(bytes("1700000000123456.7 0 0 1 0 0 0\n"), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_time, 1'700'000'000'123'456'700);
  // A time beyond int64 ns is a bad line, as before.
  out.clear();
  us.feed(bytes("1e30 0 0 1 0 0 0\n"), 0, out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(us.stats().frames_corrupt, 1u);
}

// Arduino's micros() wraps at 2^32 us (71.6 minutes): with time_bits=32 the device time runs
// on through the wrap instead of jumping back 4,295 s.
TEST(TextCodec, AWrappingTimeCounterIsUnwrapped) {
  TextCodec codec(text_codec_options({{"time_unit", "us"}, {"time_bits", "32"}}));
  std::string text;
  for (int64_t i = 0; i < 4; ++i)
    text += std::to_string((4294965296 + 1000 * i) % 4294967296) + ",0,0,1,0,0,0\n";
  text += "4294967296,0,0,1,0,0,0\n";  // not below 2^32: damaged
  text += "3000.5,0,0,1,0,0,0\n";      // not a whole count: damaged
  std::vector<Sample> out;
  codec.feed(bytes(text), 0, out);
  ASSERT_EQ(out.size(), 4u);
  for (int64_t i = 0; i < 4; ++i)
    EXPECT_EQ(out[i].device_time, (4294965296 + 1000 * i) * 1000) << i;
  EXPECT_EQ(codec.stats().frames_corrupt, 2u);
  EXPECT_THROW(text_codec_options({{"time_bits", "33"}}), Error);
  EXPECT_THROW(text_codec_options({{"time_bits", "-1"}}), Error);
  EXPECT_EQ(text_codec_options({{"time_bits", "0"}}).time_bits, 0u);
}

TEST(TextCodec, HasNoTimeSyncPoints) {
  TextCodec codec(text_codec_options({}));
  std::vector<Sample> out;
  codec.feed(bytes("10,0,0,1,0,0,0\n20,0,0,1,0,0,0\n"), 7, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_TRUE(static_cast<const Codec&>(codec).sync_points().empty());
}

// Review, 2026-11-27: the URI knew only mps2/g and rads/dps, where the column grammar says
// m/s^2, g, mg and rad/s, deg/s: one list (core's) for both now.
TEST(TextCodec, TakesTheColumnGrammarsUnitSpellings) {
  const TextCodecOptions a = text_codec_options({{"accel_unit", "m/s^2"}, {"gyro_unit", "deg/s"}});
  EXPECT_EQ(a.accel_scale, 1.0);
  EXPECT_EQ(a.gyro_scale, kRadPerDeg);
  const TextCodecOptions b = text_codec_options({{"accel_unit", "mg"}, {"gyro_unit", "rad/s"}});
  EXPECT_EQ(b.accel_scale, kStandardGravity * 1e-3);
  EXPECT_EQ(b.gyro_scale, 1.0);
}

TEST(TextCodec, RejectsBadUnitNames) {
  EXPECT_THROW(text_codec_options({{"time_unit", "min"}}), Error);
  EXPECT_THROW(text_codec_options({{"accel_unit", "G"}}), Error);
}

TEST(TextCodec, CountsEveryBrokenLineAndSurvivesSplits) {
  std::string text;
  std::set<int> broken;
  Rng rng(11);
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    std::string line = std::to_string(i) + ",0.1,0.2,9.8," + std::to_string(i % 17) + ",0,0.5\n";
    if (i > 0 && rng.uniform() < 0.05) {
      broken.insert(i);
      switch (rng.uniform_index(4)) {
        case 0:
          line = line.substr(0, line.size() / 2) + "\n";
          break;  // cut short
        case 1:
          line[1 + rng.uniform_index(line.size() - 2)] = 'x';
          break;  // garbage
        case 2:
          line.insert(line.size() - 1, ",7");
          break;  // extra field
        default:
          line = std::string(600, '9') + "\n";
          break;  // overlong
      }
    }
    text += line;
  }
  TextCodec codec(TextCodecOptions{.time_digits = 9});
  const auto out = testing::feed_split(codec, bytes(text), rng, 300);
  EXPECT_EQ(out.size(), static_cast<std::size_t>(n) - broken.size());
  EXPECT_EQ(codec.stats().samples_dropped, broken.size());
  EXPECT_EQ(codec.stats().frames_corrupt, broken.size());
  testing::expect_byte_accounting(codec);
  for (const Sample& s : out) {
    const auto i = static_cast<int>(s.device_time / 1'000'000'000);
    EXPECT_FALSE(broken.count(i));
    EXPECT_EQ(s.gyro[0], i % 17);
  }
}

// Found in review: the bytes of an overlong line were in no count until its newline came.
TEST(TextCodec, AnOverlongLineIsPendingUntilItsNewlineThenDiscarded) {
  TextCodec codec;
  std::vector<Sample> out;
  codec.feed(std::vector<uint8_t>(600, 'x'), 0, out);
  EXPECT_EQ(codec.bytes_pending(), 600u);
  testing::expect_byte_accounting(codec);
  codec.feed(bytes("\n1 2 3 4 5 6 7\n"), 1, out);
  testing::expect_byte_accounting(codec);
  EXPECT_EQ(codec.stats().bytes_discarded, 601u);
  EXPECT_EQ(codec.stats().frames_corrupt, 1u);
  EXPECT_EQ(out.size(), 1u);
}

TEST(TextCodec, AValueThatOverflowsItsUnitScaleIsDroppedAndCounted) {
  // 1e308 parses as finite; in g it is 9.8e308 m/s^2, which is +inf.
  TextCodec codec(text_codec_options({{"accel_unit", "g"}}));
  std::vector<Sample> out;
  codec.feed(bytes("1,0,0,1,0,0,0\n2,1e308,0,1,0,0,0\n3,0,0,1,0,0,0\n"), 5000, out);
  codec.finish(5000, out);
  ASSERT_EQ(out.size(), 2u);
  // Refused like a line that does not parse: no sequence number taken, so no counter gap counts
  // it a second time (found in review: "missing (counter gaps) 1" beside the codec's own 1).
  EXPECT_EQ(out[0].sequence, 0u);
  EXPECT_EQ(out[1].sequence, 1u);
  EXPECT_EQ(out[1].accel[2], kStandardGravity);
  EXPECT_EQ(codec.stats().frames_corrupt, 1u);
  EXPECT_EQ(codec.stats().samples_dropped, 1u);
  EXPECT_EQ(codec.stats().samples_decoded, 2u);
}

TEST(TextCodec, LastLineWithoutNewlineIsKept) {
  TextCodec codec;
  std::vector<Sample> out;
  codec.feed(bytes("1 2 3 4 5 6 7"), 4000, out);
  EXPECT_TRUE(out.empty());
  codec.finish(4000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].host_time, 4000);  // when its bytes came (it was stamped 0, 1970)
  EXPECT_EQ(out[0].gyro[2], 7.0);
  EXPECT_EQ(out[0].device_time, 1'000'000);  // default unit ms
}

}  // namespace
}  // namespace imukit::drivers
