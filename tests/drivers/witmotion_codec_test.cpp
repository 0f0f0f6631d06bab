#include "imukit/drivers/witmotion_codec.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"
#include "imukit/core/units.hpp"

#include <cmath>
#include <numbers>
#include <set>

#include "test_util.hpp"

namespace imukit::drivers {
namespace {

// Groups of 0x51..0x54 frames; sample i has accel x raw = i, gyro z raw = -i, T = 2512 (25.12 C).
struct WitmotionStream {
  std::vector<uint8_t> bytes;
  std::vector<std::size_t> frame_start;  // 4 frames per sample
};

WitmotionStream make_witmotion_stream(int n) {
  WitmotionStream s;
  for (int i = 0; i < n; ++i) {
    const int16_t acc[4] = {static_cast<int16_t>(i), -2048, 2048, 2512};
    const int16_t gyr[4] = {100, 0, static_cast<int16_t>(-i), 0};
    const int16_t ang[4] = {16384, -8192, 0, 0};
    const int16_t mag[4] = {300, -200, 100, 0};
    for (const auto& f : {witmotion_frame(0x51, acc), witmotion_frame(0x52, gyr),
                          witmotion_frame(0x53, ang), witmotion_frame(0x54, mag)}) {
      s.frame_start.push_back(s.bytes.size());
      s.bytes.insert(s.bytes.end(), f.begin(), f.end());
    }
  }
  return s;
}

// Feeds all of `bytes` at once, as a file replay reads them, and finishes the stream.
std::vector<Sample> decode_all(WitmotionCodec& codec, const std::vector<uint8_t>& bytes,
                               TimeNs host_time) {
  std::vector<Sample> out;
  codec.feed(bytes, host_time, out);
  codec.finish(host_time, out);
  return out;
}

TEST(WitmotionCodec, FrameChecksumMatchesTheManual) {
  // 55 51 | 4 values | SUM = low byte of the sum of the first 10 bytes.
  const int16_t v[4] = {0x0102, 0x0304, -1, 0};
  const auto f = witmotion_frame(0x51, v);
  ASSERT_EQ(f.size(), 11u);
  EXPECT_EQ(f, (std::vector<uint8_t>{
                   0x55, 0x51, 0x02, 0x01, 0x04, 0x03, 0xFF, 0xFF, 0x00, 0x00,
                   static_cast<uint8_t>(0x55 + 0x51 + 0x02 + 0x01 + 0x04 + 0x03 + 0xFF + 0xFF)}));
}

TEST(WitmotionCodec, ScalesEveryFrameTypeAndStampsHostTime) {
  const WitmotionStream st = make_witmotion_stream(3);
  WitmotionCodec codec;
  const std::vector<Sample> out = decode_all(codec, st.bytes, 5000);
  ASSERT_EQ(out.size(), 3u);
  const double g = 9.80665;
  for (int i = 0; i < 3; ++i) {
    const Sample& s = out[i];
    EXPECT_EQ(s.sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(s.host_time, 5000);
    EXPECT_FALSE(s.has_device_time);
    EXPECT_DOUBLE_EQ(s.accel[0], i / 32768.0 * 16 * g);
    EXPECT_DOUBLE_EQ(s.accel[1], -g);  // -2048/32768 * 16 g
    EXPECT_DOUBLE_EQ(s.temperature_c, 25.12);
    EXPECT_DOUBLE_EQ(s.gyro[0], 100 / 32768.0 * 2000 * std::numbers::pi / 180);
    EXPECT_DOUBLE_EQ(s.gyro[2], -i / 32768.0 * 2000 * std::numbers::pi / 180);
    EXPECT_DOUBLE_EQ(s.angles_rad[0], std::numbers::pi / 2);  // 16384/32768 * 180 deg
    EXPECT_DOUBLE_EQ(s.angles_rad[1], -std::numbers::pi / 4);
    EXPECT_EQ(s.mag[0], 300.0);
    EXPECT_EQ(s.channels, kHasAccel | kHasGyro | kHasMag | kHasTemperature | kHasAngles);
  }
}

TEST(WitmotionCodec, SplitAtRandomBoundariesChangesNothing) {
  const WitmotionStream st = make_witmotion_stream(500);
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    Rng rng(seed);
    WitmotionCodec codec;
    const auto out = testing::feed_split(codec, st.bytes, rng, 1 + 13 * seed);
    ASSERT_EQ(out.size(), 500u);
    for (int i = 0; i < 500; ++i) EXPECT_DOUBLE_EQ(out[i].accel[0], i / 32768.0 * 16 * 9.80665);
    EXPECT_EQ(codec.stats().samples_dropped, 0u);
    testing::expect_byte_accounting(codec);
  }
}

TEST(WitmotionCodec, EveryCorruptedSampleIsCountedAndNoneIsMixedUp) {
  WitmotionStream st = make_witmotion_stream(1000);
  Rng rng(3);
  std::set<int> hit_samples;
  // One corrupted byte in 120 frames of distinct samples (any of its 4 frames), not the first
  // sample (whose complete group teaches the codec what a sample holds).
  while (hit_samples.size() < 120) hit_samples.insert(1 + static_cast<int>(rng.uniform_index(999)));
  for (int i : hit_samples) {
    const std::size_t frame = st.frame_start[4 * i + rng.uniform_index(4)];
    st.bytes[frame + rng.uniform_index(11)] ^= static_cast<uint8_t>(1 + rng.uniform_index(255));
  }
  WitmotionCodec codec;
  const auto out = testing::feed_split(codec, st.bytes, rng, 50);
  const CodecStats& s = codec.stats();
  EXPECT_EQ(s.samples_decoded + s.samples_dropped, 1000u);
  EXPECT_EQ(out.size(), 1000u - hit_samples.size());
  testing::expect_byte_accounting(codec);
  // Each surviving sample is one of the originals, whole: accel x and gyro z come from the same i.
  for (const Sample& x : out) {
    const long i = std::lround(x.accel[0] / (16 * 9.80665) * 32768.0);
    EXPECT_FALSE(hit_samples.count(static_cast<int>(i))) << i;
    EXPECT_NEAR(x.gyro[2], -i / 32768.0 * 2000 * std::numbers::pi / 180, 1e-12);
  }
}

// Corrupts frame f of the stream (its checksum byte).
void corrupt(WitmotionStream& st, std::size_t f) { st.bytes[st.frame_start[f] + 10] ^= 0x5A; }
// Removes frames [first, last) of the stream.
std::vector<uint8_t> without(const WitmotionStream& st, std::size_t first, std::size_t last) {
  std::vector<uint8_t> b(st.bytes.begin(),
                         st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[first]));
  const std::size_t end = last < st.frame_start.size() ? st.frame_start[last] : st.bytes.size();
  b.insert(b.end(), st.bytes.begin() + static_cast<std::ptrdiff_t>(end), st.bytes.end());
  return b;
}

// Found in review. (a) The group whose last frame (0x54) was damaged looked complete to the
// learning of what a group holds, so later groups without 0x54 were emitted half filled instead
// of counted as dropped. (b) Two lost accel frames in a row counted one dropped sample. (c) The
// header bytes inside one damaged frame each counted another corrupt frame.
TEST(WitmotionCodec, LearnsFromACleanGroupOnlyAndCountsEveryLossOnce) {
  {  // (a): sample 0's 0x54 damaged, sample 5 lacks its 0x54 too.
    WitmotionStream st = make_witmotion_stream(10);
    corrupt(st, 3);
    corrupt(st, 4 * 5 + 3);
    WitmotionCodec codec;
    const std::vector<Sample> out = decode_all(codec, st.bytes, 0);
    EXPECT_EQ(out.size(), 8u);
    EXPECT_EQ(codec.stats().samples_dropped, 2u);
    for (const Sample& x : out) EXPECT_TRUE(x.channels & kHasMag);
    testing::expect_byte_accounting(codec);
  }
  {  // (b): the accel frames of samples 3 and 4 lost.
    const WitmotionStream st = make_witmotion_stream(10);
    std::vector<uint8_t> b = without(st, 4 * 4, 4 * 4 + 1);
    WitmotionStream cut = st;
    cut.bytes = b;
    cut.frame_start.clear();
    for (std::size_t i = 0; i < st.frame_start.size() - 1; ++i) cut.frame_start.push_back(11 * i);
    b = without(cut, 4 * 3, 4 * 3 + 1);
    WitmotionCodec codec;
    const std::vector<Sample> out = decode_all(codec, b, 0);
    EXPECT_EQ(out.size(), 8u);
    EXPECT_EQ(codec.stats().samples_dropped, 2u);
    testing::expect_byte_accounting(codec);
  }
  {  // (c): one frame whose values are full of header bytes (0x5555) and whose checksum fails.
    std::vector<uint8_t> b = make_witmotion_stream(2).bytes;
    const int16_t v[4] = {0x5555, 0x5555, 0x5555, 0x5555};
    std::vector<uint8_t> bad = witmotion_frame(0x52, v);
    bad[10] ^= 0x01;
    b.insert(b.begin() + 4 * 11 + 11, bad.begin(), bad.end());  // after sample 1's accel frame
    WitmotionCodec codec;
    const std::vector<Sample> out = decode_all(codec, b, 0);
    EXPECT_EQ(codec.stats().frames_corrupt, 1u);
    testing::expect_byte_accounting(codec);
  }
}

// Found in review (2026-11-26, fifth round): a stretch of damaged frames from inside one group
// into the next (its acceleration frame among them) left the next group's later frames looking
// like the rest of the first: sample 5 came out with the angular rate of sample 6. Stretches:
// samples 5 (0x52-0x54) and 6 (0x51); 10 (0x53, 0x54) and 11 (0x51, 0x52); 14 (0x52-0x54), all
// of 15 and 16 (0x51); then, 3 apart, random stretches of 1 to 9 frames.
TEST(WitmotionCodec, ADamagedStretchAcrossGroupsMixesNoSamplesAndCountsEachOnce) {
  const int n = 2000;
  WitmotionStream st = make_witmotion_stream(n);
  std::set<int> hit;
  const auto damage = [&](int first_frame, int frames) {
    for (int f = first_frame; f < first_frame + frames; ++f) {
      corrupt(st, static_cast<std::size_t>(f));
      hit.insert(f / 4);
    }
  };
  damage(4 * 5 + 1, 4);
  damage(4 * 10 + 2, 4);
  damage(4 * 14 + 1, 8);
  Rng rng(11);
  for (int sample = 20; sample < n - 4;) {
    const int frames = 1 + static_cast<int>(rng.uniform_index(9));
    damage(4 * sample + static_cast<int>(rng.uniform_index(4)), frames);
    sample += 3 + (frames + 3) / 4;
  }
  // Damage on the line that loses no frame, or pieces of frames, made from the end back (each
  // shifts the bytes after it). The review of the fix: counted by their bytes, a stray byte, or
  // a burst of 11, dropped a good sample, and a chunk lost in transit whose pieces kept 9 bytes
  // joined two groups; counted by frame starts (a header and a type), neither does.
  // One stray byte before each of sample 19's 0x52, 0x53 and 0x54 frames.
  for (const std::size_t f : {4 * 19 + 3, 4 * 19 + 2, 4 * 19 + 1})
    st.bytes.insert(st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[f]), 0x00);
  // A chunk lost from inside sample 17's 0x54 (its first 4 bytes kept) to inside sample 18's
  // 0x53 (its last 5 kept): both samples lost.
  st.bytes.erase(st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[4 * 17 + 3] + 4),
                 st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[4 * 18 + 2] + 6));
  hit.insert({17, 18});
  // A burst of 11 noise bytes before sample 13's 0x53.
  st.bytes.insert(st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[4 * 13 + 2]), 11,
                  0x00);
  WitmotionCodec codec;
  const auto out = testing::feed_split(codec, st.bytes, rng, 50);
  const CodecStats& s = codec.stats();
  EXPECT_EQ(out.size(), static_cast<std::size_t>(n) - hit.size());
  EXPECT_EQ(s.samples_dropped, hit.size());
  testing::expect_byte_accounting(codec);
  for (const Sample& x : out) {
    const long i = std::lround(x.accel[0] / (16 * 9.80665) * 32768.0);
    EXPECT_FALSE(hit.count(static_cast<int>(i))) << i;
    EXPECT_NEAR(x.gyro[2], -i / 32768.0 * 2000 * std::numbers::pi / 180, 1e-12) << i;
  }
}

