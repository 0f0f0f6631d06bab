// Identification speed (sim/identify.hpp): the time to identify placement, biases and time
// offset from 60 s at 100 Hz, against the time to simulate that minute once with the spline
// method (the baseline measured in the same run); a UTD-MHAD-sized trial with a time scale and
// the segment correction against simulating it once; and a run-time-vs-error table over the
// recording length (--table).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <numbers>

#include "imukit/core/rng.hpp"
#include "imukit/core/so3.hpp"
#include "imukit/sim/identify.hpp"
#include "imukit/sim/simulator.hpp"
#include "support/sampled_motion.hpp"

namespace {

using namespace imukit;
using namespace imukit::sim;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// The varied two-joint motion of tests/sim/identify_test.cpp (root turning about all axes and
// translating, the sensor's joint swinging), as functions of time.
Quaterniond root_q(double t) {
  return so3_exp(Vector3d(0.8 * std::sin(0.9 * t) + 0.3 * std::sin(2.7 * t + 1.0),
                          0.7 * std::sin(1.3 * t + 0.5) + 0.25 * std::sin(3.3 * t),
                          1.1 * std::sin(0.6 * t + 2.0) + 0.3 * std::sin(2.1 * t + 0.3)));
}
Quaterniond child_q(double t) {
  return so3_exp(Vector3d(0.6 * std::sin(1.7 * t + 0.2), 0.5 * std::sin(2.3 * t + 1.1),
                          0.4 * std::sin(1.1 * t + 0.7)));
}
Vector3d trans(double t) {
  return Vector3d(0.3 * std::sin(0.8 * t), 0.25 * std::sin(1.2 * t + 1.0),
                  0.15 * std::sin(1.9 * t + 0.5));
}

Motion sample(double rate, double seconds) {
  const auto frames = static_cast<int64_t>(std::llround(seconds * rate)) + 1;
  return testing::sampled_motion(rate, frames, root_q, child_q, trans);
}

struct Case {
  Body body;
  Motion motion;
  ImuSeries imu;
  Placement truth;
  double dt = 0.2373;
  // The motion times the IMU samples saw (t + dt): between the motion's frames, where identify
  // evaluates the simulator. The baselines simulate at them; at the IMU's own stamps, which fall
  // on frames, they took the simulator's on-frame path and were 12x cheaper than the work
  // identify does (found in review, 2026-11-27).
  std::vector<TimeNs> tau;
};

Case make_case(double seconds, uint64_t seed, double imu_period_s = 0.01) {
  Case c;
  c.body.add_joint("pelvis", -1, Vector3d::Zero());
  c.body.add_joint("arm", 0, Vector3d(0.3, 0.0, 0.1));
  c.truth.joint = 1;
  c.truth.p_joint_sensor = Vector3d(0.03, -0.02, 0.05);
  c.truth.q_joint_sensor = euler_to_quaternion(Vector3d(20, -35, 110), "XYZ", true, true);
  Motion fine = sample(500.0, seconds + 1.0);
  SensorSpec s;
  s.name = "imu";
  s.placement = c.truth;
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(c.body, {s}, so);
  std::vector<TimeNs> stamps;
  for (double t = 0.5; t < seconds - 0.5; t += imu_period_s) {
    stamps.push_back(std::llround(t * 1e9));
    c.tau.push_back(std::llround((t + c.dt) * 1e9));
  }
  std::vector<SensorBlock> out;
  sim.evaluate(fine, c.tau, out);
  c.imu = ImuSeries::with_channels(stamps.size(), true, true);
  c.imu.t = stamps;
  Rng rng(seed);
  const Vector3d ba(0.05, -0.08, 0.12), bg(0.01, -0.005, 0.02);
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(stamps.size()); ++i) {
    for (int k = 0; k < 3; ++k) {
      c.imu.accel(k, i) = out[0].specific_force(k, i) + ba[k] + 0.05 * rng.normal();
      c.imu.gyro(k, i) = out[0].angular_rate(k, i) + bg[k] + 0.005 * rng.normal();
    }
  }
  c.motion = sample(100.0, seconds + 1.0);
  return c;
}

