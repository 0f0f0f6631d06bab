#include "imukit/drivers/mock_device.hpp"

#include <gtest/gtest.h>

#include "imukit/core/error.hpp"

#include <cmath>
#include <numbers>
#include <set>

#include "imukit/core/profile.hpp"
#include "imukit/core/so3.hpp"
#include "imukit/drivers/imukit_codec.hpp"
#include "imukit/drivers/reader.hpp"
#include "imukit/drivers/sources.hpp"
#include "imukit/drivers/uri.hpp"
#include "support/test_data.hpp"

namespace imukit::drivers {
namespace {

struct MockRun {
  std::vector<Sample> samples;
  EndReason end;
  CodecStats stats;
  MockDevice* mock = nullptr;
  OpenedDevice dev;
};

// Opens the URI and reads until the mock disconnects.
MockRun run(const std::string& uri) {
  MockRun r;
  r.dev = open_device(uri);
  r.mock = dynamic_cast<MockDevice*>(r.dev.transport.get());
  std::atomic<bool> stop{false};
  r.end = DeviceReader::run(*r.dev.transport, *r.dev.codec, ReaderOptions{}, stop, r.samples);
  r.stats = r.dev.codec->stats();
  return r;
}

TEST(MockDevice, StaticDeviceReadsGravityInItsOrientation) {
  // Rolled 90 degrees about x: sensor +y points up... q = (cos 45, sin 45, 0, 0).
  const double h = std::sqrt(0.5);
  const MockRun r =
      run("mock:static?rate=200&clock=virtual&disconnect_after=400&quat=" + std::to_string(h) +
          ",0.70710678118654757,0,0");
  EXPECT_EQ(r.end.kind, EndKind::kEndOfStream);
  EXPECT_NE(r.end.message.find("disconnect"), std::string::npos);
  ASSERT_EQ(r.samples.size(), 400u);
  const double lsb = 16 * 9.80665 / 32768;  // quantisation step of the mock's accelerometer
  for (const Sample& s : r.samples) {
    EXPECT_NEAR(s.accel[0], 0.0, lsb);
    EXPECT_NEAR(s.accel[1], 9.80665, lsb);
    EXPECT_NEAR(s.accel[2], 0.0, lsb);
    EXPECT_EQ(s.gyro[0], 0.0);
    EXPECT_EQ(s.temperature_c, 25.0);
  }
  // Device times step by exactly 1/200 s (5000 ticks of the 1 MHz clock).
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    EXPECT_EQ(r.samples[i].device_time - r.samples[i - 1].device_time, 5'000'000);
    EXPECT_EQ(r.samples[i].sequence, i);
  }
  EXPECT_EQ(r.stats.samples_dropped, 0u);
}

TEST(MockDevice, VirtualTimeIsDeterministic) {
  const std::string uri =
      "mock:static?rate=400&clock=virtual&disconnect_after=800&jitter_us=300&drop=0.05&seed=9";
  const MockRun a = run(uri);
  const MockRun b = run(uri);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    EXPECT_EQ(a.samples[i].host_time, b.samples[i].host_time);
    EXPECT_EQ(a.samples[i].sequence, b.samples[i].sequence);
  }
  // Another seed draws other jitter: some arrival time differs.
  const MockRun c = run(
      "mock:static?rate=400&clock=virtual&disconnect_after=800&jitter_us=300&drop=0.05&seed=10");
  bool differs = a.samples.size() != c.samples.size();
  for (std::size_t i = 0; !differs && i < a.samples.size(); ++i)
    differs = a.samples[i].host_time != c.samples[i].host_time;
  EXPECT_TRUE(differs);
}

TEST(MockDevice, DroppedFramesAreExactlyTheDroppedSamples) {
  const MockRun r = run("mock:static?rate=400&clock=virtual&disconnect_after=4000&drop=0.1&seed=3");
  EXPECT_GT(r.mock->frames_dropped(), 20u);
  EXPECT_EQ(r.stats.samples_dropped, r.mock->samples_in_dropped_frames());
  EXPECT_EQ(r.stats.samples_decoded + r.stats.samples_dropped, 4000u);
}

