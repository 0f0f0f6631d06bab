// motion_from_keypoints (sim/keypoints.hpp) on Kinect v1 keypoints: a UTD-MHAD-sized trial
// (3 s at 19 frames/s) and a 10-minute take at 30 frames/s, both to 100 Hz; the baseline in the
// same run is simulating a wrist watch (spline, 50 Hz) on the motion it produced.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>

#include "imukit/sim/keypoints.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/simulator.hpp"

namespace {

using namespace imukit;
using namespace imukit::sim;

// Keypoints of a standing figure waving its arms and stepping, with 1 cm of deterministic
// jitter (a fixed pseudo-random sequence), frames at `fps` for `seconds`.
Keypoints figure(double fps, double seconds) {
  const KeypointTopology t = keypoint_topology("kinect_v1_20");
  const auto F = static_cast<int64_t>(seconds * fps) + 1;
  Keypoints k;
  k.keypoints = t.keypoints.size();
  k.rate_hz = fps;
  k.positions.resize(3, F * static_cast<Eigen::Index>(k.keypoints));
  uint64_t state = 12345;
  const auto jitter = [&] {  // uniform in [-1.7, 1.7] cm: 1 cm standard deviation
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5) * 0.0346;
  };
  for (int64_t f = 0; f < F; ++f) {
    const double s = static_cast<double>(f) / fps;
    const double a = 0.8 + 0.6 * std::sin(2 * std::numbers::pi * 0.7 * s);
    const auto set = [&](const char* n, Eigen::Vector3d p) {
      for (int c = 0; c < 3; ++c) p(c) += jitter();
      k.positions.col(f * static_cast<Eigen::Index>(k.keypoints) + t.keypoint_index(n)) = p;
    };
    set("hip_center", {0, 0, 1.0});
    set("spine", {0, 0, 1.2});
    set("shoulder_center", {0, 0, 1.45});
    set("head", {0, 0.02, 1.65});
    for (const double side : {-1.0, 1.0}) {
      const std::string x = side < 0 ? "left_" : "right_";
      const Eigen::Vector3d sh(side * 0.18, 0, 1.42);
      const Eigen::Vector3d el =
          sh + 0.28 * Eigen::Vector3d(side * std::sin(0.3), 0, -std::cos(0.3));
      const Eigen::Vector3d wr = el + 0.25 * Eigen::Vector3d(0, std::sin(a), -std::cos(a));
      set((x + "shoulder").c_str(), sh);
      set((x + "elbow").c_str(), el);
      set((x + "wrist").c_str(), wr);
      set((x + "hand").c_str(), wr + 0.06 * (wr - el).normalized());
      const double lift = 0.05 * std::max(0.0, std::sin(2 * std::numbers::pi * 0.5 * s + side));
      set((x + "hip").c_str(), {side * 0.09, 0, 0.95});
      set((x + "knee").c_str(), {side * 0.09, 0.03 + lift, 0.52 + lift});
      set((x + "ankle").c_str(), {side * 0.09, 0, 0.08 + lift});
      set((x + "foot").c_str(), {side * 0.09, 0.1, 0.03 + lift});
    }
  }
  return k;
}

void BM_MotionFromKeypoints(benchmark::State& state) {
  const double seconds = static_cast<double>(state.range(0));
  const double fps = state.range(0) <= 10 ? 19.0 : 30.0;
  const Keypoints k = figure(fps, seconds);
  const KeypointTopology t = keypoint_topology("kinect_v1_20");
  for (auto _ : state) benchmark::DoNotOptimize(motion_from_keypoints(k, t));
  state.counters["input_frames"] = static_cast<double>(k.frames());
}
BENCHMARK(BM_MotionFromKeypoints)->Arg(3)->Arg(600)->Unit(benchmark::kMillisecond);

// Baseline: the wrist watch simulated on the motion that conversion made.
void BM_SimulateWatchOnIt(benchmark::State& state) {
  const double seconds = static_cast<double>(state.range(0));
  const double fps = state.range(0) <= 10 ? 19.0 : 30.0;
  KeypointMotion r = motion_from_keypoints(figure(fps, seconds), keypoint_topology("kinect_v1_20"));
  SensorSpec spec;
  spec.name = "watch";
  spec.placement = preset_placement("right_wrist_watch", r.body);
  SimulationOptions o;
  o.method = DerivativeMethod::spline;
  o.rate_hz = 50.0;
  // Made once, as the other benchmarks do: the simulation alone is the baseline (its
  // construction was timed with it until review, 2026-11-27).
  Simulator sim(r.body, {spec}, o);
  for (auto _ : state) {
    int64_t n = 0;
    sim.run(r.motion,
            [&](std::size_t, const SensorBlock& b) { n += static_cast<int64_t>(b.t.size()); });
    benchmark::DoNotOptimize(n);
  }
}
BENCHMARK(BM_SimulateWatchOnIt)->Arg(3)->Arg(600)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