// The review of the fix above: a damaged frame whose payload holds 55 5x (a roll of 0x5355, 117
// degrees) counted two frame starts, ended its group and dropped the good sample after it too.
// A start inside the frame of the one before is payload.
TEST(WitmotionCodec, AHeaderInsideADamagedFramesPayloadIsNoFrameStart) {
  WitmotionStream st = make_witmotion_stream(100);
  const int16_t angles[4] = {0x5355, -8192, 0, 0};
  std::vector<uint8_t> frame = witmotion_frame(0x53, angles);
  frame[10] ^= 0x01;  // its checksum damaged
  std::copy(frame.begin(), frame.end(),
            st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[4 * 50 + 2]));
  WitmotionCodec codec;
  const std::vector<Sample> out = decode_all(codec, st.bytes, 0);
  EXPECT_EQ(out.size(), 99u);
  EXPECT_EQ(codec.stats().samples_dropped, 1u);
  testing::expect_byte_accounting(codec);
}

// Samples all of whose frames arrive damaged leave no frame to show them: the stretch of
// rejected bytes does (a whole group's worth per sample), and corrupt frames count frames, not
// stretches. Sample 10: its 4 frames bad; samples 30 and 31: all 8 frames bad; sample 50: its
// gyroscope frame bad.
TEST(WitmotionCodec, WhollyDamagedSamplesAreDroppedAndEveryBadFrameCounted) {
  WitmotionStream st = make_witmotion_stream(100);
  for (int sample : {10, 30, 31}) {
    for (int k = 0; k < 4; ++k) st.bytes[st.frame_start[4 * sample + k] + 10] ^= 1;
  }
  st.bytes[st.frame_start[4 * 50 + 1] + 10] ^= 1;
  WitmotionCodec codec;
  Rng rng(4);
  const auto out = testing::feed_split(codec, st.bytes, rng, 30);
  const CodecStats& s = codec.stats();
  EXPECT_EQ(out.size(), 96u);
  EXPECT_EQ(s.samples_decoded, 96u);
  EXPECT_EQ(s.samples_dropped, 4u);
  EXPECT_EQ(s.frames_corrupt, 13u);
  EXPECT_EQ(s.frames_ok, 387u);
  for (const Sample& x : out) {
    const auto i = static_cast<int>(std::lround(x.accel[0] / (16 * kStandardGravity / 32768.0)));
    EXPECT_TRUE(i != 10 && i != 30 && i != 31 && i != 50) << i;
  }
  testing::expect_byte_accounting(codec);
}

