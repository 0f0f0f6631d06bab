// imukit demo: the whole chain on the built-in mock device and a bundled motion, with no
// hardware and no network. A mock smartwatch IMU with a known hardware model (truth_profile.json)
// is recorded still for two hours of virtual time and over nine more short power cycles, then
// turned through a guided multi-position capture; calibrate and characterize estimate its
// hardware model the way `imukit calibrate` and `imukit characterize` do (cli/hwmodel_common)
// and the estimates are printed beside the truth; a left-wrist watch with the measured model is
// simulated on a bundled CMU walk, and a small PPDA and STDA dataset is generated from it.
// report.json holds every number the printed report shows (tests/cli/demo_test.py reads it).
#include <fmt/core.h>
#include <fmt/os.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "hwmodel_common.hpp"
#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/drivers/mock_device.hpp"
#include "imukit/drivers/uri.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"
#include "options.hpp"

#ifndef IMUKIT_SOURCE_DIR
#define IMUKIT_SOURCE_DIR ""
#endif

namespace imukit::cli {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr const char* kMotionFile = "cmu_131_01_walk_2s.bvh";
constexpr const char* kSensor = "left_wrist_watch";

struct DemoArgs {
  std::string output = "imukit_demo";
  bool quick = false;
  std::string motion;
  uint64_t seed = 1;
};

// How much of each step the demo does; --quick shortens every one (for the sanitizer pass).
struct Plan {
  double rate_hz = 200.0;
  double long_static_s = 7200.0;  // the noise recording
  int power_cycles = 10;          // static recordings in all (the long one included)
  double short_static_s = 60.0;
  int poses = 26;
  double hold_s = 5.0;
  double move_s = 2.0;
  std::size_t windows = 512;  // per dataset
};

Plan make_plan(bool quick) {
  Plan p;
  if (quick) {
    p.long_static_s = 600.0;
    p.power_cycles = 5;
    p.short_static_s = 10.0;
    p.hold_s = 3.0;  // the 26 poses stay: fewer rotations calibrate the gyroscope less well
    p.move_s = 1.5;
    p.windows = 64;
  }
  return p;
}

// The mock's hardware: the smartwatch-class IMU of examples/profiles/wrist_watch_imu.json, with
// a non-zero turn-on bias mean (so its estimate means something) and without g-sensitivity:
// neither a still recording nor a multi-position calibration (Tedaldi's model has no such term)
// can separate it from the bias, so with it the truth of either would be ill-defined. Range and
// resolution are the mock's wire format (+-16 g, +-2000 deg/s in int16): a finer resolution would
// be rounded twice, and the second rounding's ties all break one way (the float scale), which
// shrinks the noise of an axis reading near zero by a few percent.
DeviceProfile demo_truth(double rate_hz) {
  using V = Eigen::Vector3d;
  DeviceProfile p;
  p.device = DeviceInfo{"imukit", "mock (demo truth: smartwatch-class MEMS IMU)", "", "demo watch"};
  p.gravity = kStandardGravity;
  auto triad = [&](V n, V b, V k, V tob_mean, V tob_spread, V scale, Eigen::Matrix3d mis,
                   double range, double resolution) {
    SensorProfile s;
    NoiseEstimate e;
    e.noise_density = n;
    e.bias_instability = b;
    e.random_walk = k;
    s.noise = e;
    TurnOnBias t;
    t.mean = tob_mean;
    t.spread = tob_spread;
    s.turn_on_bias = t;
    Calibration c;
    c.scale = scale;
    c.misalignment = mis;
    c.bias = tob_mean;
    s.calibration = c;
    SensorLimits l;
    l.range = range;
    l.resolution = resolution;
    l.rate_hz = rate_hz;
    l.bandwidth_hz = 80.0;
    s.limits = l;
    return s;
  };
  Eigen::Matrix3d ma, mg;
  ma << 1.0, 0.002, -0.001, 0.0, 1.0, 0.0015, 0.0, 0.0, 1.0;  // upper triangular: the accelerometer
  mg << 1.0, -0.003, 0.002, 0.001, 1.0, -0.002, 0.004, 0.001, 1.0;  // defines the body frame
  p.accelerometer = triad(V(0.0018, 0.0018, 0.0021), V(0.0004, 0.0004, 0.0005), V(3e-5, 3e-5, 4e-5),
                          V(0.05, -0.08, 0.11), V(0.12, 0.12, 0.2), V(1.004, 0.997, 1.002), ma,
                          16 * kStandardGravity, 16 * kStandardGravity / 32768);
  GyroscopeProfile g;
  static_cast<SensorProfile&>(g) = triad(
      V(1.2e-4, 1.2e-4, 1.4e-4), V(3e-5, 3e-5, 4e-5), V(2e-6, 2e-6, 3e-6), V(0.004, -0.006, 0.002),
      V(0.01, 0.01, 0.015), V(0.996, 1.003, 1.001), mg, 34.906585039886593, 0.0010652644360316953);
  p.gyroscope = g;
  return p;
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct StepRecord {
  std::string name;
  double seconds = 0.0;
  std::vector<std::string> outputs;
};

Json vec(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

InputArg input(const std::string& path) {
  InputArg in;
  in.path = path;
  return in;
}

// One mock recorded in virtual time into an MCAP file; returns the mock's drawn truth.
struct CaptureOutcome {
  drivers::MockTruth truth;
  uint64_t samples = 0;
  int poses = 0;
  std::string stop_reason;
};

CaptureOutcome capture_mock(const std::string& uri, const std::string& path, double duration_s,
                            std::optional<capture::PoseGuideOptions> guide) {
  capture::SessionDevice d;
  d.name = "watch";
  d.uri = uri;
  d.device = drivers::open_device(uri);
  const auto* mock = dynamic_cast<const drivers::MockDevice*>(d.device.transport.get());
  if (mock == nullptr) throw Error("demo: " + uri + " is not a mock device");
  const std::shared_ptr<const drivers::MockTruth> truth = mock->truth();
  capture::SessionOptions o;
  o.path = path;
  o.duration_s = duration_s;
  o.detect_taps = false;  // still and slowly turned: there are no taps to find
  o.guide = guide;
  CaptureOutcome out;
  o.on_pose = [&](const std::string&, const capture::PoseEvent& e) {
    if (e.kind == capture::PoseEvent::Kind::new_pose || e.kind == capture::PoseEvent::Kind::done)
      out.poses = e.count;
  };
  std::vector<capture::SessionDevice> devices;
  devices.push_back(std::move(d));
  const capture::SessionReport report = capture::record_session(std::move(devices), o);
  out.stop_reason = report.stop_reason;
  if (!report.devices.empty()) out.samples = report.devices.front().samples;
  if (!truth->drawn)
    throw Error("demo: the mock device was never configured (" + report.stop_reason + ")");
  out.truth = *truth;
  return out;
}

std::string find_motion(const std::string& given) {
  if (!given.empty()) return given;  // read_bvh says what is wrong with it
  std::vector<fs::path> candidates;
  // Installed: <prefix>/bin/imukit and <prefix>/share/imukit/motion/.
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    candidates.push_back(self.parent_path().parent_path() / "share" / "imukit" / "motion" /
                         kMotionFile);
  if (std::string(IMUKIT_SOURCE_DIR).size() > 0)
    candidates.push_back(fs::path(IMUKIT_SOURCE_DIR) / "examples" / "motion" / kMotionFile);
  for (const auto& c : candidates) {
    if (fs::exists(c)) return c.string();
  }
  throw Error(fmt::format(
      "demo: the bundled motion {} is missing (looked in {}); give one with --motion FILE.bvh",
      kMotionFile,
      candidates.empty() ? std::string("nowhere") : candidates.front().parent_path().string()));
}

sim::Scene make_scene(const std::string& motion_path, const HardwareModel& hardware, double rate_hz,
                      uint64_t seed) {
  sim::BvhData d = sim::read_bvh(motion_path, sim::BvhOptions{});  // metres, Y up
  sim::Scene scene;
  scene.body = std::move(d.body);
  scene.motion = std::make_shared<sim::Motion>(std::move(d.motion));
  scene.frames = scene.motion->frame_count();
  scene.warnings = std::move(d.warnings);
  scene.options.rate_hz = rate_hz;
  scene.options.method = sim::DerivativeMethod::spline;  // sensor rate != motion frame rate
  scene.seed = seed;
  scene.ground_truth = true;
  sim::SceneSensor s = sim::preset_sensor(kSensor, scene.body);
  s.hardware = hardware;
  scene.sensors.push_back(std::move(s));
  return scene;
}

void append(ImuSeries& to, const sim::SensorBlock& b) {
  const auto n0 = static_cast<Eigen::Index>(to.size());
  const auto n = static_cast<Eigen::Index>(b.t.size());
  to.t.insert(to.t.end(), b.t.begin(), b.t.end());
  to.accel.conservativeResize(3, n0 + n);
  to.gyro.conservativeResize(3, n0 + n);
  to.accel.rightCols(n) = b.specific_force;
  to.gyro.rightCols(n) = b.angular_rate;
}

// Left: the noiseless signal (lines) with the measured samples over it (points); at this scale
// the hardware's error is far smaller than the motion, so the right column shows it alone
// (measured - noiseless: noise, bias, scale and misalignment). The spikes in the specific force
// are the bundled BVH's: its root translation has millimetre glitches, and a second derivative at
// 120 Hz turns 2 mm into 30 m/s^2 (examples/motion/README.md).
void plot_simulation(const fs::path& dir, const ImuSeries& measured, const ImuSeries& truth) {
  const std::string dat = std::string(kSensor) + "_error.dat";
  {
    auto out = fmt::output_file((dir / dat).string());
    out.print("# t_s  measured - noiseless: ax ay az [m/s^2] gx gy gz [rad/s]\n");
    for (std::size_t i = 0; i < measured.size(); ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      const Eigen::Vector3d da = measured.accel.col(c) - truth.accel.col(c);
      const Eigen::Vector3d dg = measured.gyro.col(c) - truth.gyro.col(c);
      out.print("{:.6f} {:.7g} {:.7g} {:.7g} {:.7g} {:.7g} {:.7g}\n",
                to_seconds(measured.t[i] - measured.t.front()), da.x(), da.y(), da.z(), dg.x(),
                dg.y(), dg.z());
    }
  }
  const std::string m = std::string(kSensor) + ".csv";
  const std::string t = std::string(kSensor) + ".truth.csv";
  const char* colour[3] = {"#b2182b", "#1b7837", "#2166ac"};
  const auto signals = [&](int first_column, const char* symbol) {
    std::string p;
    for (int ax = 0; ax < 3; ++ax) {
      p += fmt::format(
          "{}'{}' u (($1-t0)*1e-9):{} w l lw 1.5 lc rgb '{}' t '{}_{}', '{}' u (($1-t0)*1e-9):{} "
          "w p pt 7 ps 0.2 lc rgb 'black' {}",
          ax == 0 ? "" : ", ", t, first_column + ax, colour[ax], symbol, "xyz"[ax], m,
          first_column + ax, ax == 2 ? "t 'measured'" : "notitle");
    }
    return p;
  };
  const auto errors = [&](int first_column, const char* symbol) {
    std::string p;
    for (int ax = 0; ax < 3; ++ax) {
      p += fmt::format("{}'{}' u 1:{} w l lw 1 lc rgb '{}' t '{}_{}'", ax == 0 ? "" : ", ", dat,
                       first_column + ax, colour[ax], symbol, "xyz"[ax]);
    }
    return p;
  };
  const std::string script = fmt::format(
      "set grid\nset key outside right font ',9'\n"
      "t0 = 0\nset datafile separator ','\nstats '{m}' u 1 every ::0::0 nooutput\nt0 = STATS_min\n"
      "set multiplot layout 2,2 title 'simulated left-wrist watch on a CMU walk, measured hardware "
      "model: signal (left) and its error (right)'\n"
      "set ylabel 'specific force [m/s^2]'\nplot {a}\n"
      "set datafile separator whitespace\nset ylabel 'measured - noiseless [m/s^2]'\nplot {ea}\n"
      "set datafile separator ','\nset xlabel 'time [s]'\nset ylabel 'angular rate [rad/s]'\n"
      "plot {g}\n"
      "set datafile separator whitespace\nset ylabel 'measured - noiseless [rad/s]'\nplot {eg}\n"
      "unset multiplot\n",
      fmt::arg("m", m), fmt::arg("a", signals(5, "a")), fmt::arg("g", signals(2, "w")),
      fmt::arg("ea", errors(2, "a")), fmt::arg("eg", errors(5, "w")));
  run_gnuplot(dir, kSensor, script);
}

// ---- the comparison table ----------------------------------------------------------------

struct Row {
  std::string what;
  double truth = 0.0, estimate = 0.0, sigma = 0.0;
  std::string error;  // formatted
};

// Prints the rows and returns them as report.json holds them: every number the table shows.
Json print_rows(const std::string& title, const std::vector<Row>& rows) {
  fmt::print("  {}\n", title);
  Json out = Json::array();
  for (const Row& r : rows) {
    fmt::print("    {:<34} true {:>+12.6g}   estimated {:>+12.6g}{}   {}\n", r.what, r.truth,
               r.estimate,
               r.sigma > 0 ? fmt::format(" +- {:<9.2g}", r.sigma) : std::string(13, ' '), r.error);
    out.push_back({{"quantity", r.what},
                   {"true", r.truth},
                   {"estimated", r.estimate},
                   {"standard_error", r.sigma > 0 ? Json(r.sigma) : Json(nullptr)},
                   {"error", r.estimate - r.truth},
                   {"summary", r.error}});
  }
  return out;
}

// The rows of one sensor's comparison: the estimate of every quantity beside its truth. lsb: the
// wire's resolution; pose_bias: the mock's true bias in the poses run.
std::vector<Row> comparison_rows(const SensorProfile& t, const SensorProfile& m, const char* unit,
                                 double lsb, double rate_hz, const Eigen::Vector3d& pose_bias) {
  std::vector<Row> rows;
  // White noise: the wire's int16 rounding adds LSB^2/12 to the per-sample variance, so the
  // density the data carry is sqrt(N^2 + LSB^2 / (12 rate)); shown for reference.
  for (int ax = 0; ax < 3; ++ax) {
    const double n_true = (*t.noise->noise_density)[ax], n_est = (*m.noise->noise_density)[ax];
    const double n_eff = std::sqrt(n_true * n_true + lsb * lsb / (12 * rate_hz));
    rows.push_back({fmt::format("white noise N {} [{}/sqrt(Hz)]", "xyz"[ax], unit), n_true, n_est,
                    (*m.noise->noise_density_sigma)[ax],
                    fmt::format("{:+.2f} % ({:+.2f} % against N with the wire's rounding)",
                                100 * (n_est / n_true - 1), 100 * (n_est / n_eff - 1))});
  }
  const auto& tob_t = *t.turn_on_bias;
  const auto& tob_m = *m.turn_on_bias;
  const double runs = double(tob_m.runs.value_or(1));
  for (int ax = 0; ax < 3; ++ax) {
    const double se = tob_m.spread[ax] / std::sqrt(runs);  // standard error of the mean
    rows.push_back({fmt::format("turn-on bias mean {} [{}]", "xyz"[ax], unit), tob_t.mean[ax],
                    tob_m.mean[ax], se,
                    fmt::format("{:+.2f} standard errors ({} power cycles)",
                                (tob_m.mean[ax] - tob_t.mean[ax]) / se, int(runs))});
  }
  for (int ax = 0; ax < 3; ++ax) {
    rows.push_back({fmt::format("turn-on bias spread {} [{}]", "xyz"[ax], unit), tob_t.spread[ax],
                    tob_m.spread[ax], 0,
                    fmt::format("{:+.0f} % (from {} draws)",
                                100 * (tob_m.spread[ax] / tob_t.spread[ax] - 1), int(runs))});
  }
  const Calibration& ct = *t.calibration;
  const Calibration& cm = *m.calibration;
  for (int ax = 0; ax < 3; ++ax) {
    rows.push_back({fmt::format("scale {} (forward model)", "xyz"[ax]), ct.scale[ax], cm.scale[ax],
                    0, fmt::format("{:+.4f} %", 100 * (cm.scale[ax] / ct.scale[ax] - 1))});
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (r == c) continue;
      rows.push_back({fmt::format("misalignment {}{} [deg]", "xyz"[r], "xyz"[c]),
                      ct.misalignment(r, c) * kDegPerRad, cm.misalignment(r, c) * kDegPerRad, 0,
                      fmt::format("{:+.4f} deg",
                                  (cm.misalignment(r, c) - ct.misalignment(r, c)) * kDegPerRad)});
    }
  }
  for (int ax = 0; ax < 3; ++ax) {
    rows.push_back({fmt::format("bias of the poses run {} [{}]", "xyz"[ax], unit), pose_bias[ax],
                    cm.bias[ax], 0, fmt::format("{:+.3g} {}", cm.bias[ax] - pose_bias[ax], unit)});
  }
  return rows;
}

// ---- the demo's steps ----------------------------------------------------------------------

// Step 1's recordings: the inputs of the characterization and report.json's static_runs.
struct StaticCaptures {
  std::vector<InputArg> inputs;
  Json runs = Json::array();
};

// Step 3's outcome.
struct Estimates {
  DeviceProfile measured;            // the estimated hardware model, read back from profile.json
  std::size_t static_intervals = 0;  // the calibration's still intervals in the poses run
};

// Step 4's outcome: the watch simulated with the measured model (which step 5 uses again).
struct SimulatedWatch {
  HardwareModel model;
  ImuSeries series;
};

// One run of the demo: what its steps share, one member per numbered step.
struct DemoRun {
  const DemoArgs& args;
  Plan plan;
  fs::path out, plots;
  std::string motion_path;
  DeviceProfile truth;  // the mock's hardware model
  std::string truth_path, profile_path;
  double g = 0.0;
  std::vector<StepRecord> steps;
  Json report;

  // Checks the output folder and the motion, starts the report and writes the truth.
  explicit DemoRun(const DemoArgs& a) : args(a), plan(make_plan(a.quick)), out(a.output) {
    std::error_code ec;
    fs::create_directories(out / "recordings", ec);
    if (ec)
      throw Error(fmt::format("demo: cannot create {}: {}; choose another folder with -o DIR",
                              out.string(), ec.message()));
    motion_path = find_motion(args.motion);
    // Read now: a bad motion file is refused before minutes of capture, not after.
    (void)sim::read_bvh(motion_path, sim::BvhOptions{});
    plots = out / "plots";
    fs::create_directories(plots);
    report["schema"] = "imukit.demo/1";
    report["quick"] = args.quick;
    report["seed"] = args.seed;

    fmt::print(
        "imukit demo{}: mock smartwatch IMU -> capture -> calibrate and characterize -> simulate "
        "-> augment\n"
        "output folder: {}\n\n",
        args.quick ? " --quick (every step shortened)" : "", out.string());

    truth = demo_truth(plan.rate_hz);
    truth_path = (out / "truth_profile.json").string();
    write_profile(truth_path, truth);
    g = *truth.gravity;
    profile_path = (out / "profile.json").string();
  }

  std::string mock_uri(const std::string& kind, uint64_t seed, const std::string& extra) const {
    // A realistic link: the device clock runs 30 ppm fast, bytes arrive 2 ms late +- 0.5 ms.
    return fmt::format(
        "mock:{}?rate={}&clock=virtual&seed={}&drift_ppm=30&latency_us=2000&jitter_us=500&profile={"
        "}{}",
        kind, plan.rate_hz, seed, drivers::percent_encode(truth_path), extra);
  }
  std::string poses_path() const { return (out / "recordings" / "poses.mcap").string(); }
  uint64_t poses_seed() const { return args.seed * 1000 + 999; }

  // 1. Static capture: the long noise recording, then short power cycles for the turn-on bias.
  StaticCaptures capture_static() {
    fmt::print(
        "[1/5] static capture: {:g} h of virtual time at {:g} Hz, then {} more power cycles of "
        "{:g} s\n",
        plan.long_static_s / 3600, plan.rate_hz, plan.power_cycles - 1, plan.short_static_s);
    std::fflush(stdout);
    const Clock::time_point t0 = Clock::now();
    StaticCaptures s;
    for (int k = 0; k < plan.power_cycles; ++k) {
      const uint64_t seed = args.seed * 1000 + uint64_t(k);
      const std::string path = (out / "recordings" / fmt::format("static_{:02}.mcap", k)).string();
      const double duration = k == 0 ? plan.long_static_s : plan.short_static_s;
      const CaptureOutcome c =
          capture_mock(mock_uri("static", seed, ""), path, duration, std::nullopt);
      s.inputs.push_back(input(path));
      s.runs.push_back({{"file", fs::relative(path, out).string()},
                        {"seed", seed},
                        {"samples", c.samples},
                        {"true_accelerometer_bias", vec(c.truth.accelerometer_bias)},
                        {"true_gyroscope_bias", vec(c.truth.gyroscope_bias)}});
      if (k == 0) fmt::print("      {}: {} samples ({})\n", path, c.samples, c.stop_reason);
    }
    fmt::print("      {} more recordings: {}/recordings/static_01..{:02}.mcap\n",
               plan.power_cycles - 1, out.string(), plan.power_cycles - 1);
    steps.push_back({"static capture", seconds_since(t0), {"recordings/static_*.mcap"}});
    return s;
  }

  // 2. Guided multi-position capture.
  CaptureOutcome capture_poses() {
    fmt::print(
        "[2/5] guided multi-position capture: {} poses held {:g} s, {:g} s to turn between them\n",
        plan.poses, plan.hold_s, plan.move_s);
    std::fflush(stdout);
    const Clock::time_point t0 = Clock::now();
    capture::PoseGuideOptions guide;
    guide.poses_wanted = plan.poses;
    const CaptureOutcome poses =
        capture_mock(mock_uri("poses", poses_seed(),
                              fmt::format("&poses={}&hold_s={}&move_s={}&init_s={}", plan.poses,
                                          plan.hold_s, plan.move_s, plan.hold_s)),
                     poses_path(), plan.poses * (plan.hold_s + plan.move_s) + 5.0, guide);
    fmt::print("      {}: {} samples, {} distinct poses ({})\n", poses_path(), poses.samples,
               poses.poses, poses.stop_reason);
    steps.push_back({"multi-position capture", seconds_since(t0), {"recordings/poses.mcap"}});
    return poses;
  }

  // 3. Calibrate (first: its scale and misalignment say what a still, level accelerometer
  // reads, which the accelerometer's turn-on bias is measured against), then characterize.
  // Adds each static run's measured biases to its entry in `statics.runs`.
  Estimates calibrate_and_characterize(StaticCaptures& statics) {
    fmt::print(
        "[3/5] calibrate (multi-position, Ceres) and characterize (Allan deviation, noise fit, "
        "turn-on bias)\n");
    std::fflush(stdout);
    const Clock::time_point t0 = Clock::now();
    if (fs::exists(profile_path))
      fs::remove(profile_path);  // a fresh profile, not a merge with an old run's
    const auto pose_runs = load_runs({input(poses_path())});
    CalibrateOptions copt;
    copt.gravity = g;
    copt.init_static_s = plan.hold_s - 1.0;  // the first pose is the initial static period
    const CalibrateResult cal = calibrate_series(pose_runs.front().series, copt);
    plot_calibration(plots, pose_runs.front().series, cal);
    update_profile(profile_path, cal.update);
    const Calibration& acal = *cal.update.accelerometer->calibration;
    const Eigen::Vector3d level_reading =
        acal.scale.asDiagonal() * acal.misalignment * Eigen::Vector3d(0, 0, g);
    // Each recording is its own power cycle (load_runs would merge files with equal time stamps).
    std::vector<LoadedRun> static_loaded;
    for (const InputArg& in : statics.inputs)
      static_loaded.push_back({in.path, load_imu_series(in), {}});
    CharacterizeOptions nopt;
    nopt.gravity = g;
    nopt.level = true;  // the static mock lies level, z up
    nopt.level_reading = level_reading;
    const CharacterizeResult ch = characterize_runs(static_loaded, nopt);
    plot_noise(plots, ch);
    update_profile(profile_path, ch.update);
    for (std::size_t k = 0; k < ch.gyro_run_bias.size() && k < statics.runs.size(); ++k) {
      statics.runs[k]["measured_gyroscope_bias"] = vec(ch.gyro_run_bias[k]);
      statics.runs[k]["measured_accelerometer_bias"] = vec(ch.accel_run_bias[k]);
    }
    steps.push_back({"calibrate + characterize",
                     seconds_since(t0),
                     {"profile.json", "plots/accelerometer_allan.svg", "plots/gyroscope_allan.svg",
                      "plots/calibration_residuals.svg"}});
    return {read_profile(profile_path), cal.fit.poses.size()};
  }

  // The estimates beside the truth: printed, and returned as report.json's comparison.
  Json compare_with_truth(const DeviceProfile& measured, const CaptureOutcome& poses) const {
    fmt::print("\nestimated hardware model ({}) beside the mock's truth ({}):\n", profile_path,
               truth_path);
    Json comparison;
    for (int sensor = 0; sensor < 2; ++sensor) {
      const SensorProfile& t =
          sensor == 0 ? *truth.accelerometer : static_cast<const SensorProfile&>(*truth.gyroscope);
      const SensorProfile& m = sensor == 0 ? *measured.accelerometer
                                           : static_cast<const SensorProfile&>(*measured.gyroscope);
      const char* name = sensor == 0 ? "accelerometer" : "gyroscope";
      const char* unit = sensor == 0 ? "m/s^2" : "rad/s";
      const double lsb = sensor == 0 ? 16 * g / 32768 : 2000 * kRadPerDeg / 32768;
      const Eigen::Vector3d pose_bias =
          sensor == 0 ? poses.truth.accelerometer_bias : poses.truth.gyroscope_bias;
      Json j;
      j["rows"] = print_rows(name, comparison_rows(t, m, unit, lsb, plan.rate_hz, pose_bias));
      j["true_calibration_bias_of_poses_run"] = vec(pose_bias);
      j["wire_lsb"] = lsb;
      comparison[name] = j;
    }
    return comparison;
  }

  // report.json's poses_run.
  Json poses_run(const CaptureOutcome& poses, std::size_t static_intervals) const {
    return {{"file", "recordings/poses.mcap"},
            {"seed", poses_seed()},
            {"samples", poses.samples},
            {"distinct_poses", poses.poses},
            {"static_intervals", static_intervals},
            {"true_accelerometer_bias", vec(poses.truth.accelerometer_bias)},
            {"true_gyroscope_bias", vec(poses.truth.gyroscope_bias)}};
  }

  // 4. Simulate the watch on the bundled walk with the measured hardware model.
  SimulatedWatch simulate_watch(const DeviceProfile& measured) {
    fmt::print("\n[4/5] simulate a left-wrist watch with the measured hardware model on {}\n",
               motion_path);
    std::fflush(stdout);
    const Clock::time_point t0 = Clock::now();
    SimulatedWatch watch{to_hardware_model(measured), {}};
    const fs::path sim_dir = out / "simulate";
    fs::create_directories(sim_dir);
    ImuSeries watch_truth;
    {
      sim::Scene scene = make_scene(motion_path, watch.model, plan.rate_hz, args.seed);
      for (const std::string& w : scene.warnings) fmt::print("      warning: {}\n", w);
      sim::run_scene(scene, [&](std::size_t, const sim::SensorBlock& m, const sim::SensorBlock* t) {
        append(watch.series, m);
        if (t != nullptr) append(watch_truth, *t);
      });
    }
    write_euroc_csv((sim_dir / (std::string(kSensor) + ".csv")).string(), watch.series.view());
    write_euroc_csv((sim_dir / (std::string(kSensor) + ".truth.csv")).string(), watch_truth.view());
    plot_simulation(sim_dir, watch.series, watch_truth);
    fmt::print("      {} samples at {:g} Hz ({:.2f} s) -> {}/{}.csv (+ .truth.csv, noiseless)\n",
               watch.series.size(), plan.rate_hz, watch.series.size() / plan.rate_hz,
               sim_dir.string(), kSensor);
    steps.push_back({"simulate",
                     seconds_since(t0),
                     {"simulate/left_wrist_watch.csv", "simulate/left_wrist_watch.truth.csv",
                      "simulate/left_wrist_watch.svg"}});
    report["simulation"] = {{"motion", motion_path},
                            {"sensor", kSensor},
                            {"rate_hz", plan.rate_hz},
                            {"samples", watch.series.size()},
                            {"method", "spline"}};
    return watch;
  }

  // 5. A small PPDA dataset (the motion, placement and hardware varied, then simulated again)
  // and its STDA counterpart (the simulated signal itself transformed), same policy and seed.
  void write_datasets(const SimulatedWatch& watch) {
    fmt::print("[5/5] augment: {} windows of PPDA and of STDA (policy 'imukit')\n", plan.windows);
    std::fflush(stdout);
    const Clock::time_point t0 = Clock::now();
    const augment::Policy policy = augment::builtin_policy("imukit");
    augment::DatasetOptions dopt;
    dopt.window = 100;  // 0.5 s at 200 Hz
    dopt.stride = 25;
    dopt.count = plan.windows;
    dopt.batch_size = 32;
    dopt.seed = args.seed;
    dopt.threads = 0;  // the output does not depend on the thread count
    const std::vector<int64_t> labels(watch.series.size(), 0);  // one activity: walking (label 0)
    Json datasets;
    {
      const sim::Scene scene = make_scene(motion_path, watch.model, plan.rate_hz, args.seed);
      const augment::Dataset ppda = augment::generate_dataset(scene, policy, labels, dopt);
      augment::write_dataset((out / "ppda").string(), ppda.X, ppda.shape, ppda.y, ppda.sub_policy,
                             ppda.info);
      const augment::Dataset stda =
          augment::generate_dataset({kSensor}, {&watch.series}, policy, labels, dopt);
      augment::write_dataset((out / "stda").string(), stda.X, stda.shape, stda.y, stda.sub_policy,
                             stda.info);
      fmt::print(
          "      {}/ppda and {}/stda: X.npy ({} windows x {} samples x {} channels), y.npy, "
          "dataset.json\n",
          out.string(), out.string(), ppda.y.size(), dopt.window,
          ppda.X.size() / std::max<std::size_t>(1, ppda.y.size() * dopt.window));
      datasets = {{"ppda", "ppda"}, {"stda", "stda"}, {"windows", ppda.y.size()}};
    }
    steps.push_back({"augment",
                     seconds_since(t0),
                     {"ppda/X.npy", "ppda/y.npy", "ppda/dataset.json", "stda/X.npy", "stda/y.npy",
                      "stda/dataset.json"}});
    report["datasets"] = datasets;
  }

  // The report: the steps' times printed, and report.json written.
  void write_report(Clock::time_point t_start) {
    const double total = seconds_since(t_start);
    fmt::print("\nreport ({} in {:.1f} s):\n", out.string(), total);
    Json jsteps = Json::array();
    for (const StepRecord& s : steps) {
      std::string outputs;
      for (const auto& o : s.outputs) outputs += (outputs.empty() ? "" : ", ") + o;
      fmt::print("  {:<26} {:>7.2f} s   {}\n", s.name, s.seconds, outputs);
      jsteps.push_back({{"name", s.name}, {"seconds", s.seconds}, {"outputs", s.outputs}});
    }
    report["steps"] = jsteps;
    report["total_seconds"] = total;
    report["truth_profile"] = "truth_profile.json";
    report["profile"] = "profile.json";
    {
      auto f = fmt::output_file((out / "report.json").string());
      f.print("{}\n", report.dump(2));
    }
    fmt::print(
        "  numbers of this report: {}/report.json; plots: {}/\n"
        "  next: `imukit info {}/recordings/poses.mcap`, open the .mcap files in Foxglove, or load "
        "{}/ppda/X.npy with numpy\n",
        out.string(), plots.string(), out.string(), out.string());
  }
};

int run_demo(const DemoArgs& args) {
  const Clock::time_point t_start = Clock::now();
  DemoRun run(args);
  StaticCaptures statics = run.capture_static();
  const CaptureOutcome poses = run.capture_poses();
  const Estimates estimates = run.calibrate_and_characterize(statics);
  run.report["comparison"] = run.compare_with_truth(estimates.measured, poses);
  run.report["static_runs"] = statics.runs;
  run.report["poses_run"] = run.poses_run(poses, estimates.static_intervals);
  const SimulatedWatch watch = run.simulate_watch(estimates.measured);
  run.write_datasets(watch);
  run.write_report(t_start);
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    demo, CommandSpec{
              "demo",
              "The whole chain on a built-in mock IMU and a bundled walk: no hardware, no network",
              100, [](CLI::App& sub) -> std::function<int()> {
                auto args = std::make_shared<DemoArgs>();
                sub.add_option("-o,--output", args->output,
                               "folder for everything the demo writes (default imukit_demo)");
                sub.add_flag("--quick", args->quick,
                             "shorten every step (10 min still recording, 4 more power cycles of "
                             "10 s, 3 s poses, 64 windows)");
                sub.add_option("--motion", args->motion,
                               "a BVH file (metres, Y up) instead of the bundled CMU walk");
                sub.add_option("--seed", args->seed,
                               "seed of the mock devices, the simulation and the augmentation")
                    ->check(whole_in(0, 1'000'000'000'000));  // times 1000 for the mock seeds
                sub.footer(
                    "\nSteps: (1) record a still mock smartwatch IMU with a known hardware model "
                    "for 2 h of\n"
                    "virtual time at 200 Hz, plus 9 short power cycles; (2) a guided "
                    "multi-position capture\n"
                    "(26 poses); (3) calibrate and characterize it, printing each estimate beside "
                    "the truth;\n"
                    "(4) simulate a left-wrist watch with the measured model on a bundled CMU "
                    "walk; (5) write\n"
                    "a small PPDA and STDA dataset. Under two minutes; every number is in "
                    "DIR/report.json.\n\n"
                    "Examples:\n"
                    "  imukit demo\n"
                    "  imukit demo -o /tmp/demo --quick\n"
                    "  imukit demo --motion my_walk.bvh --seed 7\n");
                return [args] { return run_demo(*args); };
              }});

}  // namespace imukit::cli
