#include "imukit/drivers/playstation_codec.hpp"

#include "imukit/core/error.hpp"
#include "imukit/core/units.hpp"
#include "imukit/drivers/reader.hpp"
#include "imukit/drivers/transport.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <numbers>

namespace imukit::drivers {
namespace {

void put16(std::vector<uint8_t>& r, std::size_t at, int v) {
  r[at] = static_cast<uint8_t>(v & 0xFF);
  r[at + 1] = static_cast<uint8_t>((v >> 8) & 0xFF);
}

// A DualShock 4 USB calibration report (0x02, 37 bytes) with the values of a real pad
// (hid-playstation's USB layout: pitch+ pitch- yaw+ yaw- roll+ roll-).
std::vector<uint8_t> ds4_calibration() {
  std::vector<uint8_t> r(37, 0);
  r[0] = 0x02;
  put16(r, 1, -7);      // pitch bias
  put16(r, 3, 9);       // yaw bias
  put16(r, 5, -7);      // roll bias
  put16(r, 7, 8958);    // pitch+
  put16(r, 9, -8972);   // pitch-
  put16(r, 11, 8891);   // yaw+
  put16(r, 13, -8871);  // yaw-
  put16(r, 15, 8841);   // roll+
  put16(r, 17, -8856);  // roll-
  put16(r, 19, 540);    // speed+
  put16(r, 21, 540);    // speed-
  put16(r, 23, 8403);   // acc x+
  put16(r, 25, -8441);  // acc x-
  put16(r, 27, 8383);   // acc y+
  put16(r, 29, -8022);  // acc y-
  put16(r, 31, 7868);   // acc z+
  put16(r, 33, -8568);  // acc z-
  return r;
}

std::vector<uint8_t> ds4_report(int counter, int timestamp, const int gyro[3], const int accel[3]) {
  std::vector<uint8_t> r(64, 0);
  r[0] = 0x01;
  r[7] = static_cast<uint8_t>((counter & 0x3F) << 2);
  put16(r, 10, timestamp & 0xFFFF);
  for (int i = 0; i < 3; ++i) {
    put16(r, 13 + 2 * i, gyro[i]);
    put16(r, 19 + 2 * i, accel[i]);
  }
  return r;
}

TEST(PlaystationCodec, AppliesDualShock4CalibrationLikeTheKernel) {
  PlaystationCodec codec(PlaystationModel::kDualShock4);
  codec.on_feature_report(0x02, ds4_calibration());
  ASSERT_TRUE(codec.calibrated());
  // hid-playstation: gyro numer = speed_2x * 1024, denom = |plus - bias| + |minus - bias|, bias 0.
  EXPECT_EQ(codec.calibration().gyro[0].numer, 1080 * 1024);
  EXPECT_EQ(codec.calibration().gyro[0].denom, 8965 + 8965);
  EXPECT_EQ(codec.calibration().gyro[0].bias, 0);
  EXPECT_EQ(codec.calibration().gyro[1].denom, 8882 + 8880);
  // accel: range_2g = plus - minus, bias = plus - range_2g / 2 (C integer division).
  EXPECT_EQ(codec.calibration().accel[0].denom, 16844);
  EXPECT_EQ(codec.calibration().accel[0].bias, 8403 - 8422);
  EXPECT_EQ(codec.calibration().accel[1].bias, 8383 - 16405 / 2);
  const int gyro[3] = {1000, -2000, 0};
  const int accel[3] = {8192, 0, -8000};
  std::vector<Sample> out;
  codec.feed(ds4_report(5, 100, gyro, accel), 42, out);
  ASSERT_EQ(out.size(), 1u);
  const double deg = std::numbers::pi / 180;
  EXPECT_NEAR(out[0].gyro[0], 1000.0 * 1080 / 17930 * deg, 1e-12);
  EXPECT_NEAR(out[0].gyro[1], -2000.0 * 1080 / 17762 * deg, 1e-12);
  EXPECT_NEAR(out[0].accel[0], (8192.0 + 19) * 2 / 16844 * 9.80665, 1e-12);
  EXPECT_NEAR(out[0].accel[2], (-8000.0 - (7868 - 16436 / 2)) * 2 / 16436 * 9.80665, 1e-12);
  EXPECT_EQ(out[0].host_time, 42);
}

TEST(PlaystationCodec, UnwrapsTimestampAndCountsDroppedReports) {
  PlaystationCodec codec(PlaystationModel::kDualShock4);
  const int z[3] = {0, 0, 0};
  std::vector<Sample> out;
  int dropped = 0;
  int counter = 60;
  int ts = 60000;  // wraps at 65536 after a few reports
  for (int k = 0; k < 300; ++k) {
    const bool skip = k % 37 == 5;  // lose a report now and then
    if (!skip) codec.feed(ds4_report(counter, ts, z, z), k, out);
    dropped += skip;
    counter = (counter + 1) & 0x3F;
    ts = (ts + 750) & 0xFFFF;  // 4 ms in 16/3 us units
  }
  EXPECT_EQ(codec.stats().samples_dropped, static_cast<uint64_t>(dropped));
  EXPECT_EQ(out.size(), 300u - dropped);
  // Device time advances 4 ms per report (750 * 16/3 us), across the 16-bit wrap.
  const int64_t first = out.front().device_time;
  EXPECT_EQ(first, ticks_to_ns(60000 * 16, 3'000'000));
  EXPECT_EQ(out.back().device_time - first, 299 * 4'000'000);
  // Truncated or foreign reports are counted as corrupt.
  std::vector<uint8_t> bad = ds4_report(0, 0, z, z);
  bad.resize(40);
  codec.feed(bad, 0, out);
  bad = ds4_report(0, 0, z, z);
  bad[0] = 0x11;
  codec.feed(bad, 0, out);
  EXPECT_EQ(codec.stats().frames_corrupt, 2u);
}

TEST(PlaystationCodec, DualSenseLayoutAndCalibration) {
  std::vector<uint8_t> cal(41, 0);
  cal[0] = 0x05;
  put16(cal, 1, 2);      // pitch bias: in the sensitivity, not an offset
  put16(cal, 7, 8000);   // pitch+
  put16(cal, 9, -8000);  // pitch-
  put16(cal, 11, 8000);
  put16(cal, 13, -8000);
  put16(cal, 15, 8000);
  put16(cal, 17, -8000);
  put16(cal, 19, 500);
  put16(cal, 21, 500);
  put16(cal, 23, 8192);
  put16(cal, 25, -8192);
  put16(cal, 27, 8192);
  put16(cal, 29, -8192);
  put16(cal, 31, 8292);
  put16(cal, 33, -8092);
  PlaystationCodec codec(PlaystationModel::kDualSense);
  EXPECT_EQ(codec.feature_requests()[0].report_id, 0x05);
  codec.on_feature_report(0x05, cal);
  std::vector<uint8_t> r(64, 0);
  r[0] = 0x01;
  r[7] = 200;
  put16(r, 16, 1602);  // gyro x
  put16(r, 26, 100);   // accel z
  const uint32_t ts = 0xFFFFFFF0u;
  for (int i = 0; i < 4; ++i) r[28 + i] = static_cast<uint8_t>(ts >> (8 * i));
  std::vector<Sample> out;
  codec.feed(r, 0, out);
  ASSERT_EQ(out.size(), 1u);
  // 1602 * 1000 * 1024 / (|8000 - 2| + |-8000 - 2|) units of 1/1024 deg/s = 100.125 deg/s (the
  // bias as an offset with plus - minus, the kernel's rule before 2023, gave 100).
  EXPECT_NEAR(out[0].gyro[0], 100.125 * std::numbers::pi / 180, 1e-12);
  // accel z bias = 8292 - 16384 / 2 = 100: reads 0.
  EXPECT_NEAR(out[0].accel[2], 0.0, 1e-12);
  EXPECT_EQ(out[0].device_time, ticks_to_ns(0xFFFFFFF0LL, 3'000'000));
  EXPECT_THROW(
      parse_playstation_calibration(PlaystationModel::kDualSense, std::vector<uint8_t>(20, 0x05)),
      imukit::Error);
}

// A pad whose calibration report fails `failures` times (as hidapi's get_feature_report does,
// or answers short), then gives it; then a few input reports and the end.
class FlakyPad : public ReportTransport {
 public:
  FlakyPad(int failures, bool short_reply) : failures_(failures), short_(short_reply) {}
  std::string describe() const override { return "flaky pad"; }
  std::vector<uint8_t> get_feature_report(uint8_t, std::size_t) override {
    ++asked;
    if (asked > failures_) return ds4_calibration();
    if (short_) return std::vector<uint8_t>(7, 0x02);  // a clone's short reply
    throw TransportError("hid 054c:05c4: get feature report 2: Broken pipe");
  }
  ReadResult read_report(std::span<uint8_t> buf, int) override {
    ReadResult r;
    r.host_time = 1'000'000 * (sent_ + 1);
    if (sent_ == 5) {
      r.end = true;
      r.end_reason = "unplugged";
      return r;
    }
    const int gyro[3] = {100, 0, 0}, accel[3] = {0, 0, 8192};
    const std::vector<uint8_t> rep = ds4_report(sent_, 188 * sent_, gyro, accel);
    std::copy(rep.begin(), rep.end(), buf.begin());
    r.size = rep.size();
    ++sent_;
    return r;
  }
  void write_report(std::span<const uint8_t>) override {}
  void send_feature_report(std::span<const uint8_t>) override {}
  int asked = 0;

