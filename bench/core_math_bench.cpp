// Throughput of core's math: normal draws (imukit's portable ziggurat against libstdc++'s
// std::normal_distribution on std::mt19937_64, in the same run), SO(3) exp/log/slerp, and PCHIP /
// cubic-spline construction plus evaluation over a typical augmentation batch (256 windows x 100
// samples x 12 channels, each window resampled at 100 warped times).
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "imukit/core/interpolation.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/so3.hpp"

namespace {

constexpr int kDraws = 1 << 16;

void BM_RngFillNormal(benchmark::State& state) {
  imukit::Rng rng(1);
  std::vector<double> out(kDraws);
  for (auto _ : state) {
    rng.fill_normal(out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kDraws);
}
BENCHMARK(BM_RngFillNormal);

void BM_RngNormalLoop(benchmark::State& state) {
  imukit::Rng rng(1);
  std::vector<double> out(kDraws);
  for (auto _ : state) {
    for (double& v : out) v = rng.normal();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kDraws);
}
BENCHMARK(BM_RngNormalLoop);

// Baseline: the standard library's normal distribution (Marsaglia polar in libstdc++).
void BM_StdNormalDistributionMt19937_64(benchmark::State& state) {
  std::mt19937_64 gen(1);
  std::normal_distribution<double> dist(0.0, 1.0);
  std::vector<double> out(kDraws);
  for (auto _ : state) {
    for (double& v : out) v = dist(gen);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kDraws);
}
BENCHMARK(BM_StdNormalDistributionMt19937_64);

void BM_RngUniform(benchmark::State& state) {
  imukit::Rng rng(1);
  std::vector<double> out(kDraws);
  for (auto _ : state) {
    for (double& v : out) v = rng.uniform();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kDraws);
}
BENCHMARK(BM_RngUniform);

constexpr int kRotations = 1024;

std::vector<Eigen::Vector3d> random_rotation_vectors() {
  imukit::Rng rng(2);
  std::vector<Eigen::Vector3d> v(kRotations);
  for (auto& r : v) r = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
  return v;
}

std::vector<Eigen::Quaterniond> random_quaternions(uint64_t seed) {
  imukit::Rng rng(seed);
  std::vector<Eigen::Quaterniond> q(kRotations);
  for (auto& r : q) {
    r = Eigen::Quaterniond(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    r.normalize();
  }
  return q;
}

void BM_So3Exp(benchmark::State& state) {
  const auto v = random_rotation_vectors();
  std::vector<Eigen::Quaterniond> out(kRotations);
  for (auto _ : state) {
    for (int i = 0; i < kRotations; ++i) out[i] = imukit::so3_exp(v[i]);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kRotations);
}
BENCHMARK(BM_So3Exp);

void BM_So3Log(benchmark::State& state) {
  const auto q = random_quaternions(3);
  std::vector<Eigen::Vector3d> out(kRotations);
  for (auto _ : state) {
    for (int i = 0; i < kRotations; ++i) out[i] = imukit::so3_log(q[i]);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kRotations);
}
BENCHMARK(BM_So3Log);

void BM_Slerp(benchmark::State& state) {
  const auto q0 = random_quaternions(4);
  const auto q1 = random_quaternions(5);
  std::vector<Eigen::Quaterniond> out(kRotations);
  for (auto _ : state) {
    for (int i = 0; i < kRotations; ++i) out[i] = imukit::slerp(q0[i], q1[i], 0.37);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kRotations);
}
BENCHMARK(BM_Slerp);

// 256 windows of 100 samples x 12 channels, each resampled at 100 warped (monotone) times.
struct Batch {
  static constexpr int kWindows = 256;
  static constexpr int kSamples = 100;
  static constexpr int kChannels = 12;
  std::vector<double> t;
  std::vector<Eigen::MatrixXd> windows;
  std::vector<std::vector<double>> warped_t;

  Batch() : t(kSamples) {
    imukit::Rng rng(6);
    for (int i = 0; i < kSamples; ++i) t[i] = i;
    for (int w = 0; w < kWindows; ++w) {
      Eigen::MatrixXd y(kChannels, kSamples);
      for (int i = 0; i < kSamples; ++i) {
        for (int c = 0; c < kChannels; ++c) y(c, i) = rng.normal();
      }
      windows.push_back(y);
      // A smooth monotone warp of [0, 99] onto itself.
      std::vector<double> q(kSamples);
      const double a = 0.1 * rng.uniform(-1.0, 1.0);
      for (int i = 0; i < kSamples; ++i) {
        const double u = i / (kSamples - 1.0);
        q[i] = (kSamples - 1.0) * (u + a * u * (1.0 - u));
      }
      warped_t.push_back(q);
    }
  }
};

void interpolate_batch(benchmark::State& state, imukit::InterpolationKind kind) {
  const Batch batch;
  Eigen::MatrixXd out(Batch::kChannels, Batch::kSamples);
  for (auto _ : state) {
    for (int w = 0; w < Batch::kWindows; ++w) {
      const imukit::Interpolant f = imukit::Interpolant::make(kind, batch.t, batch.windows[w]);
      f.evaluate(batch.warped_t[w], out);
      benchmark::DoNotOptimize(out.data());
    }
    benchmark::ClobberMemory();
  }
  // Items: output values (256 * 100 * 12 per batch).
  state.SetItemsProcessed(state.iterations() * Batch::kWindows * Batch::kSamples *
                          Batch::kChannels);
}

void BM_PchipBatch256x100x12(benchmark::State& state) {
  interpolate_batch(state, imukit::InterpolationKind::pchip);
}
BENCHMARK(BM_PchipBatch256x100x12)->Unit(benchmark::kMicrosecond);

void BM_CubicSplineBatch256x100x12(benchmark::State& state) {
  interpolate_batch(state, imukit::InterpolationKind::cubic_spline_not_a_knot);
}
BENCHMARK(BM_CubicSplineBatch256x100x12)->Unit(benchmark::kMicrosecond);

// Evaluation only, the interpolants built beforehand.
void BM_PchipEvaluateOnly256x100x12(benchmark::State& state) {
  const Batch batch;
  std::vector<imukit::Interpolant> f;
  for (int w = 0; w < Batch::kWindows; ++w) {
    f.push_back(imukit::Interpolant::pchip(batch.t, batch.windows[w]));
  }
  Eigen::MatrixXd out(Batch::kChannels, Batch::kSamples);
  for (auto _ : state) {
    for (int w = 0; w < Batch::kWindows; ++w) {
      f[w].evaluate(batch.warped_t[w], out);
      benchmark::DoNotOptimize(out.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * Batch::kWindows * Batch::kSamples *
                          Batch::kChannels);
}
BENCHMARK(BM_PchipEvaluateOnly256x100x12)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
