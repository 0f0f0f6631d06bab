#include "hwmodel_common.hpp"

#include <fmt/core.h>
#include <fmt/os.h>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/time.hpp"
#include "imukit/core/units.hpp"

namespace imukit::cli {

void check_profile_to_update(const std::string& path) {
  check_updatable_file(path, "profile to create or update");
  if (std::filesystem::exists(path)) (void)read_profile(path);
}

std::vector<LoadedRun> load_runs(const std::vector<InputArg>& inputs) {
  std::vector<LoadedRun> runs;
  for (const InputArg& in : inputs) {
    Recording context;
    ImuSeries s = load_imu_series(in, &context);
    s.validate(in.path);
    if (!runs.empty() && runs.back().series.t == s.t) {
      ImuSeries& dst = runs.back().series;
      auto take = [&](Eigen::Matrix3Xd& to, Eigen::Matrix3Xd& from, const char* what) {
        if (from.cols() == 0) return;
        if (to.cols() != 0) {
          throw Error(
              fmt::format("{}: {} channel already given by {}", in.path, what, runs.back().name));
        }
        to = std::move(from);
      };
      take(dst.accel, s.accel, "accelerometer");
      take(dst.gyro, s.gyro, "gyroscope");
      take(dst.mag, s.mag, "magnetometer");
      continue;
    }
    runs.push_back({in.path, std::move(s), std::move(context)});
  }
  return runs;
}

std::optional<InitialStill> guided_initial_still(const LoadedRun& run) {
  const auto it = run.context.metadata.find("imukit.guide.initial_still_s");
  if (it == run.context.metadata.end()) return std::nullopt;
  double seconds = 0.0;
  const std::string& text = it->second;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), seconds);
  if (ec != std::errc() || end != text.data() + text.size() || !(seconds > 0 && seconds <= 3600))
    return std::nullopt;
  for (const Event& e : run.context.events) {
    if (e.kind == "initial_still") return InitialStill{seconds, e.t};
  }
  return std::nullopt;  // the capture stopped before the period was held
}

bool run_gnuplot(const std::filesystem::path& dir, const std::string& name,
                 const std::string& script) {
  const auto gp = dir / (name + ".gp");
  {
    // The script first moves to its own folder (gnuplot's ARG0 is the script's path), so its
    // data and SVG are found by name wherever `gnuplot DIR/NAME.gp` is run from.
    auto out = fmt::output_file(gp.string());
    out.print(
        "# {name}.svg from the data beside this script; run `gnuplot {name}.gp` from anywhere.\n"
        "last_slash(s, i) = i == 0 ? 0 : (s[i:i] eq '/' ? i : last_slash(s, i - 1))\n"
        "script_dir_end = last_slash(ARG0, strlen(ARG0))\n"
        "if (script_dir_end > 0) {{ cd ARG0[1:script_dir_end] }}\n"
        "set terminal svg size 900,600 dynamic enhanced font 'sans,12'\nset output '{name}.svg'\n"
        "{script}",
        fmt::arg("name", name), fmt::arg("script", script));
  }
  // Run without a shell: a folder name is data, never a command.
  const std::string path = gp.string();
  char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>(path.c_str()), nullptr};
  pid_t pid = 0;
  if (::posix_spawnp(&pid, "gnuplot", nullptr, nullptr, argv, environ) != 0) {
    fmt::print(stderr, "imukit: note: gnuplot not found; run `gnuplot {}` to draw the plot\n",
               path);
    return false;
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error(fmt::format("gnuplot failed on {}", path));
  return true;
}