// Baseline: simulating the sensor once over the minute (spline, at the motion times the 100 Hz
// IMU saw).
void BM_SimulateMinuteSpline(benchmark::State& state) {
  Case c = make_case(60.0, 1);
  SensorSpec s;
  s.name = "imu";
  s.placement = c.truth;
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(c.body, {s}, so);
  std::vector<SensorBlock> out;
  for (auto _ : state) {
    sim.evaluate(c.motion, c.tau, out);
    benchmark::DoNotOptimize(out[0].specific_force.data());
  }
}
BENCHMARK(BM_SimulateMinuteSpline)->Unit(benchmark::kMillisecond);

// Identification of placement (6), biases (6) and time offset from 60 s at 100 Hz.
void BM_Identify60s100Hz(benchmark::State& state) {
  Case c = make_case(60.0, 1);
  IdentifyOptions o;
  o.joint = 1;
  o.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const IdentifyResult r = identify(c.body, c.motion, c.imu, o);
    benchmark::DoNotOptimize(r.time_offset_s);
    state.counters["iterations"] = r.iterations;
  }
}
BENCHMARK(BM_Identify60s100Hz)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// A UTD-MHAD-sized trial (5 s at 50 Hz) fitted as the batch fits one (docs/identification.md,
// "UTD-MHAD"): clock rate within +-5 % (coarse grid, then Levenberg-Marquardt), bias priors,
// function tolerance 1e-6; arg 0 without a segment correction, 1 the twist, 2 the 3-D rotation.
void BM_IdentifyTrial5s50Hz(benchmark::State& state) {
  Case c = make_case(6.0, 1, 0.02);
  IdentifyOptions o;
  o.joint = 1;
  o.clock_rate = true;
  o.max_clock_rate = 0.05;
  o.accel_bias_prior_mps2 = 0.5;
  o.gyro_bias_prior_radps = 0.05;
  o.function_tolerance = 1e-6;
  o.correction = state.range(0) == 0   ? SegmentCorrection::none
                 : state.range(0) == 1 ? SegmentCorrection::twist
                                       : SegmentCorrection::rotation;
  for (auto _ : state) {
    const IdentifyResult r = identify(c.body, c.motion, c.imu, o);
    benchmark::DoNotOptimize(r.time_offset_s);
    state.counters["iterations"] = r.iterations;
    state.counters["samples"] = static_cast<double>(r.samples_used);
  }
}
BENCHMARK(BM_IdentifyTrial5s50Hz)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Baseline of the trial: simulating its 5 s once (spline, at the motion times the 50 Hz IMU saw).
void BM_SimulateTrialSpline(benchmark::State& state) {
  Case c = make_case(6.0, 1, 0.02);
  SensorSpec s;
  s.name = "imu";
  s.placement = c.truth;
  SimulationOptions so;
  so.method = DerivativeMethod::spline;
  Simulator sim(c.body, {s}, so);
  std::vector<SensorBlock> out;
  for (auto _ : state) {
    sim.evaluate(c.motion, c.tau, out);
    benchmark::DoNotOptimize(out[0].specific_force.data());
  }
}
BENCHMARK(BM_SimulateTrialSpline)->Unit(benchmark::kMicrosecond);

void print_table() {
  std::printf(
      "| recording s | samples | rotation error deg | position error mm | time offset error ms | "
      "accel bias error mm/s^2 | iterations | CPU s |\n|---|---|---|---|---|---|---|---|\n");
  for (double seconds : {10.0, 20.0, 30.0, 60.0}) {
    Case c = make_case(seconds, 2);
    IdentifyOptions o;
    o.joint = 1;
    // Process CPU time (one thread): the shared machine's wall clock says more about the load.
    const std::clock_t t0 = std::clock();
    const IdentifyResult r = identify(c.body, c.motion, c.imu, o);
    const double s = static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
    std::printf("| %.0f | %lld | %.4f | %.3f | %.4f | %.2f | %d | %.3f |\n", seconds,
                static_cast<long long>(r.samples_used),
                angular_distance(r.placement.q_joint_sensor, c.truth.q_joint_sensor) * 180 /
                    std::numbers::pi,
                (r.placement.p_joint_sensor - c.truth.p_joint_sensor).norm() * 1e3,
                std::abs(r.time_offset_s - c.dt) * 1e3,
                (r.accel_bias - Vector3d(0.05, -0.08, 0.12)).norm() * 1e3, r.iterations, s);
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--table") == 0) {
      print_table();
      return 0;
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
