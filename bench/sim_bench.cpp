// Simulator benchmarks (docs/benchmarks.md):
//  * the run time vs error table of the three derivative methods at 25/50/100/200 Hz on a smooth
//    synthetic arm motion with analytic truth (printed before the timings);
//  * throughput on the reference's 12-joint body with 2 wrist sensors at 100 Hz, and on the
//    21-joint default humanoid with 9 sensors, once per instruction-set variant of the kernels
//    with the speed-ups over the baseline variant (bench/isa_compare.hpp);
//  * plan pruning: one wrist sensor on a 25-joint body vs on the 6-joint chain it needs, and
//    accelerometer only;
//  * peak memory of a 60-minute 100 Hz scene, streamed (`--memory-streamed`) or with the motion
//    loaded whole (`--memory-loaded`): each runs alone in its process and prints the peak RSS.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>

#include "imukit/sim/scene.hpp"
#include "imukit/sim/simulator.hpp"
#include "isa_compare.hpp"
#include "support/procedural_scene.hpp"

namespace {

using imukit::TimeNs;
using namespace imukit::sim;
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// The reference simulator's REALDISP body (../shared/data/reference_sim/sceneA_params.json).
Body reference_body() {
  Body b;
  b.add_joint("BASE", -1, Vector3d::Zero());
  b.add_joint("PELVIS", 0, Vector3d::Zero());
  b.add_joint("R_CLAVICLE", 1, Vector3d(0, 0, 0.46));
  b.add_joint("R_SHOULDER", 2, Vector3d(0.22, -0.09, 0));
  b.add_joint("R_ELBOW", 3, Vector3d(0.27, 0, 0));
  b.add_joint("L_CLAVICLE", 1, Vector3d(0, 0, 0.46));
  b.add_joint("L_SHOULDER", 5, Vector3d(-0.22, -0.09, 0));
  b.add_joint("L_ELBOW", 6, Vector3d(-0.27, 0, 0));
  b.add_joint("R_HIP", 0, Vector3d(0.14, 0, 0));
  b.add_joint("R_KNEE", 8, Vector3d(0, 0, -0.4));
  b.add_joint("L_HIP", 0, Vector3d(-0.14, 0, 0));
  b.add_joint("L_KNEE", 10, Vector3d(0, 0, -0.4));
  return b;
}

SensorSpec sensor(const std::string& name, int joint, const Vector3d& p, bool gyro = true) {
  SensorSpec s;
  s.name = name;
  s.placement.joint = joint;
  s.placement.p_joint_sensor = p;
  s.placement.q_joint_sensor = Quaterniond(Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()));
  s.outputs.gyroscope = gyro;
  return s;
}

// --- accuracy table: a 4-joint arm chain, each joint about a fixed axis by a sinusoid ---------

