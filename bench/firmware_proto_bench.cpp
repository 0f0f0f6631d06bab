// Host-side cost of the imukit wire protocol v1 (docs/protocol.md): decoding a valid stream of
// SampleBlock frames (COBS + CRC-32C + header checks), optionally parsing every block into its
// struct, and encoding. Blocks of 1, 8 and 32 samples with accelerometer and gyroscope (the common
// 6-axis case), and 32 samples with every channel. Counters:
//   bytes_per_second      wire bytes decoded per second (the 1 GB/s target is for 32-sample blocks)
//   frames_per_second     frames per second
//   samples_per_second    IMU samples per second
//   wire_bytes_per_sample encoded bytes on the wire per sample, delimiter included
//   raw_bytes_per_sample  the same samples as bare int16 values (12 for 6 axes)
//   overhead_pct          100 * (wire / raw - 1)
// The stream (about 4 MB) is fed in 4096-byte reads, as from a USB or serial driver, so some frames
// straddle two reads and take the decoder's buffering path.
//
//   ./build/release/bench/bench_firmware_proto --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace {

using imukit::proto::FrameDecoder;
using imukit::proto::SampleBlock;
namespace proto = imukit::proto;

constexpr size_t kStreamBytes = 4 << 20;
constexpr size_t kReadSize = 4096;

struct Stream {
  std::vector<uint8_t> bytes;
  size_t frames = 0;
  size_t samples = 0;
};

// A device at rest-ish: gravity on z, small noisy rates, slow drift; int16 counts as a 16 g /
// 2000 dps sensor would give them (many high bytes 0x00 or 0xFF, as on real devices).
Stream make_stream(uint8_t count, uint8_t channels) {
  std::mt19937_64 rng(42);
  auto noise = [&](int amplitude) {
    return static_cast<int>(rng() % static_cast<uint64_t>(2 * amplitude + 1)) - amplitude;
  };
  Stream s;
  SampleBlock block;
  block.count = count;
  block.channels = channels;
  uint32_t index = 0;
  uint16_t seq = 0;
  std::vector<uint8_t> frame(proto::kMaxFrameSize);
  while (s.bytes.size() < kStreamBytes) {
    block.sample_index = index;
    block.first_tick = index * 125u;
    for (uint8_t i = 0; i < count; ++i) {
      const int drift = static_cast<int>((index + i) % 4000) / 40;
      block.accel[i][0] = static_cast<int16_t>(120 + drift + noise(30));
      block.accel[i][1] = static_cast<int16_t>(-80 + noise(30));
      block.accel[i][2] = static_cast<int16_t>(2048 + noise(30));
      for (int a = 0; a < 3; ++a) block.gyro[i][a] = static_cast<int16_t>(noise(40));
      for (int a = 0; a < 3; ++a) block.mag[i][a] = static_cast<int16_t>(300 * (a - 1) + noise(5));
      block.temperature[i] = static_cast<int16_t>(1536 + noise(2));
    }
    const size_t n = proto::encode_message(block, seq++, frame.data(), frame.size());
    s.bytes.insert(s.bytes.end(), frame.begin(), frame.begin() + static_cast<ptrdiff_t>(n));
    ++s.frames;
    s.samples += count;
    index += count;
  }
  return s;
}

void set_counters(benchmark::State& state, const Stream& s, uint8_t channels) {
  const double iterations = static_cast<double>(state.iterations());
  state.SetBytesProcessed(static_cast<int64_t>(iterations * static_cast<double>(s.bytes.size())));
  using benchmark::Counter;
  state.counters["frames_per_second"] =
      Counter(iterations * static_cast<double>(s.frames), Counter::kIsRate);
  state.counters["samples_per_second"] =
      Counter(iterations * static_cast<double>(s.samples), Counter::kIsRate);
  const double wire = static_cast<double>(s.bytes.size()) / static_cast<double>(s.samples);
  const double raw = static_cast<double>(proto::sample_size(channels));
  state.counters["wire_bytes_per_sample"] = wire;
  state.counters["raw_bytes_per_sample"] = raw;
  state.counters["overhead_pct"] = 100.0 * (wire / raw - 1.0);
}

// Frames only: COBS, CRC, header, sequence accounting.
void BM_Decode(benchmark::State& state) {
  const auto count = static_cast<uint8_t>(state.range(0));
  const auto channels = static_cast<uint8_t>(state.range(1));
  const Stream s = make_stream(count, channels);
  size_t frames = 0;
  for (auto _ : state) {
    FrameDecoder decoder;
    for (size_t pos = 0; pos < s.bytes.size(); pos += kReadSize) {
      const size_t n = std::min(kReadSize, s.bytes.size() - pos);
      decoder.feed(s.bytes.data() + pos, n, [&](const proto::Frame& f) {
        benchmark::DoNotOptimize(f.payload);
        ++frames;
      });
    }
    if (decoder.stats().frames_ok != s.frames) state.SkipWithError("frames lost");
  }
  set_counters(state, s, channels);
}

// Frames plus parsing every SampleBlock into its struct: what a host driver does.
void BM_DecodeAndParse(benchmark::State& state) {
  const auto count = static_cast<uint8_t>(state.range(0));
  const auto channels = static_cast<uint8_t>(state.range(1));
  const Stream s = make_stream(count, channels);
  SampleBlock block;
  int64_t checksum = 0;
  for (auto _ : state) {
    FrameDecoder decoder;
    for (size_t pos = 0; pos < s.bytes.size(); pos += kReadSize) {
      const size_t n = std::min(kReadSize, s.bytes.size() - pos);
      decoder.feed(s.bytes.data() + pos, n, [&](const proto::Frame& f) {
        if (proto::parse_message(f, block) == proto::ParseStatus::kOk) {
          checksum += block.accel[block.count - 1][2];
        }
      });
    }
    benchmark::DoNotOptimize(checksum);
    if (decoder.stats().frames_ok != s.frames) state.SkipWithError("frames lost");
  }
  set_counters(state, s, channels);
}

// Encoding (what the device does per block; on the host for reference).
void BM_Encode(benchmark::State& state) {
  const auto count = static_cast<uint8_t>(state.range(0));
  const auto channels = static_cast<uint8_t>(state.range(1));
  const Stream s = make_stream(count, channels);
  SampleBlock block;
  block.count = count;
  block.channels = channels;
  for (uint8_t i = 0; i < count; ++i) {
    for (int a = 0; a < 3; ++a) block.accel[i][a] = static_cast<int16_t>(100 * a - 7 + i);
    for (int a = 0; a < 3; ++a) block.gyro[i][a] = static_cast<int16_t>(a - 1 + i);
  }
  std::vector<uint8_t> out(proto::kMaxFrameSize);
  uint16_t seq = 0;
  for (auto _ : state) {
    for (size_t f = 0; f < s.frames; ++f) {
      block.sample_index = static_cast<uint32_t>(f);
      benchmark::DoNotOptimize(proto::encode_message(block, seq++, out.data(), out.size()));
    }
  }
  set_counters(state, s, channels);
}

constexpr int64_t kSixAxis = proto::kChannelAccel | proto::kChannelGyro;
constexpr int64_t kAll = proto::kChannelMaskAll;

void block_sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"samples", "channels"});
  b->Args({1, kSixAxis})->Args({8, kSixAxis})->Args({32, kSixAxis})->Args({32, kAll});
  b->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_Decode)->Apply(block_sizes);
BENCHMARK(BM_DecodeAndParse)->Apply(block_sizes);
BENCHMARK(BM_Encode)->Apply(block_sizes);

}  // namespace

BENCHMARK_MAIN();