namespace {

constexpr double kBadNoiseFitChi2PerDof = 100.0;

void print_triad(const char* name, const char* unit, const hwmodel::TriadNoise& tn) {
  const SamplingStats& st = tn.allan.sampling;
  fmt::print("{} ({} samples, tau0 {:.6g} s measured from the time stamps{})\n", name, st.samples,
             tn.allan.tau0_s,
             st.samples_missing() || tn.allan.uniform
                 ? ""
                 : "; NOT uniformly sampled: jitter above 1 % of the period");
  if (st.samples_missing()) {
    // Not jitter: samples are missing, and the curve treats those either side as neighbours.
    fmt::print(
        "  warning: {} gap(s) in the time stamps (periods above 1.5x the median {:.6g} s; {:.4g} s "
        "in all, {:.2g} % of the span, the longest {:.4g} s): tau0 is the mean period between "
        "them; the samples either side of a gap are taken as neighbours, so a long gap biases "
        "the long-tau terms (B, K); a record without gaps is better\n",
        st.gaps, st.median_period_s, to_seconds(st.gap_duration),
        100.0 * static_cast<double>(st.gap_duration) / static_cast<double>(st.duration),
        st.max_period_s);
  }
  fmt::print(
      "  axis  fit: N [{u}/sqrt(Hz)]      B [{u}]              K [{u}/s/sqrt(Hz)]   chi2/dof | "
      "slopes: N@1s      B=min/0.664   K@3s\n",
      fmt::arg("u", unit));
  for (int ax = 0; ax < 3; ++ax) {
    if (tn.axes[size_t(ax)].constant) {
      fmt::print(
          "  {}     constant: every sample the same (a dead axis, or noise below one count): "
          "no noise to fit, 0 in the profile\n",
          "xyz"[ax]);
      continue;
    }
    const auto& f = tn.axes[size_t(ax)].fit;
    const auto& s = tn.axes[size_t(ax)].slopes;
    auto pm = [](double v, double sd, bool active, double upper) {
      if (active) return fmt::format("{:.4g} +- {:.2g}", v, sd);
      if (!std::isfinite(upper)) return std::string("0 (undetermined)");
      return upper > 0 ? fmt::format("0 (< {:.3g})", upper) : std::string("0 (not seen)");
    };
    auto rd = [](const hwmodel::SlopeReading& r) {
      return r.found ? fmt::format("{:.4g}", r.value) : std::string("-");
    };
    fmt::print("  {}     {:<22} {:<20} {:<20} {:>7.2f}  | {:<11} {:<13} {}\n", "xyz"[ax],
               pm(f.value[1], f.sigma[1], f.active[1], f.upper[1]),
               pm(f.value[2], f.sigma[2], f.active[2], f.upper[2]),
               pm(f.value[3], f.sigma[3], f.active[3], f.upper[3]), f.chi2_per_dof, rd(s.white),
               rd(s.bias_instability), rd(s.random_walk));
    if (!f.note.empty()) fmt::print("        note: {}\n", f.note);
    // Real sensors fit with chi2/dof of about 1 to 34 (docs/validation.md); a record with
    // motion in it, 1e4 and more (found in review: a multi-position session gave a profile).
    if (f.chi2_per_dof > kBadNoiseFitChi2PerDof) {
      fmt::print(
          "        warning: the noise model does not describe this curve (chi2/dof {:.3g}): was "
          "the device still? Motion, vibration or a temperature drift is not noise; these "
          "numbers are no noise model\n",
          f.chi2_per_dof);
    }
  }
}

// Axis colours of every imukit plot: x red, y green, z blue.
constexpr const char* kAxisColour[3] = {"#d62728", "#2ca02c", "#1f77b4"};

void plot_triad(const std::filesystem::path& dir, const std::string& name, const char* unit,
                const hwmodel::TriadNoise& tn) {
  const std::string dat = name + "_allan.dat";
  {
    auto out = fmt::output_file((dir / dat).string());
    out.print(
        "# tau_s adev_x lo_x hi_x model_x adev_y lo_y hi_y model_y adev_z lo_z hi_z model_z\n");
    for (size_t k = 0; k < tn.allan.tau_s.size(); ++k) {
      const double tau = tn.allan.tau_s[k];
      out.print("{:.9g}", tau);
      for (int ax = 0; ax < 3; ++ax) {
        const auto K = Eigen::Index(k);
        out.print(" {:.9g} {:.9g} {:.9g} {:.9g}", tn.allan.allan.deviation(ax, K),
                  tn.allan.allan.lower(ax, K), tn.allan.allan.upper(ax, K),
                  std::sqrt(hwmodel::model_allan_variance(tn.axes[size_t(ax)].fit.value, tau)));
      }
      out.print("\n");
    }
  }
  // Per axis: the estimates with their intervals (open symbols of three shapes, so an axis
  // under another still shows), the fitted model, and the slope line of each fitted term (only
  // the terms detected: a line at 0 would be listed and not drawn).
  // Open circle (largest, so an axis with the same values as another still rings it), triangle,
  // square.
  const int point_type[3] = {6, 8, 4};
  const double point_size[3] = {0.9, 0.6, 0.6};
  std::string plots;
  const auto add = [&](const std::string& p) { plots += (plots.empty() ? "" : ", \\\n     ") + p; };
  for (int ax = 0; ax < 3; ++ax) {
    const int col = 2 + 4 * ax;
    const char axis = "xyz"[ax];
    add(fmt::format("'{}' u 1:{}:{}:{} w yerrorbars lc rgb '{}' pt {} ps {} t '{}'", dat, col,
                    col + 1, col + 2, kAxisColour[ax], point_type[ax], point_size[ax], axis));
    add(fmt::format("'{}' u 1:{} w l lc rgb '{}' lw 1.5 t '{} model'", dat, col + 3,
                    kAxisColour[ax], axis));
  }
  for (int ax = 0; ax < 3; ++ax) {
    const auto& f = tn.axes[size_t(ax)].fit;
    const char axis = "xyz"[ax];
    const char* c = kAxisColour[ax];
    if (f.value[hwmodel::kWhite] > 0)
      add(fmt::format("{:.9g}/sqrt(x) w l dt 2 lc rgb '{}' t '{}: N/sqrt(tau)'",
                      f.value[hwmodel::kWhite], c, axis));
    if (f.value[hwmodel::kBiasInstability] > 0)
      add(fmt::format("0.6643*{:.9g} w l dt 4 lc rgb '{}' t '{}: 0.664 B'",
                      f.value[hwmodel::kBiasInstability], c, axis));
    if (f.value[hwmodel::kRandomWalk] > 0)
      add(fmt::format("{:.9g}*sqrt(x/3) w l dt 3 lc rgb '{}' t '{}: K sqrt(tau/3)'",
                      f.value[hwmodel::kRandomWalk], c, axis));
  }
  const std::string script = fmt::format(
      "set logscale xy\nset format x '10^{{%L}}'\nset format y '10^{{%L}}'\nset grid\n"
      "set key outside right top font ',10'\nset xlabel 'averaging time tau [s]'\n"
      "set ylabel 'Allan deviation [{}]'\n"
      "set title '{}: overlapping Allan deviation, 1-sigma intervals, fitted model'\n"
      "plot {}\n",
      unit, name, plots);
  run_gnuplot(dir, name + "_allan", script);
}

void print_calibration(const char* name, const hwmodel::TriadCalibration& c, bool raw,
                       const char* unit) {
  fmt::print("{}: true = T diag(scale) (reading - bias)\n", name);
  fmt::print("  scale  {:.8g} {:.8g} {:.8g} {}\n", c.scale.x(), c.scale.y(), c.scale.z(),
             raw ? fmt::format("{} per count", unit) : std::string("(dimensionless)"));
  if (raw) {
    fmt::print("         ({:.6g} {:.6g} {:.6g} counts per {})\n", 1 / c.scale.x(), 1 / c.scale.y(),
               1 / c.scale.z(), unit);
  }
  fmt::print("  bias   {:.6g} {:.6g} {:.6g} {}\n", c.bias.x(), c.bias.y(), c.bias.z(),
             raw ? "counts" : unit);
  fmt::print("  T      [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(0, 0), c.T(0, 1), c.T(0, 2));
  fmt::print("         [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(1, 0), c.T(1, 1), c.T(1, 2));
  fmt::print("         [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(2, 0), c.T(2, 1), c.T(2, 2));
}

// Why a calibration found too few poses, and what to do. Its stillness threshold is a multiple
// of the initial period's variance, so an initial period that was not still makes the device
// look still while it turns: the usual cause. A shorter initial period is named only when the
// accelerometer then calibrates (found in review: halving suggestions that never helped).
std::string too_few_poses_hint(const ImuSeries& s, const hwmodel::CalibrationOptions& opt) {
  for (double init = opt.detector.init_static_s / 2; init >= 1.0; init /= 2) {
    hwmodel::CalibrationOptions shorter = opt;
    shorter.detector.init_static_s = init;
    shorter.calibrate_gyro = false;
    try {
      const hwmodel::CalibrationResult r =
          hwmodel::calibrate(s.t, s.accel, Eigen::Matrix3Xd(3, 0), shorter);
      return fmt::format(
          "the device was not still for all of them (with --init-static {:g} the accelerometer "
          "calibrates from {} poses); the initial static period sets the stillness threshold",
          init, r.poses.size());
    } catch (const Error&) {
    }
  }
  return fmt::format(
      "record the device first still for the initial static period, then still in {} or more "
      "orientations: `imukit record URI --guide multipos --poses 12 -o poses.mcap` asks for both",
      opt.min_poses);
}

}  // namespace

CharacterizeResult characterize_runs(const std::vector<LoadedRun>& runs,
                                     const CharacterizeOptions& options) {
  if (runs.empty()) throw Error("characterize: no recordings to characterize");
  CharacterizeResult r;
  // Noise from the longest recording (in time: the long-tau terms need hours, and a 2 h record
  // at 1 Hz has fewer samples than 80 s at 100 Hz) that holds the sensor, for each sensor: an
  // accelerometer and a gyroscope in separate files on different time stamps are separate
  // runs, and taking the longest run for both dropped the other sensor without a word (review,
  // 2026-11-27). Turn-on bias across all of them.
  const auto span_of = [](const ImuSeries& s) {
    return s.empty() ? TimeNs{0} : s.t.back() - s.t.front();
  };
  const auto longest_with = [&](bool (ImuSeries::*has)() const) -> const LoadedRun* {
    const LoadedRun* best = nullptr;
    for (const LoadedRun& run : runs)
      if ((run.series.*has)() && (best == nullptr || span_of(run.series) > span_of(best->series)))
        best = &run;
    return best;
  };
  const LoadedRun* accel_run = longest_with(&ImuSeries::has_accel);
  const LoadedRun* gyro_run = longest_with(&ImuSeries::has_gyro);
  const LoadedRun* first = accel_run != nullptr ? accel_run : gyro_run;
  if (first == nullptr)
    throw Error("characterize: the inputs hold neither accelerometer nor gyroscope data");
  r.noise_run =
      accel_run != nullptr && gyro_run != nullptr && accel_run != gyro_run
          ? fmt::format("{} (accelerometer) and {} (gyroscope)", accel_run->name, gyro_run->name)
          : first->name;
  fmt::print("noise from {} ({} recordings given)\n", r.noise_run, runs.size());
  // Gravity enters only the level turn-on bias: written with --level, else the profile keeps
  // the gravity its calibration was fitted at (it was overwritten by the default; review,
  // 2026-11-27).
  if (options.level) r.update.gravity = options.gravity;
  const hwmodel::TriadNoiseOptions noise_options{options.points_per_decade, options.fit_tau_min_s};
  // The triad's name on any error its noise fit gives (which axis it names itself).
  const auto characterize = [&](const char* name, const LoadedRun& run, const Eigen::Matrix3Xd& x) {
    try {
      return hwmodel::characterize_triad(run.series.t, x, noise_options);
    } catch (const Error& e) {
      throw Error(fmt::format("characterize: {} of {}: {}", name, run.name, e.what()));
    }
  };
  if (accel_run != nullptr) {
    r.accel = characterize("accelerometer", *accel_run, accel_run->series.accel);
    print_triad("accelerometer", "m/s^2", *r.accel);
    r.update.accelerometer = SensorProfile{};
    r.update.accelerometer->noise = hwmodel::noise_estimate(*r.accel);
  }
  if (gyro_run != nullptr) {
    r.gyro = characterize("gyroscope", *gyro_run, gyro_run->series.gyro);
    print_triad("gyroscope", "rad/s", *r.gyro);
    r.update.gyroscope = GyroscopeProfile{};
    r.update.gyroscope->noise = hwmodel::noise_estimate(*r.gyro);
  }
  fmt::print(
      "The fit (generalised least squares on the whole curve, terms not detected set to 0) is the\n"
      "estimate to use; the slope readings are shown for comparison with other tools "
      "(docs/hwmodel.md).\n");

  // Turn-on bias: gyroscope mean per recording; accelerometer only when level (z up), against
  // the reading a still level sensor gives.
  const Eigen::Vector3d level_reading =
      options.level_reading.value_or(Eigen::Vector3d(0, 0, options.gravity));
  for (const auto& run : runs) {
    if (run.series.has_gyro())
      r.gyro_run_bias.push_back(hwmodel::gyro_static_bias(run.series.gyro));
    if (options.level && run.series.has_accel()) {
      // A device lying otherwise than level, z up (upside down: a "bias" of -2 g went into the
      // profile; review, 2026-11-27) is no turn-on bias. 0.2 g is beyond any MEMS offset.
      const Eigen::Vector3d mean = run.series.accel.rowwise().mean();
      if ((mean - level_reading).norm() > 0.2 * options.gravity) {
        throw Error(fmt::format(
            "characterize --level: {} reads a mean acceleration of ({:.4g}, {:.4g}, {:.4g}) m/s^2, "
            "not near ({:.4g}, {:.4g}, {:.4g}): the device did not lie level, z up; lay it so "
            "for the turn-on bias, or leave out --level",
            run.name, mean.x(), mean.y(), mean.z(), level_reading.x(), level_reading.y(),
            level_reading.z()));
      }
      r.accel_run_bias.push_back(mean - level_reading);
    }
  }
  // The spread needs several power cycles: from one recording there is none to measure.
  const auto spread_text = [](const TurnOnBias& t, std::size_t runs) {
    if (runs < 2)
      return std::string("spread not measured (needs recordings from 2 or more power cycles)");
    return fmt::format("spread {:.3g} {:.3g} {:.3g}", t.spread.x(), t.spread.y(), t.spread.z());
  };
  if (!r.gyro_run_bias.empty() && r.update.gyroscope) {
    const TurnOnBias& t =
        *(r.update.gyroscope->turn_on_bias = hwmodel::turn_on_bias_stats(r.gyro_run_bias));
    fmt::print("gyroscope turn-on bias over {} recording(s): mean {:.4g} {:.4g} {:.4g} rad/s, {}\n",
               r.gyro_run_bias.size(), t.mean.x(), t.mean.y(), t.mean.z(),
               spread_text(t, r.gyro_run_bias.size()));
  }
  if (!r.accel_run_bias.empty() && r.update.accelerometer) {
    const TurnOnBias& t =
        *(r.update.accelerometer->turn_on_bias = hwmodel::turn_on_bias_stats(r.accel_run_bias));
    fmt::print(
        "accelerometer turn-on bias (level, z up) over {} recording(s): mean {:.4g} {:.4g} {:.4g} "
        "m/s^2, {}\n",
        r.accel_run_bias.size(), t.mean.x(), t.mean.y(), t.mean.z(),
        spread_text(t, r.accel_run_bias.size()));
  }
  return r;
}

std::vector<std::string> axes_without_noise_model(const CharacterizeResult& result) {
  std::vector<std::string> out;
  for (const auto& [name, triad] :
       {std::pair{"accelerometer", &result.accel}, std::pair{"gyroscope", &result.gyro}}) {
    if (!*triad) continue;
    for (int ax = 0; ax < 3; ++ax) {
      const auto& axis = (*triad)->axes[size_t(ax)];
      if (!axis.constant && axis.fit.chi2_per_dof > kBadNoiseFitChi2PerDof)
        out.push_back(
            fmt::format("{} {} (chi2/dof {:.2g})", name, "xyz"[ax], axis.fit.chi2_per_dof));
    }
  }
  return out;
}

void plot_noise(const std::filesystem::path& dir, const CharacterizeResult& result) {
  std::filesystem::create_directories(dir);
  if (result.accel) plot_triad(dir, "accelerometer", "m/s^2", *result.accel);
  if (result.gyro) plot_triad(dir, "gyroscope", "rad/s", *result.gyro);
}

CalibrateResult calibrate_series(const ImuSeries& s, const CalibrateOptions& options) {
  if (!s.has_accel())
    throw Error("calibrate: the input has no accelerometer channels (ax, ay, az)");
  CalibrateResult out;
  out.gyro = options.gyro && s.has_gyro();
  hwmodel::CalibrationOptions opt;
  opt.gravity = options.gravity;
  opt.calibrate_gyro = out.gyro;
  opt.detector.init_static_s = options.init_static_s;
  try {
    out.fit = hwmodel::calibrate(s.t, s.accel, out.gyro ? s.gyro : Eigen::Matrix3Xd(3, 0), opt);
  } catch (const hwmodel::TooFewPosesError& e) {
    throw Error(fmt::format("{} with the first {:g} s as the initial static period; {}", e.what(),
                            options.init_static_s, too_few_poses_hint(s, opt)));
  }
  const hwmodel::CalibrationResult& r = out.fit;
  // SI data whose scale comes out far from 1 is in another unit, or --gravity is: SI data with
  // --gravity 1 wrote an accelerometer scale of about 10, data in g a scale of 0.1, exit 0
  // (found in review, 2026-11-27).
  if (!options.raw) {
    const double lo = r.accel.scale.minCoeff(), hi = r.accel.scale.maxCoeff();
    if (!(lo > 0.5 && hi < 2.0)) {
      throw Error(fmt::format(
          "calibrate: the accelerometer's scale comes out {:.3g} to {:.3g} against a gravity of "
          "{:g} m/s^2: the data are not in m/s^2 (counts need --raw, g needs the input's unit "
          "option) or --gravity is not the local gravity in m/s^2",
          lo, hi, options.gravity));
    }
  }
  fmt::print("{} static poses (threshold {} x the initial static variance), fit in {:.3f} s\n",
             r.poses.size(), r.threshold_factor, r.seconds);
  print_calibration("accelerometer", r.accel, options.raw, "m/s^2");
  fmt::print("  residual |a| - g over the poses: rms {:.5f} m/s^2, max {:.5f} m/s^2 (g = {})\n",
             r.accel_rms, r.accel_max, options.gravity);
  if (out.gyro) {
    print_calibration("gyroscope", r.gyro, options.raw, "rad/s");
    fmt::print(
        "  residual gravity direction between consecutive poses: rms {:.4f} deg, max {:.4f} deg\n",
        r.gyro_rms_rad * kDegPerRad, r.gyro_max_rad * kDegPerRad);
  }
  out.update = hwmodel::calibration_profile(r, options.raw, out.gyro, options.gravity);
  return out;
}

void plot_calibration(const std::filesystem::path& dir, const ImuSeries& s,
                      const CalibrateResult& result) {
  std::filesystem::create_directories(dir);
  const hwmodel::CalibrationResult& r = result.fit;
  const std::string dat = "calibration_residuals.dat";
  {
    auto out = fmt::output_file((dir / dat).string());
    out.print("# pose start_s norm_error_mps2 gyro_direction_error_deg(to next pose)\n");
    for (size_t i = 0; i < r.poses.size(); ++i) {
      out.print("{} {:.6f} {:.9g} {}\n", i, to_seconds(s.t[size_t(r.poses[i].begin)] - s.t.front()),
                r.accel_norm_error[i],
                i < r.gyro_direction_error_rad.size()
                    ? fmt::format("{:.9g}", r.gyro_direction_error_rad[i] * kDegPerRad)
                    : std::string("NaN"));
    }
  }
  const std::string script = fmt::format(
      "set multiplot layout 2,1 title 'multi-position calibration residuals'\nset grid\n"
      "set ylabel '|a_{{cal}}| - g [m/s^2]'\nset style fill solid 0.6\nset boxwidth 0.7\n"
      "plot '{d}' u 1:3 w boxes lc 1 t 'accelerometer, per pose'\n"
      "set xlabel 'pose'\nset ylabel 'angle [deg]'\n"
      "plot '{d}' u 1:4 w boxes lc 2 t 'gyroscope: carried vs measured gravity direction'\nunset "
      "multiplot\n",
      fmt::arg("d", dat));
  run_gnuplot(dir, "calibration_residuals", script);
}

}  // namespace imukit::cli