struct ArmChain {
  std::vector<Vector3d> axis, offset;
  std::vector<double> amp, freq, phase;
  Vector3d r = Vector3d(0.25, 0.01, 0.03);
  ArmChain() {
    axis = {Vector3d(0, 0, 1), Vector3d(0.3, 1, 0).normalized(), Vector3d(1, 0, 0.2).normalized(),
            Vector3d(0, 1, 0.4).normalized()};
    offset = {Vector3d::Zero(), Vector3d(0.2, 0, 0.45), Vector3d(0.28, 0, 0), Vector3d(0.26, 0, 0)};
    amp = {0.4, 0.7, 0.9, 0.6};
    freq = {0.35, 0.8, 1.1, 0.6};
    phase = {0.1, 0.7, 1.9, 2.5};
  }
  double th(std::size_t j, double t, int d) const {
    const double w = 2 * std::numbers::pi * freq[j];
    const double x = w * t + phase[j];
    if (d == 0) return amp[j] * std::sin(x);
    if (d == 1) return amp[j] * w * std::cos(x);
    return -amp[j] * w * w * std::sin(x);
  }
  // Analytic truth by rigid-body kinematics (world axes).
  void truth(double t, Vector3d& f, Vector3d& w_s) const {
    Matrix3d R = Matrix3d::Identity();
    Vector3d w = Vector3d::Zero(), dw = Vector3d::Zero(), a = Vector3d::Zero();
    for (std::size_t j = 0; j < axis.size(); ++j) {
      const Vector3d o = R * offset[j];
      a += dw.cross(o) + w.cross(w.cross(o));
      R = R * Eigen::AngleAxisd(th(j, t, 0), axis[j]).toRotationMatrix();
      const Vector3d wl = R * axis[j] * th(j, t, 1);
      dw += w.cross(wl) + R * axis[j] * th(j, t, 2);
      w += wl;
    }
    const Vector3d rr = R * r;
    a += dw.cross(rr) + w.cross(w.cross(rr));
    f = R.transpose() * a;  // motion part of the specific force (gravity excluded)
    w_s = R.transpose() * w;
  }
  Body body() const {
    Body b;
    for (std::size_t j = 0; j < axis.size(); ++j) {
      std::string name(1, 'j');  // appended, not operator+: gcc 12 -Wrestrict false positive
      name += std::to_string(j);
      b.add_joint(name, static_cast<int>(j) - 1, offset[j]);
    }
    return b;
  }
  Motion motion(double rate, double seconds) const {
    const auto n = static_cast<int64_t>(std::lround(seconds * rate)) + 1;
    Motion m(rate, axis.size(), n);
    for (int64_t k = 0; k < n; ++k) {
      for (std::size_t j = 0; j < axis.size(); ++j) {
        m.rotation(k, j) =
            Quaterniond(Eigen::AngleAxisd(th(j, static_cast<double>(k) / rate, 0), axis[j]));
      }
    }
    return m;
  }
};

void print_accuracy_table() {
  const ArmChain arm;
  const Body body = arm.body();
  std::printf(
      "Run time vs error, 4-joint arm chain with sinusoidal joints (0.35-1.1 Hz), 60 s, 1 "
      "sensor\n");
  std::printf(
      "error = RMSE / RMS of the signal (accelerometer: motion part, gravity excluded), interior "
      "samples\n");
  std::printf("%-10s %7s %12s %12s %14s %16s\n", "method", "rate_Hz", "acc_err_%", "gyro_err_%",
              "time_ms", "samples_per_s");
  for (const DerivativeMethod method :
       {DerivativeMethod::reference, DerivativeMethod::fd, DerivativeMethod::spline}) {
    for (const double rate : {25.0, 50.0, 100.0, 200.0}) {
      Motion m = arm.motion(rate, 60.0);
      SimulationOptions opt;
      opt.method = method;
      opt.gravity_world = Vector3d::Zero();
      SensorSpec s;
      s.name = "s";
      s.placement.joint = 3;
      s.placement.p_joint_sensor = arm.r;
      Simulator sim(body, {s}, opt);
      std::vector<TimeNs> t;
      for (int64_t k = 0; k < sim.sample_count(m, m.frames()); ++k)
        t.push_back(sim.sample_time_ns(m, k));
      std::vector<SensorBlock> out;
      const int reps = 20;
      const auto t0 = std::chrono::steady_clock::now();
      for (int r = 0; r < reps; ++r) sim.evaluate(m, t, out);
      const double sec =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
      double ef = 0, ew = 0, sf = 0, sw = 0;
      for (std::size_t i = 0; i < t.size(); ++i) {
        const double ts = imukit::to_seconds(t[i]);
        if (ts < 1.0 || ts > 59.0) continue;
        Vector3d f, w;
        arm.truth(ts, f, w);
        ef += (out[0].specific_force.col(static_cast<Eigen::Index>(i)) - f).squaredNorm();
        ew += (out[0].angular_rate.col(static_cast<Eigen::Index>(i)) - w).squaredNorm();
        sf += f.squaredNorm();
        sw += w.squaredNorm();
      }
      std::printf("%-10s %7.0f %12.4g %12.4g %14.3f %16.3g\n",
                  std::string(to_string(method)).c_str(), rate, 100 * std::sqrt(ef / sf),
                  100 * std::sqrt(ew / sw), sec * 1e3, static_cast<double>(t.size()) / sec);
    }
  }
  std::printf("\n");
}

// --- throughput -------------------------------------------------------------------------------

