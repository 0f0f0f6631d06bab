// Capture throughput: the MCAP writer alone, and whole recording sessions of 8 mock devices,
// both in virtual time (as fast as one core can go: the session's ceiling) and in real time
// (the load a recorder sees from 8 real devices), with the recorder's own losses and its CPU use.
#include <benchmark/benchmark.h>

#include <sys/resource.h>
#include <filesystem>

#include "imukit/capture/mcap.hpp"
#include "imukit/capture/ros_messages.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/drivers/uri.hpp"

namespace {

namespace fs = std::filesystem;
using namespace imukit;

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("imukit-bench-" + name);
}

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// One sensor_msgs/Imu + one RawImu per sample, zstd chunks, as a session writes them.
void BM_McapWriteImuSamples(benchmark::State& state) {
  const std::string path = temp_file("write.mcap").string();
  capture::ImuMessage imu;
  imu.frame_id = "bench";
  capture::RawImuMessage raw;
  int64_t samples = 0;
  for (auto _ : state) {
    capture::McapWriter w(path);
    const uint16_t s = w.add_schema(capture::kImuSchemaName, "ros2msg", capture::kImuSchemaText);
    const uint16_t r =
        w.add_schema(capture::kRawImuSchemaName, "ros2msg", capture::kRawImuSchemaText);
    const uint16_t ci = w.add_channel(s, "/imu/bench", "cdr");
    const uint16_t cr = w.add_channel(r, "/imu/bench/raw", "cdr");
    for (int i = 0; i < 100'000; ++i) {
      const auto t = static_cast<TimeNs>(i) * 125'000;  // 8 kHz
      imu.stamp = raw.stamp = t;
      imu.angular_velocity = {0.001 * (i % 100), 0.0, -0.002 * (i % 37)};
      imu.linear_acceleration = {0.01 * (i % 13), 0.0, 9.81};
      raw.sample_index = static_cast<uint64_t>(i);
      w.write_message(cr, static_cast<uint64_t>(t), static_cast<uint64_t>(t),
                      capture::encode_cdr(raw));
      w.write_message(ci, static_cast<uint64_t>(t), static_cast<uint64_t>(t),
                      capture::encode_cdr(imu));
    }
    w.close();
    samples += 100'000;
  }
  state.counters["samples/s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
  state.counters["bytes/sample"] = static_cast<double>(fs::file_size(path)) / 100'000.0;
  fs::remove(path);
}
BENCHMARK(BM_McapWriteImuSamples)->Unit(benchmark::kMillisecond)->MinTime(1.0);

// 8 mock devices at `rate` Hz for `seconds` of device time, virtual (range(2) == 1) or real time.
void BM_SessionEightDevices(benchmark::State& state) {
  const auto rate = state.range(0);
  const auto seconds = state.range(1);
  const bool virtual_time = state.range(2) == 1;
  const std::string path = temp_file("session.mcap").string();
  uint64_t written = 0, lost = 0, missing = 0;
  double cpu = 0;
  for (auto _ : state) {
    std::vector<capture::SessionDevice> devices;
    for (int k = 0; k < 8; ++k) {
      const std::string uri = "mock:static?rate=" + std::to_string(rate) +
                              "&seed=" + std::to_string(k + 1) +
                              "&clock=" + (virtual_time ? "virtual" : "real") + "&block=32";
      devices.push_back({"dev" + std::to_string(k), uri, drivers::open_device(uri), std::nullopt});
    }
    capture::SessionOptions options;
    options.path = path;
    options.duration_s = static_cast<double>(seconds);
    const double cpu0 = cpu_seconds();
    const capture::SessionReport report = capture::record_session(std::move(devices), options);
    cpu += cpu_seconds() - cpu0;
    for (const auto& d : report.devices) {
      written += d.samples;
      lost += d.backpressure;
      missing += d.dropped;
    }
  }
  state.counters["samples/s"] =
      benchmark::Counter(static_cast<double>(written), benchmark::Counter::kIsRate);
  state.counters["recorder_lost"] = static_cast<double>(lost);
  state.counters["missing"] = static_cast<double>(missing);
  // CPU seconds the whole process used per second of recording (all threads: readers, writer,
  // the mocks themselves, the final refit).
  state.counters["cpu_per_s"] = cpu / static_cast<double>(state.iterations() * seconds);
  fs::remove(path);
}
BENCHMARK(BM_SessionEightDevices)
    ->Args({8000, 10, 1})
    ->Args({8000, 10, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
