#include "capture/clock_map.hpp"

#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>

#include "core/rng.hpp"

namespace imukit::capture {
namespace {

// A device at `rate_hz` whose 1 MHz clock runs `drift_ppm` fast, sending blocks of 8 samples
// that reach the host after `latency_s` plus exponential jitter (mean 0.25 ms, at most 1 ms).
struct Link {
  double rate_hz = 1000.0;
  double drift_ppm = 200.0;
  double latency_s = 0.002;
  double tick_hz = 1e6;
  TimeNs host_start = 1'700'000'000'000'000'000;
  uint64_t tick_start = 4'000'000'000ull;  // any offset; near the u32 wrap on purpose

  double true_time(int64_t sample) const { return static_cast<double>(sample) / rate_hz; }
  uint64_t ticks_at(double true_s) const {
    return tick_start +
           static_cast<uint64_t>(std::llround(true_s * (1 + drift_ppm * 1e-6) * tick_hz));
  }
  TimeNs host_at(double true_s) const { return host_start + from_seconds(true_s); }
  double jitter(Rng& rng) const { return std::min(1e-3, -0.25e-3 * std::log(1.0 - rng.uniform())); }
};

TEST(ClockMapper, EnvelopeMapsSamplesWithConstantOffsetDespiteDriftAndJitter) {
  const Link link;
  Rng rng(3);
  ClockMapper mapper(link.tick_hz);
  const int64_t samples = 60'000;  // 60 s at 1 kHz
  for (int64_t first = 0; first < samples; first += 8) {
    const double sent = link.true_time(first + 7);  // the block leaves after its last sample
    mapper.add_packet(link.ticks_at(link.true_time(first)),
                      link.host_at(sent + link.latency_s + link.jitter(rng)));
  }
  // Mapped time minus true sample time: constant (the unobservable latency plus the block's
  // 7 ms of buffering) to within 50 us over every sample.
  double lo = 1e9, hi = -1e9;
  for (int64_t i = 0; i < samples; i += 7) {
    const double err =
        to_seconds(mapper.map(link.ticks_at(link.true_time(i))) - link.host_at(link.true_time(i)));
    lo = std::min(lo, err);
    hi = std::max(hi, err);
  }
  EXPECT_LT(hi - lo, 50e-6) << "spread " << (hi - lo) * 1e6 << " us";
  EXPECT_NEAR(lo, 0.002 + 0.007, 100e-6);
  const ClockFit fit = mapper.fit();
  EXPECT_NEAR(fit.skew_ppm, 200.0, 1.0);
  EXPECT_FALSE(fit.ping_corrected);
  EXPECT_NEAR(fit.jitter_mean_s, 0.25e-3, 0.03e-3);  // exponential mean, slightly clipped
  EXPECT_LE(fit.jitter_max_s, 1e-3 + 60e-6);
  EXPECT_EQ(fit.packets, 7500u);
}

TEST(ClockMapper, PingsRemoveTheLatency) {
  Link link;
  link.drift_ppm = -150.0;
  Rng rng(4);
  ClockMapper mapper(link.tick_hz);
  // Samples stamped with their own tick this time (no buffering), pings once a second with the
  // same one-way latency and jitter as the data.
  for (int64_t i = 0; i < 20'000; i += 4) {
    const double t = link.true_time(i);
    mapper.add_packet(link.ticks_at(t), link.host_at(t + link.latency_s + link.jitter(rng)));
    if (i % 1000 == 0) {
      const double t1 = t + 0.0003;
      const double rx = t1 + link.latency_s + link.jitter(rng);
      const double tx = rx + 50e-6;
      const double t2 = tx + link.latency_s + link.jitter(rng);
      mapper.add_ping(link.host_at(t1), link.ticks_at(rx), link.ticks_at(tx), link.host_at(t2));
    }
  }
  const ClockFit fit = mapper.fit();
  ASSERT_TRUE(fit.ping_corrected);
  EXPECT_EQ(fit.pings, 20u);
  EXPECT_NEAR(fit.latency_correction_s, link.latency_s, 60e-6);
  EXPECT_NEAR(fit.skew_ppm, -150.0, 1.0);
  for (int64_t i = 0; i < 20'000; i += 97) {
    const double t = link.true_time(i);
    EXPECT_NEAR(to_seconds(mapper.map(link.ticks_at(t)) - link.host_at(t)), 0.0, 80e-6) << i;
  }
}

TEST(ClockMapper, EnvelopeNeverLiesAboveAPacketOnline) {
  const Link link;
  Rng rng(5);
  ClockMapper mapper(link.tick_hz);
  for (int64_t i = 0; i < 5000; i += 10) {
    const double t = link.true_time(i);
    const uint64_t ticks = link.ticks_at(t);
    const TimeNs received = link.host_at(t + link.latency_s + link.jitter(rng));
    mapper.add_packet(ticks, received);
    ASSERT_LE(mapper.map(ticks), received + 1) << i;  // 1 ns of rounding
  }
}

TEST(ClockMapper, OnePacketUsesTheNominalRate) {
  ClockMapper mapper(1e6);
  EXPECT_FALSE(mapper.ready());
  mapper.add_packet(1000, 5'000'000'000);
  EXPECT_EQ(mapper.map(1000), 5'000'000'000);
  EXPECT_EQ(mapper.map(2000), 5'001'000'000);
  mapper.add_packet(1000, 4'000'000'000);  // same tick, earlier arrival: the lower one counts
  EXPECT_EQ(mapper.map(1000), 4'000'000'000);
}

// Blocks of 8 samples arriving together: only each block's last sample enters the fit, so the
// jitter statistics describe the link, not the device's buffering.
TEST(ClockMapper, SamplesOfAPacketCountOnceAsItsLastSample) {
  const Link link;
  Rng rng(6);
  ClockMapper mapper(link.tick_hz);
  for (int64_t first = 0; first < 8000; first += 8) {
    const TimeNs received =
        link.host_at(link.true_time(first + 7) + link.latency_s + link.jitter(rng));
    for (int64_t i = first; i < first + 8; ++i)
      mapper.add_sample(link.ticks_at(link.true_time(i)), received);
  }
  mapper.flush();
  const ClockFit fit = mapper.fit();
  EXPECT_EQ(fit.packets, 1000u);
  EXPECT_LE(fit.jitter_max_s, 1e-3 + 20e-6);  // the link's jitter, not the 7 ms of buffering
  EXPECT_NEAR(fit.jitter_mean_s, 0.25e-3, 0.05e-3);
}

TEST(ClockMapper, ADayAt100HzStaysExact) {
  Link link;
  link.rate_hz = 100.0;
  link.drift_ppm = 35.0;
  ClockMapper mapper(link.tick_hz);
  const int64_t samples = 8'640'000;
  for (int64_t i = 0; i < samples; i += 10) {
    const double t = link.true_time(i);
    mapper.add_packet(link.ticks_at(t), link.host_at(t + link.latency_s));
  }
  for (int64_t i : {int64_t{0}, samples / 2, samples - 10}) {
    const double t = link.true_time(i);
    EXPECT_NEAR(to_seconds(mapper.map(link.ticks_at(t)) - link.host_at(t)), link.latency_s, 2e-6)
        << i;
  }
  EXPECT_NEAR(mapper.fit().skew_ppm, 35.0, 1e-3);
}

}  // namespace
}  // namespace imukit::capture
