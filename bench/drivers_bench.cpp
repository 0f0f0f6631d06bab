// Decoding throughput of each drivers codec on one core: samples per second from an in-memory
// stream fed in 4 KiB chunks (what a reader hands a byte codec), or report by report for HID.
//   bench_drivers --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cstring>
#include <functional>
#include <memory>
#include <string>

#include "imukit/drivers/imukit_codec.hpp"
#include "imukit/drivers/playstation_codec.hpp"
#include "imukit/drivers/text_codec.hpp"
#include "imukit/drivers/witmotion_codec.hpp"
#include "imukit/drivers/xsens_codec.hpp"
#include "imukit/firmware_proto/messages.hpp"
#include "support/example_models.hpp"

namespace {

using namespace imukit::drivers;
namespace proto = imukit::proto;

constexpr int kSamples = 100'000;

std::vector<uint8_t> imukit_stream() {
  std::vector<uint8_t> s;
  uint8_t buf[proto::kMaxFrameSize];
  // A 1 MHz device clock at 1 kHz output.
  const proto::DeviceInfo info = imukit::testing::example_device_info(1'000'000, 1'000'000);
  std::size_t n = proto::encode_message(info, 0, buf, sizeof buf);
  s.insert(s.end(), buf, buf + n);
  for (int b = 0; b < kSamples / 8; ++b) {
    proto::SampleBlock blk;
    blk.sample_index = 8u * static_cast<uint32_t>(b);
    blk.first_tick = 8000u * static_cast<uint32_t>(b);
    blk.count = 8;
    blk.channels = proto::kChannelAccel | proto::kChannelGyro;
    for (int i = 0; i < 8; ++i) {
      for (int k = 0; k < 3; ++k) {
        blk.accel[i][k] = static_cast<int16_t>(b * 7 + i * 3 + k);
        blk.gyro[i][k] = static_cast<int16_t>(-b + k);
      }
    }
    n = proto::encode_message(blk, static_cast<uint16_t>(b + 1), buf, sizeof buf);
    s.insert(s.end(), buf, buf + n);
  }
  return s;
}

std::vector<uint8_t> xsens_stream() {
  std::vector<uint8_t> s;
  for (int i = 0; i < kSamples; ++i) {
    std::vector<uint8_t> p = {
        0x10, 0x20, 2, static_cast<uint8_t>(i >> 8), static_cast<uint8_t>(i), 0x10, 0x60,
        4,    0,    0, static_cast<uint8_t>(i >> 8), static_cast<uint8_t>(i)};
    for (uint16_t id : {uint16_t{0x4020}, uint16_t{0x8020}, uint16_t{0xC020}}) {
      p.insert(p.end(), {static_cast<uint8_t>(id >> 8), static_cast<uint8_t>(id), 12});
      for (int k = 0; k < 3; ++k) {
        const float f = 0.25f * static_cast<float>(k + i % 10);
        uint32_t bits;
        std::memcpy(&bits, &f, 4);
        for (int j = 3; j >= 0; --j) p.push_back(static_cast<uint8_t>(bits >> (8 * j)));
      }
    }
    const auto f = xsens_frame(0x36, p);
    s.insert(s.end(), f.begin(), f.end());
  }
  return s;
}

std::vector<uint8_t> witmotion_stream() {
  std::vector<uint8_t> s;
  for (int i = 0; i < kSamples; ++i) {
    const int16_t a[4] = {static_cast<int16_t>(i), 1, 2048, 2500}, g[4] = {3, 4, 5, 0},
                  an[4] = {6, 7, 8, 0}, m[4] = {9, 10, 11, 0};
    for (const auto& f : {witmotion_frame(0x51, a), witmotion_frame(0x52, g),
                          witmotion_frame(0x53, an), witmotion_frame(0x54, m)}) {
      s.insert(s.end(), f.begin(), f.end());
    }
  }
  return s;
}

std::vector<uint8_t> text_stream() {
  std::string t;
  for (int i = 0; i < kSamples; ++i) {
    t += std::to_string(i * 10) + ",0.0123,-0.0456,9.8066," + std::to_string(i % 100) +
         ".5,-0.25,0.125\n";
  }
  return {t.begin(), t.end()};
}

void run_bytes(benchmark::State& state, const std::vector<uint8_t>& stream,
               const std::function<std::unique_ptr<Codec>()>& make) {
  std::vector<Sample> out;
  out.reserve(kSamples + 16);
  uint64_t samples = 0;
  for (auto _ : state) {
    auto codec = make();
    out.clear();
    for (std::size_t pos = 0; pos < stream.size(); pos += 4096) {
      const std::size_t n = std::min<std::size_t>(4096, stream.size() - pos);
      codec->feed(std::span<const uint8_t>(stream.data() + pos, n), 0, out);
    }
    codec->finish(0, out);
    samples += out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(stream.size()));
}

void BM_Imukit(benchmark::State& state) {
  static const auto s = imukit_stream();
  run_bytes(state, s, [] {
    return std::make_unique<ImukitCodec>(ImukitCodecOptions{false, 0, 8, 0, 0});
  });
}
void BM_Xsens(benchmark::State& state) {
  static const auto s = xsens_stream();
  run_bytes(state, s, [] { return std::make_unique<XsensCodec>(); });
}
void BM_Witmotion(benchmark::State& state) {
  static const auto s = witmotion_stream();
  run_bytes(state, s, [] { return std::make_unique<WitmotionCodec>(); });
}
void BM_Text(benchmark::State& state) {
  static const auto s = text_stream();
  run_bytes(state, s, [] { return std::make_unique<TextCodec>(); });
}

void BM_DualShock4(benchmark::State& state) {
  std::vector<std::vector<uint8_t>> reports(1000, std::vector<uint8_t>(64, 0));
  for (std::size_t i = 0; i < reports.size(); ++i) {
    reports[i][0] = 0x01;
    reports[i][7] = static_cast<uint8_t>((i & 0x3F) << 2);
    reports[i][10] = static_cast<uint8_t>((i * 750) & 0xFF);
    reports[i][11] = static_cast<uint8_t>(((i * 750) >> 8) & 0xFF);
    reports[i][13] = static_cast<uint8_t>(i);
  }
  std::vector<Sample> out;
  out.reserve(reports.size());
  uint64_t samples = 0;
  for (auto _ : state) {
    PlaystationCodec codec(PlaystationModel::kDualShock4);
    out.clear();
    for (const auto& r : reports) codec.feed(r, 0, out);
    samples += out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}

BENCHMARK(BM_Imukit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Xsens)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Witmotion)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Text)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DualShock4)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
