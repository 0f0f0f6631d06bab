// Throughput of the hardware model (ImuErrorGenerator) on the simulator's hot path: blocks of
// true samples run through the error model in place, as a stream. Items are triad-samples (one
// 3-axis sample of one sensor). Cases: an ideal model (must cost ~nothing), each term alone, and
// a full consumer-MEMS accelerometer + gyroscope. The generator's state carries over from one
// iteration to the next, as in a long simulation; the input is re-copied so values stay bounded,
// and that copy (96 KiB) is in every case's time: the ideal model is the copy alone, the floor
// to subtract from the others.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cstring>

#include "imukit/core/hardware_model.hpp"
#include "imukit/core/rng.hpp"
#include "support/example_models.hpp"

namespace {

constexpr Eigen::Index kBlock = 4096;

Eigen::Matrix3Xd true_signal(double amplitude) {
  imukit::Rng rng(3);
  Eigen::Matrix3Xd x(3, kBlock);
  for (Eigen::Index i = 0; i < kBlock; ++i) {
    for (int a = 0; a < 3; ++a) x(a, i) = amplitude * rng.uniform(-1.0, 1.0);
  }
  return x;
}

// The tests' every-term model; the magnetometer is not on this path.
imukit::HardwareModel full_model() { return imukit::testing::consumer_mems_model(); }

enum Case { kIdeal, kWhite, kRandomWalk, kBiasInstability, kMatrixLowPassQuantise, kFull };

imukit::HardwareModel model_for(Case c) {
  const imukit::HardwareModel full = full_model();
  imukit::HardwareModel m;
  switch (c) {
    case kIdeal:
      break;
    case kWhite:
      m.accelerometer.noise_density = full.accelerometer.noise_density;
      break;
    case kRandomWalk:
      m.accelerometer.random_walk = full.accelerometer.random_walk;
      break;
    case kBiasInstability:
      m.accelerometer.bias_instability = full.accelerometer.bias_instability;
      break;
    case kMatrixLowPassQuantise:
      m.accelerometer.scale = full.accelerometer.scale;
      m.accelerometer.misalignment = full.accelerometer.misalignment;
      m.accelerometer.bandwidth_hz = full.accelerometer.bandwidth_hz;
      m.accelerometer.range = full.accelerometer.range;
      m.accelerometer.resolution = full.accelerometer.resolution;
      break;
    case kFull:
      m = full;
      break;
  }
  return m;
}

// Accelerometer only, one term at a time.
void BM_AccelerometerTerm(benchmark::State& state) {
  const auto c = static_cast<Case>(state.range(0));
  imukit::Rng rng(1);
  imukit::ImuErrorGenerator generator(model_for(c), 100.0, rng);
  const Eigen::Matrix3Xd input = true_signal(20.0);
  Eigen::Matrix3Xd y(3, kBlock);
  for (auto _ : state) {
    std::memcpy(y.data(), input.data(), sizeof(double) * static_cast<std::size_t>(y.size()));
    generator.apply_accelerometer(y);
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kBlock);
  static const char* const names[] = {"ideal",
                                      "white noise",
                                      "random walk",
                                      "bias instability (5 GM)",
                                      "scale+misalignment+LPF+saturation+quantisation",
                                      "full"};
  state.SetLabel(names[c]);
}
BENCHMARK(BM_AccelerometerTerm)->DenseRange(kIdeal, kFull);

// A full accelerometer and gyroscope (g-sensitivity included): items are IMU samples (two
// triads each), what the simulator's sensor-samples/s counts.
void BM_FullImu(benchmark::State& state) {
  imukit::Rng rng(1);
  imukit::ImuErrorGenerator generator(full_model(), 100.0, rng);
  const Eigen::Matrix3Xd accel_in = true_signal(20.0);
  const Eigen::Matrix3Xd gyro_in = true_signal(5.0);
  Eigen::Matrix3Xd accel(3, kBlock);
  Eigen::Matrix3Xd gyro(3, kBlock);
  for (auto _ : state) {
    std::memcpy(accel.data(), accel_in.data(),
                sizeof(double) * static_cast<std::size_t>(accel.size()));
    std::memcpy(gyro.data(), gyro_in.data(),
                sizeof(double) * static_cast<std::size_t>(gyro.size()));
    generator.apply_gyroscope(gyro, accel);
    generator.apply_accelerometer(accel);
    benchmark::DoNotOptimize(accel.data());
    benchmark::DoNotOptimize(gyro.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kBlock);
}
BENCHMARK(BM_FullImu);

// The floor under the noise terms: the normal draws themselves, three per item, so that its
// items are triads as the other cases' (it counted single draws, 3x the triads, until review,
// 2026-11-27).
void BM_NormalDraws(benchmark::State& state) {
  imukit::Rng rng(1);
  std::vector<double> out(3 * kBlock);
  for (auto _ : state) {
    rng.fill_normal(out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kBlock);
}
BENCHMARK(BM_NormalDraws);

}  // namespace

BENCHMARK_MAIN();
