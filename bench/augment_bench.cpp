// Augmentation benchmarks (docs/benchmarks.md, issue 9):
//  * PPDA: a batch of 256 windows x 100 samples x 9 sensors on the 21-joint default humanoid
//    (procedural motion, 100 Hz), under the heaviest sub-policy of the built-in grid (amplitude
//    warping, speed warping, placement rotation, hardware noise), under sub-policies drawn from
//    the whole grid, and under identity; on 1 and 2 threads. Baseline in the same run: the plain
//    simulator evaluating the same 256 windows (spline method, all 9 sensors, no augmentation).
//    The reference simulator needs 0.24 s for the simulation alone (seed-summary section 2).
//    The one-thread batches and the baseline run once per instruction-set variant of the kernels,
//    with the speed-ups over the baseline variant printed at the end (bench/isa_compare.hpp).
//  * STDA: each method on a 256 x 100 x 12 float batch.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>

#include "imukit/augment/policy.hpp"
#include "imukit/augment/ppda.hpp"
#include "imukit/augment/stda.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"
#include "isa_compare.hpp"
#include "support/procedural_scene.hpp"

namespace {

using namespace imukit;
using namespace imukit::augment;

constexpr std::size_t kBatch = 256;

const sim::Scene& humanoid_scene() {
  static const sim::Scene scene =
      testing::preset_scene({"left_wrist_watch", "right_wrist_watch", "right_index_ring",
                             "left_earbud", "right_front_pocket_phone", "chest_strap",
                             "left_upper_arm_band", "right_ankle_clip", "waist_belt"},
                            {.rate_hz = 100.0, .frames = 6000, .seed = 9, .amplitude_rad = 0.2});
  return scene;
}

std::vector<int64_t> batch_starts(const PpdaAugmenter& aug) {
  std::vector<int64_t> all = aug.window_starts(20);
  std::vector<int64_t> starts;
  for (std::size_t k = 0; k < kBatch; ++k) starts.push_back(all[(k * 7) % all.size()]);
  return starts;
}

void report(benchmark::State& state) {
  state.counters["windows/s"] = benchmark::Counter(static_cast<double>(state.iterations() * kBatch),
                                                   benchmark::Counter::kIsRate);
}

// arg 0: threads; arg 1: 0 identity, 1 heaviest sub-policy, 2 sub-policies drawn from the grid;
// arg 2: derivative method (0 spline, 1 fd).
void BM_PpdaBatch(benchmark::State& state) {
  PpdaOptions po;
  po.method = state.range(2) == 0 ? sim::DerivativeMethod::spline : sim::DerivativeMethod::fd;
  PpdaAugmenter aug(humanoid_scene(), po);
  const std::vector<int64_t> starts = batch_starts(aug);
  const Policy policy = builtin_policy("imukit");
  std::vector<float> out(kBatch * aug.window() * aug.channels());
  const auto threads = static_cast<unsigned>(state.range(0));
  Rng rng(1);
  for (auto _ : state) {
    std::size_t k = 0;
    if (state.range(1) == 1) k = policy.sub_policies.size() - 1;
    if (state.range(1) == 2) k = sample_sub_policy(policy, rng);
    if (state.range(1) >= 10) k = static_cast<std::size_t>(state.range(1) - 10);  // grid index
    if (state.range(1) == 0)
      aug.apply(SubPolicy{}, starts, rng, out, threads);
    else
      aug.apply(policy, k, starts, rng, out, threads);
    benchmark::DoNotOptimize(out.data());
  }
  report(state);
}
BENCHMARK(BM_PpdaBatch)
    ->ArgNames({"threads", "policy", "fd"})
    ->Args({1, 2, 0})
    ->Args({2, 1, 0})
    ->Args({2, 2, 0})
    ->Args({2, 1, 1})
    ->Args({1, 10 + 720, 1})  // amplitude warping only
    ->Args({1, 10 + 80, 1})   // speed warping only
    ->Args({1, 10 + 5, 1})    // placement only
    ->Args({1, 10 + 4, 1})    // hardware only
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Baseline: the simulator itself on the same 256 windows (9 sensors), one plan; arg: 0 spline,
// 1 fd.
void BM_SimulatorSameWindows(benchmark::State& state) {
  const sim::Scene& scene = humanoid_scene();
  std::vector<sim::SensorSpec> specs;
  for (const auto& s : scene.sensors) specs.push_back(s.spec);
  sim::SimulationOptions o;
  o.method = state.range(0) == 0 ? sim::DerivativeMethod::spline : sim::DerivativeMethod::fd;
  sim::Simulator simulator(scene.body, specs, o);
  PpdaAugmenter aug(scene);
  const std::vector<int64_t> starts = batch_starts(aug);
  std::vector<sim::SensorBlock> blocks;
  std::vector<TimeNs> times(100);
  for (auto _ : state) {
    for (int64_t s : starts) {
      for (int64_t i = 0; i < 100; ++i)
        times[static_cast<std::size_t>(i)] = sample_time(0, s + i, 100.0);
      simulator.evaluate(*scene.motion, times, blocks);
      benchmark::DoNotOptimize(blocks.data());
    }
  }
  report(state);
}

void BM_Stda(benchmark::State& state) {
  const auto method = static_cast<StdaMethod>(state.range(0));
  const BatchShape shape{kBatch, 100, 12};
  const ChannelLayout layout = ChannelLayout::imu({"a", "b"});
  std::vector<float> x(shape.size()), x0(shape.size());
  for (std::size_t k = 0; k < x0.size(); ++k)
    x0[k] = static_cast<float>(std::sin(0.01 * static_cast<double>(k)));
  StdaSpec spec;
  spec.method = method;
  spec.sigma = 0.2;
  spec.knots = 4;
  spec.lo = 0.5;
  spec.hi = 2.0;
  spec.ratio = 2.0;
  spec.jitter_sigma[0] = 0.1;
  spec.jitter_sigma[1] = 0.01;
  Rng rng(3);
  for (auto _ : state) {
    state.PauseTiming();
    x = x0;
    state.ResumeTiming();
    apply_stda(spec, layout, x, shape, rng);
    benchmark::DoNotOptimize(x.data());
  }
  state.SetLabel(std::string(to_string(method)));
}
BENCHMARK(BM_Stda)->DenseRange(1, 6)->Unit(benchmark::kMicrosecond);

// Once per instruction-set variant of the kernels (bench/isa_compare.hpp): the baseline
// simulation, identity and the heaviest sub-policy on one thread.
void register_per_isa_benchmarks() {
  imukit::bench::register_per_isa("BM_PpdaBatch", BM_PpdaBatch, [](auto* b) {
    b->ArgNames({"threads", "policy", "fd"})
        ->Args({1, 0, 0})
        ->Args({1, 1, 0})
        ->Args({1, 0, 1})
        ->Args({1, 1, 1})
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  });
  imukit::bench::register_per_isa("BM_SimulatorSameWindows", BM_SimulatorSameWindows, [](auto* b) {
    b->ArgName("fd")->DenseRange(0, 1)->Unit(benchmark::kMillisecond)->UseRealTime();
  });
}

}  // namespace

int main(int argc, char** argv) {
  register_per_isa_benchmarks();
  return imukit::bench::run_with_isa_ratios(argc, argv);
}