TEST(MockDevice, BitFlipsAreCaughtAndEveryLostSampleCounted) {
  const MockRun r =
      run("mock:static?rate=400&clock=virtual&disconnect_after=4000&flip=0.002&seed=5");
  EXPECT_GT(r.mock->bytes_flipped(), 50u);
  EXPECT_GT(r.stats.frames_corrupt, 10u);
  // Unless the very last block was hit (then nothing after it can show the gap).
  EXPECT_GE(r.stats.samples_decoded + r.stats.samples_dropped, 4000u - 8u);
  EXPECT_LE(r.stats.samples_decoded + r.stats.samples_dropped, 4000u);
  const double lsb = 16 * 9.80665 / 32768;
  for (const Sample& s : r.samples)
    EXPECT_NEAR(s.accel[2], 9.80665, lsb);  // nothing corrupt got through
}

TEST(MockDevice, DeviceClockDriftShowsAgainstHostTime) {
  const MockRun r =
      run("mock:static?rate=100&clock=virtual&disconnect_after=2000&drift_ppm=250&latency_us=1500");
  ASSERT_EQ(r.samples.size(), 2000u);
  // Over the run the device clock gains 250 ppm on the host's: device span = host span * (1
  // + 2.5e-4). Host times are block arrival times, so compare the first and last samples of whole
  // blocks.
  const Sample& a = r.samples[7];
  const Sample& b = r.samples[1999];
  const double device = static_cast<double>(b.device_time - a.device_time);
  const double host = static_cast<double>(b.host_time - a.host_time);
  EXPECT_NEAR(device / host, 1.0 + 250e-6, 2e-6);
  // Device times are the device's own: exactly 1/100 s of its ticks apart.
  EXPECT_EQ(r.samples[1].device_time - r.samples[0].device_time, 10'000'000);
}