 private:
  int failures_;
  bool short_;
  int sent_ = 0;
};

// hid-playstation asks for the calibration three times and then streams with the nominal
// scale; a single failure ended the stream before any report was read (review, 2026-11-27).
TEST(PlaystationCodec, AnUnreadableCalibrationIsAskedThriceThenTheNominalScaleStreams) {
  const std::atomic<bool> stop{false};
  for (const bool short_reply : {false, true}) {
    {
      FlakyPad pad(2, short_reply);  // the third attempt answers
      PlaystationCodec codec(PlaystationModel::kDualShock4);
      std::vector<Sample> out;
      DeviceReader::run(pad, codec, ReaderOptions{}, stop, out);
      EXPECT_EQ(pad.asked, 3);
      EXPECT_TRUE(codec.calibrated());
      EXPECT_EQ(codec.stats().feature_reports_failed, 0u);
      EXPECT_EQ(out.size(), 5u);
    }
    FlakyPad pad(3, short_reply);
    PlaystationCodec codec(PlaystationModel::kDualShock4);
    std::vector<Sample> out;
    const EndReason end = DeviceReader::run(pad, codec, ReaderOptions{}, stop, out);
    EXPECT_EQ(pad.asked, 3);
    EXPECT_FALSE(codec.calibrated());
    EXPECT_EQ(codec.stats().feature_reports_failed, 1u);
    EXPECT_EQ(end.message, "unplugged");
    ASSERT_EQ(out.size(), 5u) << short_reply;
    // The nominal scale: 8192 counts of 4 * 8192 / 32767 g each.
    EXPECT_NEAR(out[0].accel[2], 8192.0 * 4 / 32767 * kStandardGravity, 1e-9);
  }
}

TEST(PlaystationCodec, ZeroCalibrationFallsBackToNominalScale) {
  std::vector<uint8_t> cal(37, 0);
  cal[0] = 0x02;
  const PsCalibration c = parse_playstation_calibration(PlaystationModel::kDualShock4, cal);
  EXPECT_EQ(c.gyro[2].numer, 2048 * 1024);
  EXPECT_EQ(c.gyro[2].denom, 32767);
  EXPECT_EQ(c.accel[0].numer, 4 * 8192);
}

}  // namespace
}  // namespace imukit::drivers