TEST(WitmotionCodec, RateCommandsFollowTheRegisterMap) {
  EXPECT_EQ(witmotion_rate_commands(100),
            (std::vector<uint8_t>{0xFF, 0xAA, 0x69, 0x88, 0xB5, 0xFF, 0xAA, 0x03, 0x09, 0x00, 0xFF,
                                  0xAA, 0x00, 0x00, 0x00}));
  EXPECT_EQ(witmotion_rate_commands(200)[8], 0x0B);
  EXPECT_THROW(witmotion_rate_commands(150), Error);
  WitmotionCodec codec(WitmotionCodecOptions{10, 16, 2000});
  codec.start(0);
  EXPECT_EQ(codec.take_outgoing()[8], 0x06);
}

// A replay (decode only) given the rate the stream was made at: sample slot n is timed n / rate
// on a device clock of `rate` ticks per second, and a group lost whole leaves a gap in the
// sequence as a counter would. 10 groups at 100 Hz, group 4's 44 bytes zeroed: 9 samples with
// sequence (and ticks) 0, 1, 2, 3, 5, ..., 9 at 0, 10, 20, 30, 50, ..., 90 ms; 1 dropped. (The old
// codec had no such option and stamped receive times only.)
TEST(WitmotionCodec, AReplayWithARateIsTimedBySampleSlot) {
  WitmotionStream st = make_witmotion_stream(10);
  std::fill(st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[16]),
            st.bytes.begin() + static_cast<std::ptrdiff_t>(st.frame_start[20]), 0);
  WitmotionCodecOptions o;
  o.rate_hz = 100;
  o.send_commands = false;
  WitmotionCodec codec(o);
  codec.start(0);
  EXPECT_TRUE(codec.take_outgoing().empty());  // a replay gets no rate command
  const std::vector<Sample> out = decode_all(codec, st.bytes, 7000);
  ASSERT_EQ(out.size(), 9u);
  EXPECT_EQ(codec.stats().samples_dropped, 1u);
  const std::vector<uint64_t> slots = {0, 1, 2, 3, 5, 6, 7, 8, 9};
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].sequence, slots[i]) << i;
    EXPECT_TRUE(out[i].has_device_time);
    EXPECT_EQ(out[i].device_ticks, slots[i]);
    EXPECT_EQ(out[i].tick_hz, 100.0);
    EXPECT_EQ(out[i].device_time, static_cast<TimeNs>(slots[i]) * 10'000'000) << i;
    EXPECT_EQ(out[i].host_time, 7000);
  }
  // Without a rate a replay's samples have receive times only; with commands, a rate is the
  // rate to set and times stay receive times (a live device's bytes arrive when made).
  for (const bool commands : {false, true}) {
    WitmotionCodecOptions plain;
    plain.rate_hz = commands ? 100 : 0;
    plain.send_commands = commands;
    WitmotionCodec c(plain);
    const std::vector<Sample> v = decode_all(c, make_witmotion_stream(3).bytes, 7000);
    ASSERT_EQ(v.size(), 3u);
    EXPECT_FALSE(v[2].has_device_time);
    EXPECT_EQ(v[2].sequence, 2u);
  }
}

}  // namespace
}  // namespace imukit::drivers