TEST(MockDevice, LatencyAndJitterDelayArrivalsWithinTheirBounds) {
  const MockRun r =
      run("mock:static?rate=400&clock=virtual&disconnect_after=2000&latency_us=2000&jitter_us=500&"
          "seed=2");
  ASSERT_EQ(r.samples.size(), 2000u);
  // A block leaves when its last sample is due; it arrives latency + U(0, jitter) later. The
  // device clock has no drift here, so host - (epoch + device time) of each block's last sample
  // is that delay (to the 1 us tick).
  const TimeNs epoch = MockOptions{}.epoch;
  TimeNs lo = INT64_MAX, hi = INT64_MIN;
  for (std::size_t i = 7; i < r.samples.size(); i += 8) {
    const TimeNs delay = r.samples[i].host_time - (epoch + r.samples[i].device_time);
    lo = std::min(lo, delay);
    hi = std::max(hi, delay);
  }
  EXPECT_GE(lo, 2'000'000 - 1'000);
  EXPECT_LE(hi, 2'500'000 + 1'000);
  EXPECT_GT(hi - lo, 400'000);  // 250 blocks spread over most of the jitter range
}

TEST(MockDevice, StallHoldsBytesBackThenDeliversThemAll) {
  const MockRun r =
      run("mock:static?rate=400&clock=virtual&disconnect_after=1200&stall_ms=300&stall_at_s=1");
  ASSERT_EQ(r.samples.size(), 1200u);
  TimeNs max_gap = 0;
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    max_gap = std::max(max_gap, r.samples[i].host_time - r.samples[i - 1].host_time);
  }
  EXPECT_GE(max_gap, 280'000'000);
  EXPECT_EQ(r.stats.samples_dropped, 0u);
}

TEST(MockDevice, ProfileNoiseReachesTheSamples) {
  imukit::testing::TempDir dir;
  DeviceProfile p;
  SensorProfile acc;
  acc.noise = NoiseEstimate{};
  acc.noise->noise_density = Eigen::Vector3d(0.002, 0.002, 0.002);  // m/s^2/sqrt(Hz)
  p.accelerometer = acc;
  const std::string path = (dir / "p.json").string();
  write_profile(path, p);
  const MockRun r =
      run("mock:static?rate=400&clock=virtual&disconnect_after=8000&seed=4&profile=" + path);
  ASSERT_EQ(r.samples.size(), 8000u);
  double sum = 0, sum2 = 0;
  for (const Sample& s : r.samples) {
    sum += s.accel[0];
    sum2 += s.accel[0] * s.accel[0];
  }
  const double mean = sum / 8000, sd = std::sqrt(sum2 / 8000 - mean * mean);
  // sigma = N sqrt(rate) = 0.04 m/s^2 (plus quantisation, lsb^2/12: negligible); 8000 samples
  // give the sample sd within 2.5 % at 3 sigma.
  EXPECT_NEAR(sd, 0.002 * std::sqrt(400.0), 0.04 * 0.03);
  EXPECT_NEAR(mean, 0.0, 4 * 0.04 / std::sqrt(8000.0));
}

TEST(MockDevice, PosesRotateBetweenSixFacesWithConsistentGyro) {
  PosesSource src(PosesSource::six_faces(), 1.0, 0.5);
  // Integrate the true gyro over each move: the rotation reached matches the next pose.
  const int rate = 2000;
  for (int k = 0; k < 5; ++k) {
    Eigen::Quaterniond q = PosesSource::six_faces()[k];
    const double t0 = k * 1.5 + 1.0;
    for (int i = 0; i < rate / 2; ++i) {
      const TimeNs t = from_seconds(t0 + (i + 0.5) / rate);
      Eigen::Matrix3Xd w;
      src.evaluate(std::span<const TimeNs>(&t, 1), nullptr, &w);
      q = q * so3_exp(w.col(0) / rate);  // body-frame rate: right multiplication
    }
    EXPECT_LT(angular_distance(q, PosesSource::six_faces()[k + 1]), 1e-5) << "move " << k;
  }
  // Held poses: the named axis points up.
  int held = -2;
  src.orientation(1.5 * 3 + 0.5, &held);
  EXPECT_EQ(held, 3);
  const TimeNs t = from_seconds(1.5 * 3 + 0.5);
  Eigen::Matrix3Xd f;
  src.evaluate(std::span<const TimeNs>(&t, 1), &f, nullptr);
  EXPECT_NEAR(f(2, 0), -9.80665, 1e-12);  // pose 3 is -z up
}

// Every sample taken while the pose source holds a pose reads gravity in that pose's sensor axes
// (to one LSB of the +-16 g range); `also(sample, pose)` is called for each. The device clock
// counts from the mock's creation, the source's time zero (no drift).
template <class Also>
void expect_held_samples_read_gravity(const MockRun& r, const PosesSource& src, Also also) {
  const double lsb = 16 * 9.80665 / 32768;
  for (const Sample& s : r.samples) {
    int held = -1;
    const Eigen::Quaterniond q = src.orientation(to_seconds(s.device_time), &held);
    if (held < 0) continue;
    const Eigen::Vector3d f = q.conjugate() * Eigen::Vector3d(0, 0, 9.80665);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.accel[k], f[k], lsb);
    also(s, held);
  }
}

TEST(MockDevice, PosesUriHoldsEachFaceUp) {
  // 6 holds of 0.5 s and 5 moves of 0.25 s: 4.25 s at 200 Hz.
  const MockRun r =
      run("mock:poses?rate=200&hold_s=0.5&move_s=0.25&init_s=0&clock=virtual&disconnect_after=840");
  ASSERT_EQ(r.samples.size(), 840u);
  int checked = 0;
  expect_held_samples_read_gravity(r, PosesSource(PosesSource::six_faces(), 0.5, 0.25),
                                   [&](const Sample& s, int) {
                                     for (int k = 0; k < 3; ++k) EXPECT_EQ(s.gyro[k], 0.0);
                                     ++checked;
                                   });
  EXPECT_GT(checked, 500);
}

TEST(MockDevice, TiltTourVisitsEveryCubeDirectionByTilts) {
  const auto poses = PosesSource::tilt_tour(26);
  ASSERT_EQ(poses.size(), 26u);
  EXPECT_LT(angular_distance(poses.front(), Eigen::Quaterniond::Identity()), 1e-15);
  std::vector<Eigen::Vector3d> ups;
  Eigen::Vector3d axis_reach = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    // The sensor direction pointing up, R_world_sensor^T z: a face, edge or corner direction.
    const Eigen::Vector3d up = poses[k].conjugate() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d scaled = up / up.cwiseAbs().maxCoeff();
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(scaled[i], std::round(scaled[i]), 1e-12) << "pose " << k;
    for (const auto& seen : ups)
      EXPECT_LT(seen.dot(up), std::cos(30 * std::numbers::pi / 180)) << "pose " << k;
    ups.push_back(up);
    if (k == 0) continue;
    // A tilt: the relative rotation's axis (sensor frame) is perpendicular to both ups, and
    // its angle is the angle between them (35..90 degrees between neighbours of the cube).
    const Eigen::AngleAxisd rel(poses[k - 1].conjugate() * poses[k]);
    const double angle = std::acos(std::clamp(ups[k - 1].dot(up), -1.0, 1.0));
    EXPECT_NEAR(rel.angle(), angle, 1e-12) << "pose " << k;
    EXPECT_GT(angle, 35 * std::numbers::pi / 180 - 1e-9) << "pose " << k;
    EXPECT_LE(angle, std::numbers::pi / 2 + 1e-9) << "pose " << k;
    EXPECT_NEAR(rel.axis().dot(up), 0.0, 1e-12);
    EXPECT_NEAR(rel.axis().dot(ups[k - 1]), 0.0, 1e-12);
    axis_reach = axis_reach.cwiseMax(rel.axis().cwiseAbs());
  }
  // Rotations about every sensor axis: a gyroscope calibration needs all three excited.
  EXPECT_GT(axis_reach.minCoeff(), 0.99);
  // A shorter tour is the start of the long one.
  const auto nine = PosesSource::tilt_tour(9);
  for (std::size_t k = 0; k < nine.size(); ++k)
    EXPECT_LT(angular_distance(nine[k], poses[k]), 1e-15);
}