void run_whole(benchmark::State& state, const Body& body, const std::vector<SensorSpec>& sensors,
               DerivativeMethod method, int64_t frames) {
  Motion m = imukit::testing::procedural_motion(body.size(), {.frames = frames});
  SimulationOptions opt;
  opt.method = method;
  Simulator sim(body, sensors, opt);
  int64_t samples = 0;
  for (auto _ : state) {
    sim.run(m, [&](std::size_t, const SensorBlock& b) {
      benchmark::DoNotOptimize(b.specific_force.data());
      samples += static_cast<int64_t>(b.t.size());
    });
  }
  state.SetItemsProcessed(samples);  // sensor-samples
  state.counters["sensor_samples_per_s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}

void BM_Reference12Joints2Wrists100Hz3min(benchmark::State& state) {
  const Body b = reference_body();
  run_whole(state, b,
            {sensor("RWR", 4, Vector3d(0.25, 0, 0.03)), sensor("LWR", 7, Vector3d(-0.25, 0, 0.03))},
            static_cast<DerivativeMethod>(state.range(0)), 18000);
}

void BM_FullBody9Sensors100Hz3min(benchmark::State& state) {
  const Body b = Body::default_humanoid();
  std::vector<SensorSpec> s;
  for (const char* p :
       {"left_wrist_watch", "right_wrist_watch", "right_index_ring", "left_earbud", "chest_strap",
        "right_front_pocket_phone", "left_upper_arm_band", "right_ankle_clip", "waist_belt"}) {
    SensorSpec x;
    x.name = p;
    x.placement = preset_placement(p, b);
    s.push_back(x);
  }
  run_whole(state, b, s, static_cast<DerivativeMethod>(state.range(0)), 18000);
}

// The throughput benchmarks run once per instruction-set variant of the kernels (baseline, AVX2,
// AVX-512 as supported), with each variant's speed-up over the baseline printed at the end.
void register_throughput_benchmarks() {
  const auto methods = [](benchmark::internal::Benchmark* b) {
    b->Arg(0)
        ->Arg(1)
        ->Arg(2)
        ->ArgName("method_fd0_spline1_reference2")
        ->Unit(benchmark::kMillisecond);
  };
  imukit::bench::register_per_isa("BM_Reference12Joints2Wrists100Hz3min",
                                  BM_Reference12Joints2Wrists100Hz3min, methods);
  imukit::bench::register_per_isa("BM_FullBody9Sensors100Hz3min", BM_FullBody9Sensors100Hz3min,
                                  methods);
}

// --- anti-aliasing ----------------------------------------------------------------------------

// What the anti-aliasing filter costs: a wrist watch on the default humanoid, 3 min of motion at
// 120 Hz, sampled at 50 Hz point by point (anti_alias 0) or band-limited (1), and, as the
// baseline of the same run, every frame at the motion's own 120 Hz (rate 120): the filter
// evaluates each frame once and weighs 58 of them per sample.
void BM_AntiAliasedWatch120HzMotion(benchmark::State& state) {
  const Body b = Body::default_humanoid();
  SensorSpec s;
  s.name = "watch";
  s.placement = preset_placement("left_wrist_watch", b);
  Motion m = imukit::testing::procedural_motion(b.size(), {.rate_hz = 120.0, .frames = 21600});
  SimulationOptions opt;
  opt.method = static_cast<DerivativeMethod>(state.range(0));
  opt.rate_hz = static_cast<double>(state.range(2));
  opt.anti_alias = state.range(1) != 0;
  Simulator sim(b, {s}, opt);
  int64_t samples = 0;
  for (auto _ : state) {
    sim.run(m, [&](std::size_t, const SensorBlock& block) {
      benchmark::DoNotOptimize(block.specific_force.data());
      samples += static_cast<int64_t>(block.t.size());
    });
  }
  state.counters["sensor_samples_per_s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_AntiAliasedWatch120HzMotion)
    ->Args({0, 0, 50})
    ->Args({0, 1, 50})
    ->Args({0, 0, 120})
    ->Args({1, 0, 50})
    ->Args({1, 1, 50})
    ->Args({1, 0, 120})
    ->ArgNames({"method_fd0_spline1", "anti_alias", "rate_hz"})
    ->Unit(benchmark::kMillisecond);

// --- plan pruning -----------------------------------------------------------------------------

// The default humanoid plus 4 finger joints on the right hand: 25 joints.
Body body25() {
  Body b = Body::default_humanoid();
  const int hand = b.index_of("right_wrist");
  int parent = hand;
  for (int k = 0; k < 4; ++k) {
    std::string name = "right_finger";
    name += std::to_string(k);
    parent = b.add_joint(name, parent, Vector3d(0.03, 0, 0));
  }
  return b;
}

// Just the chain from the root to the left elbow, with the same offsets: what the plan keeps of
// the 25-joint body (pelvis, spine, chest, left clavicle, shoulder, elbow: 6 joints).
Body chain_only() {
  const Body full = body25();
  Body b;
  for (int j : full.chain(full.index_of("left_elbow"))) {
    const Joint& src = full.joint(static_cast<std::size_t>(j));
    b.add_joint(src.name, static_cast<int>(b.size()) - 1, src.offset_parent_joint);
  }
  return b;
}

void BM_PlanPruningOneWrist(benchmark::State& state) {
  const bool big = state.range(0) == 25;
  const bool gyro = state.range(1) != 0;
  const Body b = big ? body25() : chain_only();
  run_whole(state, b, {sensor("w", b.index_of("left_elbow"), Vector3d(-0.24, 0, 0.03), gyro)},
            DerivativeMethod::fd, 18000);
}
BENCHMARK(BM_PlanPruningOneWrist)
    ->Args({25, 1})
    ->Args({6, 1})
    ->Args({25, 0})
    ->Args({6, 0})
    ->ArgNames({"body_joints", "gyro"})
    ->Unit(benchmark::kMillisecond);

// --- memory -----------------------------------------------------------------------------------

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

int memory_run(bool streamed) {
  const Body b = reference_body();
  const int64_t frames = 60 * 60 * 100 + 1;
  std::shared_ptr<MotionSource> source;
  std::size_t motion_bytes = 0;
  ProceduralMotionOptions po;
  po.frames = frames;
  if (streamed) {
    source = std::make_shared<ProceduralMotion>(b.size(), po);
  } else {
    ProceduralMotion proc(b.size(), po);
    auto m = std::make_shared<Motion>(proc.materialize(frames));
    motion_bytes = m->memory_bytes();
    source = m;
  }
  const long before = peak_rss_kb();
  Simulator sim(
      b, {sensor("RWR", 4, Vector3d(0.25, 0, 0.03)), sensor("LWR", 7, Vector3d(-0.25, 0, 0.03))});
  std::FILE* f = std::fopen("/tmp/imukit_sim_bench_memory.csv", "wb");
  int64_t n = 0;
  sim.run(*source, [&](std::size_t s, const SensorBlock& blk) {
    for (std::size_t i = 0; i < blk.t.size(); ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      std::fprintf(f, "%zu,%lld,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", s,
                   static_cast<long long>(blk.t[i]), blk.angular_rate(0, c), blk.angular_rate(1, c),
                   blk.angular_rate(2, c), blk.specific_force(0, c), blk.specific_force(1, c),
                   blk.specific_force(2, c));
    }
    n += static_cast<int64_t>(blk.t.size());
  });
  std::fclose(f);
  std::remove("/tmp/imukit_sim_bench_memory.csv");
  const long peak = peak_rss_kb();
  std::printf("%s: 60 min at 100 Hz, 12 joints, 2 sensors, %lld sensor-samples written to a file\n",
              streamed ? "streamed motion source" : "motion loaded whole",
              static_cast<long long>(n));
  std::printf(
      "  peak RSS %.1f MB; motion in memory %.1f MB; peak beyond the loaded state %.1f MB\n",
      peak / 1024.0, static_cast<double>(motion_bytes) / 1048576.0, (peak - before) / 1024.0);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--memory-streamed") == 0) return memory_run(true);
    if (std::strcmp(argv[i], "--memory-loaded") == 0) return memory_run(false);
    if (std::strcmp(argv[i], "--table") == 0) {
      print_accuracy_table();
      return 0;
    }
  }
  print_accuracy_table();
  register_throughput_benchmarks();
  return imukit::bench::run_with_isa_ratios(argc, argv);
}