TEST(MockDevice, PosesKeySelectsTheTiltTour) {
  // 9 holds of 0.5 s and 8 moves of 0.25 s at 200 Hz: 1300 samples; the held directions follow
  // the tour.
  const MockRun r =
      run("mock:poses?rate=200&hold_s=0.5&move_s=0.25&init_s=0&poses=9&clock=virtual&"
          "disconnect_after=1300");
  ASSERT_EQ(r.samples.size(), 1300u);
  std::set<int> seen;
  expect_held_samples_read_gravity(r, PosesSource(PosesSource::tilt_tour(9), 0.5, 0.25),
                                   [&](const Sample&, int held) { seen.insert(held); });
  EXPECT_EQ(seen.size(), 9u);
  EXPECT_THROW(open_device("mock:poses?poses=27"), Error);
  EXPECT_THROW(open_device("mock:poses?poses=0"), Error);
}

TEST(MockDevice, TruthHandleHoldsTheDrawnTurnOnBias) {
  // A profile with only a turn-on bias spread: the static gyro reads the drawn bias plus
  // quantisation noise, so its mean over 4000 samples lands within a quarter LSB of the truth.
  const imukit::testing::TempDir dir;
  const std::string path = (dir / "turn_on_only.json").string();
  DeviceProfile p;
  p.gyroscope = GyroscopeProfile{};
  TurnOnBias tob;
  tob.mean = Eigen::Vector3d(0.01, -0.02, 0.03);
  tob.spread = Eigen::Vector3d(0.05, 0.05, 0.05);
  p.gyroscope->turn_on_bias = tob;
  write_profile(path, p);
  MockRun r =
      run("mock:static?rate=400&clock=virtual&disconnect_after=4000&seed=21&profile=" + path);
  ASSERT_EQ(r.samples.size(), 4000u);
  const auto truth = r.mock->truth();
  ASSERT_TRUE(truth->drawn);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Sample& s : r.samples)
    mean += Eigen::Vector3d(s.gyro[0], s.gyro[1], s.gyro[2]) / 4000.0;
  const double lsb = 2000 * std::numbers::pi / 180 / 32768;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(mean[k], truth->gyroscope_bias[k], 0.5 * lsb) << k;
  // A drawn bias, not the mean: the three draws are not all within 0.1 sigma of the mean.
  EXPECT_GT((truth->gyroscope_bias - tob.mean).cwiseAbs().maxCoeff(), 0.005);
  EXPECT_EQ(truth->accelerometer_bias, Eigen::Vector3d::Zero());
}

TEST(MockDevice, UriErrorsNameTheKey) {
  EXPECT_THROW(open_device("mock:static?drop=2"), Error);
  EXPECT_THROW(open_device("mock:static?quat=1,0,0"), Error);
  EXPECT_THROW(open_device("mock:spinning"), Error);
  try {
    open_device("mock:static?clock=fast");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("clock=fast"), std::string::npos) << e.what();
  }
}

TEST(MockDevice, RefusedConfigurationEndsTheStreamWithTheDevicesReason) {
  // The mock accepts the asked rate; the codec is made to ask for another, unsupported one.
  OpenedDevice dev = open_device("mock:static?rate=400&clock=virtual");
  ImukitCodec codec(ImukitCodecOptions{true, 123.0, 8, 0, 0});
  std::atomic<bool> stop{false};
  std::vector<Sample> out;
  const EndReason end = DeviceReader::run(*dev.transport, codec, ReaderOptions{}, stop, out);
  EXPECT_EQ(end.kind, EndKind::kError);
  EXPECT_NE(end.message.find("refused Configure"), std::string::npos) << end.message;
  EXPECT_NE(end.message.find("rate not supported"), std::string::npos) << end.message;
  EXPECT_TRUE(out.empty());
}

// Found in review: the start-up repeated Configure and Start until the first sample block, every
// 0.5 s; at 10 Hz in blocks of 8 that block comes after 0.8 s, the device (streaming by then)
// refused the second Configure, and the stream ended with 0 samples. Now the start-up repeats
// only until the device acknowledges the Start.
TEST(MockDevice, SlowRatesStreamAlthoughTheFirstBlockComesAfterTheRetryTime) {
  for (const std::string rate : {"10", "12.5"}) {
    const MockRun r = run("mock:static?clock=virtual&disconnect_after=40&rate=" + rate);
    EXPECT_EQ(r.end.kind, EndKind::kEndOfStream) << rate << ": " << r.end.message;
    EXPECT_EQ(r.samples.size(), 40u) << rate;
    EXPECT_EQ(r.stats.samples_dropped, 0u) << rate;
    EXPECT_EQ(r.stats.device_errors, 0u) << rate;
  }
}

// Found in review: a device left streaming by an earlier session (the recorder exited, the
// firmware kept going) refused the next session's Configure (the session ended) and, without a
// rate, kept its own numbering, so every sample it had made before counted as dropped. The
// start-up now stops it first: the second session's samples are numbered from 0, none dropped.
// Found in review too: what the earlier stream sent after the last block read counted as
// dropped. With 20 ms of latency that is 80 ms of samples (that block's 20 ms on the link, then
// GetDeviceInfo up, DeviceInfo down and Stop up), 16 at 200 Hz, all before the Ack of our
// Start: discarded as not this session's (samples_before_start), and none on a fresh device.
TEST(MockDevice, ADeviceLeftStreamingIsStoppedAndStartedAgain) {
  OpenedDevice dev = open_device("mock:static?rate=200&clock=virtual&latency_us=20000");
  for (const double asked_rate : {200.0, 0.0}) {
    for (int session = 0; session < 2; ++session) {
      ImukitCodec codec(ImukitCodecOptions{true, asked_rate, 8, 0, 0});
      std::atomic<bool> stop{false};
      std::vector<Sample> out;
      ReaderOptions options;
      options.max_samples = 500;
      const EndReason end = DeviceReader::run(*dev.transport, codec, options, stop, out);
      // The reader stops at the limit; the device goes on streaming for the next session.
      EXPECT_NE(end.kind, EndKind::kError) << end.message;
      ASSERT_GE(out.size(), 500u) << asked_rate << " " << session;
      EXPECT_EQ(out.front().sequence, 0u) << asked_rate << " " << session;
      EXPECT_EQ(codec.stats().samples_dropped, 0u) << asked_rate << " " << session;
      const bool fresh_device = asked_rate == 200.0 && session == 0;
      EXPECT_EQ(codec.stats().samples_before_start, fresh_device ? 0u : 16u)
          << asked_rate << " " << session;
      for (std::size_t i = 1; i < out.size(); ++i)
        ASSERT_EQ(out[i].sequence, out[i - 1].sequence + 1) << i;
    }
  }
}

// Found in review: with commands=false (the codec only decodes) the mock waited for a Start
// that never came and no sample arrived. A device that cannot be commanded streams from
// power-on: its DeviceInfo first (the only other frame: no Ack, nobody asked), then samples from
// index 0, 5 ms apart at 200 Hz, none lost; the host sends nothing.
TEST(MockDevice, WithoutCommandsItStreamsFromPowerOn) {
  OpenedDevice dev =
      open_device("mock:static?rate=200&clock=virtual&commands=false&disconnect_after=400");
  const auto* mock = dynamic_cast<MockDevice*>(dev.transport.get());
  ASSERT_NE(mock, nullptr);
  // On its own thread with a deadline: a mock that never starts would never disconnect.
  DeviceReader reader(std::move(dev.transport), std::move(dev.codec));
  reader.start();
  ASSERT_TRUE(reader.wait(10'000)) << "no end of stream: the mock did not stream";
  EXPECT_EQ(reader.end_reason().kind, EndKind::kEndOfStream) << reader.end_reason().message;
  const std::vector<Sample> samples = reader.take();
  ASSERT_EQ(samples.size(), 400u);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(samples[i].sequence, i);
    EXPECT_EQ(samples[i].device_time, static_cast<TimeNs>(i) * 5'000'000);
    EXPECT_NEAR(samples[i].accel[2], 9.80665, 16 * 9.80665 / 32768);
  }
  EXPECT_EQ(reader.stats().samples_dropped, 0u);
  EXPECT_EQ(reader.stats().frames_other, 2u);           // the DeviceInfo and the Start's Ack
  EXPECT_EQ(mock->model().link_stats().frames_ok, 2u);  // its own GetDeviceInfo and Start
  // The Ack reaches the host: muted, it took frame 1 and every such stream showed a frame lost
  // (review, 2026-11-27).
  const auto& codec = dynamic_cast<const ImukitCodec&>(reader.codec());
  EXPECT_EQ(codec.frame_stats().sequence_gaps, 0u);
  EXPECT_EQ(codec.frame_stats().frames_missed, 0u);
}

TEST(MockDevice, RealTimeReaderDeliversAtTheRate) {
  OpenedDevice dev = open_device("mock:static?rate=200&clock=real");
  DeviceReader reader(std::move(dev.transport), std::move(dev.codec));
  reader.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  reader.stop();
  EXPECT_EQ(reader.end_reason().kind, EndKind::kStopped);
  // Time sync ran: at least the first ping (sent as soon as streaming started) came back, and
  // the device's receive tick lies between the host's send and receive times (same origin here:
  // the mock's device clock has no offset, only its own zero).
  const auto& sync = dynamic_cast<ImukitCodec&>(reader.codec()).sync_points();
  ASSERT_GE(sync.size(), 1u);
  EXPECT_LE(sync[0].host_send, sync[0].host_receive);
  EXPECT_LE(sync[0].device_rx, sync[0].device_tx);
  const auto s = reader.take();
  // 0.6 s at 200 Hz = 120 samples, less the start-up exchange and the last unfinished block.
  EXPECT_GT(s.size(), 60u);
  EXPECT_LT(s.size(), 130u);
}

}  // namespace
}  // namespace imukit::drivers
