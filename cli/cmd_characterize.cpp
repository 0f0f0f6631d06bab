// imukit characterize: noise of each accelerometer and gyroscope axis from static recordings
// (Allan deviation, noise-model fit and the textbook slope readings), turn-on bias across
// recordings, written as the noise and turn_on_bias sections of an imukit.profile/1 file, plus
// optional Kalibr imu.yaml and SVG plots.
#include <fmt/core.h>
#include <fmt/os.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "cli/command.hpp"
#include "cli/hwmodel_common.hpp"
#include "cli/inputs.hpp"
#include "core/error.hpp"
#include "core/profile.hpp"
#include "hwmodel/allan.hpp"
#include "hwmodel/calibration.hpp"
#include "hwmodel/noise_fit.hpp"

namespace imukit::cli {
namespace {

struct CharacterizeArgs {
  std::string output;
  std::string plot_dir;
  std::string kalibr;
  double gravity = 9.80665;
  int points_per_decade = 10;
  bool level = false;
  double fit_tau_min_s = 0.0;
};

struct AxisNoise {
  hwmodel::NoiseFit fit;
  hwmodel::SlopeReadings slopes;
};

struct TriadNoise {
  hwmodel::AllanResult allan;
  std::array<AxisNoise, 3> axes;
};

TriadNoise characterize_triad(const ImuSeries& s, const Eigen::Matrix3Xd& x, int ppd, double tau_min) {
  TriadNoise out;
  hwmodel::AllanOptions opt;
  opt.points_per_decade = ppd;
  out.allan = hwmodel::allan_deviation(s.t, x, opt);
  const auto& a = out.allan.allan;
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<double> dev, lo, hi;
    for (Eigen::Index k = 0; k < a.deviation.cols(); ++k) {
      dev.push_back(a.deviation(ax, k));
      lo.push_back(a.lower(ax, k));
      hi.push_back(a.upper(ax, k));
    }
    hwmodel::NoiseFitOptions fo;
    fo.tau_min_s = tau_min;
    out.axes[size_t(ax)].fit =
        hwmodel::fit_noise_model_gls(out.allan.tau_s, dev, out.allan.factors, int64_t(s.size()), fo);
    out.axes[size_t(ax)].slopes = hwmodel::read_slopes(out.allan.tau_s, dev, lo, hi);
  }
  return out;
}

NoiseEstimate to_estimate(const TriadNoise& tn) {
  NoiseEstimate e;
  Eigen::Vector3d n, ns, b, bs, k, ks;
  for (int ax = 0; ax < 3; ++ax) {
    const auto& f = tn.axes[size_t(ax)].fit;
    n(ax) = f.value[hwmodel::kWhite], ns(ax) = f.sigma[hwmodel::kWhite];
    b(ax) = f.value[hwmodel::kBiasInstability], bs(ax) = f.sigma[hwmodel::kBiasInstability];
    k(ax) = f.value[hwmodel::kRandomWalk], ks(ax) = f.sigma[hwmodel::kRandomWalk];
  }
  e.noise_density = n, e.noise_density_sigma = ns;
  e.bias_instability = b, e.bias_instability_sigma = bs;
  e.random_walk = k, e.random_walk_sigma = ks;
  AllanCurve c;
  c.tau_s = tn.allan.tau_s;
  for (int ax = 0; ax < 3; ++ax) {
    for (Eigen::Index q = 0; q < tn.allan.allan.deviation.cols(); ++q)
      c.adev[size_t(ax)].push_back(tn.allan.allan.deviation(ax, q));
  }
  e.allan = c;
  return e;
}

void print_triad(const char* name, const char* unit, const TriadNoise& tn) {
  fmt::print("{} ({} samples, tau0 {:.6g} s measured from the time stamps{})\n", name,
             tn.allan.sampling.samples, tn.allan.tau0_s,
             tn.allan.uniform ? "" : "; NOT uniformly sampled: jitter above 1 % of the period");
  fmt::print("  axis  fit: N [{u}/sqrt(Hz)]      B [{u}]              K [{u}/s/sqrt(Hz)]   chi2/dof | slopes: N@1s      B=min/0.664   K@3s\n",
             fmt::arg("u", unit));
  for (int ax = 0; ax < 3; ++ax) {
    const auto& f = tn.axes[size_t(ax)].fit;
    const auto& s = tn.axes[size_t(ax)].slopes;
    auto pm = [](double v, double sd, bool active, double upper) {
      if (active) return fmt::format("{:.4g} +- {:.2g}", v, sd);
      return upper > 0 ? fmt::format("0 (< {:.3g})", upper) : std::string("0 (not seen)");
    };
    auto rd = [](const hwmodel::SlopeReading& r) { return r.found ? fmt::format("{:.4g}", r.value) : std::string("-"); };
    fmt::print("  {}     {:<22} {:<20} {:<20} {:>7.2f}  | {:<11} {:<13} {}\n", "xyz"[ax],
               pm(f.value[1], f.sigma[1], f.active[1], f.upper[1]),
               pm(f.value[2], f.sigma[2], f.active[2], f.upper[2]),
               pm(f.value[3], f.sigma[3], f.active[3], f.upper[3]), f.chi2_per_dof, rd(s.white),
               rd(s.bias_instability), rd(s.random_walk));
  }
}

void plot_triad(const std::filesystem::path& dir, const std::string& name, const char* unit,
                const TriadNoise& tn) {
  const std::string dat = (dir / (name + "_allan.dat")).string();
  {
    auto out = fmt::output_file(dat);
    out.print("# tau_s adev_x lo_x hi_x model_x adev_y lo_y hi_y model_y adev_z lo_z hi_z model_z\n");
    for (size_t k = 0; k < tn.allan.tau_s.size(); ++k) {
      const double tau = tn.allan.tau_s[k];
      out.print("{:.9g}", tau);
      for (int ax = 0; ax < 3; ++ax) {
        const auto K = Eigen::Index(k);
        out.print(" {:.9g} {:.9g} {:.9g} {:.9g}", tn.allan.allan.deviation(ax, K), tn.allan.allan.lower(ax, K),
                  tn.allan.allan.upper(ax, K),
                  std::sqrt(hwmodel::model_allan_variance(tn.axes[size_t(ax)].fit.value, tau)));
      }
      out.print("\n");
    }
  }
  // Slope lines of the fitted N and K (x axis), and the fitted model per axis.
  const auto& fx = tn.axes[0].fit;
  std::string script = fmt::format(
      "set logscale xy\nset grid\nset key bottom left\nset xlabel 'averaging time tau [s]'\n"
      "set ylabel 'Allan deviation [{}]'\nset title '{}: overlapping Allan deviation, 1-sigma intervals, fitted model'\n"
      "N={:.9g}; K={:.9g}; B={:.9g}\n"
      "plot '{d}' u 1:2:3:4 w yerrorbars lc 1 pt 7 ps 0.4 t 'x', '{d}' u 1:5 w l lc 1 t 'x model', "
      "'{d}' u 1:6:7:8 w yerrorbars lc 2 pt 7 ps 0.4 t 'y', '{d}' u 1:9 w l lc 2 t 'y model', "
      "'{d}' u 1:10:11:12 w yerrorbars lc 3 pt 7 ps 0.4 t 'z', '{d}' u 1:13 w l lc 3 t 'z model', "
      "(N>0 ? N/sqrt(x) : 1/0) w l dt 2 lc 0 t 'x: N/sqrt(tau)', (K>0 ? K*sqrt(x/3) : 1/0) w l dt 3 lc 0 t 'x: K sqrt(tau/3)', "
      "(B>0 ? 0.6643*B : 1/0) w l dt 4 lc 0 t 'x: 0.664 B'\n",
      unit, name, fx.value[1], fx.value[3], fx.value[2], fmt::arg("d", dat));
  run_gnuplot(dir, name + "_allan", script);
}

int run_characterize(const CharacterizeArgs& args, const std::vector<std::string>& tokens) {
  const auto inputs = parse_input_args(tokens);
  if (inputs.empty()) throw Error("characterize: name at least one input file");
  if (args.output.empty()) throw Error("characterize: say where the profile goes with -o profile.json");
  const auto runs = load_runs(inputs);
  // Noise from the longest recording; turn-on bias across all of them.
  const auto longest = std::max_element(runs.begin(), runs.end(), [](const LoadedRun& a, const LoadedRun& b) {
    return a.series.size() < b.series.size();
  });
  const ImuSeries& s = longest->series;
  fmt::print("noise from {} ({} recordings given)\n", longest->name, runs.size());
  DeviceProfile update;
  update.gravity = args.gravity;
  std::optional<TriadNoise> acc, gyr;
  if (s.has_accel()) {
    acc = characterize_triad(s, s.accel, args.points_per_decade, args.fit_tau_min_s);
    print_triad("accelerometer", "m/s^2", *acc);
    update.accelerometer = SensorProfile{};
    update.accelerometer->noise = to_estimate(*acc);
  }
  if (s.has_gyro()) {
    gyr = characterize_triad(s, s.gyro, args.points_per_decade, args.fit_tau_min_s);
    print_triad("gyroscope", "rad/s", *gyr);
    update.gyroscope = GyroscopeProfile{};
    update.gyroscope->noise = to_estimate(*gyr);
  }
  if (!acc && !gyr) throw Error("characterize: the inputs hold neither accelerometer nor gyroscope data");
  fmt::print("The fit (generalised least squares on the whole curve, terms not detected set to 0) is the\n"
             "estimate to use; the slope readings are shown for comparison with other tools (docs/hwmodel.md).\n");

  // Turn-on bias: gyroscope mean per recording; accelerometer only with --level (z up).
  std::vector<Eigen::Vector3d> gb, ab;
  for (const auto& r : runs) {
    if (r.series.has_gyro()) gb.push_back(hwmodel::gyro_static_bias(r.series.gyro));
    if (args.level && r.series.has_accel())
      ab.push_back(hwmodel::accel_static_bias(r.series.accel, Eigen::Matrix3d::Identity(), args.gravity));
  }
  auto tob = [](const std::vector<Eigen::Vector3d>& v) {
    const auto st = hwmodel::turn_on_bias_stats(v);
    TurnOnBias t;
    t.mean = st.mean;
    t.spread = st.spread;
    t.runs = st.runs;
    return t;
  };
  if (!gb.empty() && update.gyroscope) {
    update.gyroscope->turn_on_bias = tob(gb);
    fmt::print("gyroscope turn-on bias over {} recording(s): mean {:.4g} {:.4g} {:.4g} rad/s, spread {:.3g} {:.3g} {:.3g}\n",
               gb.size(), update.gyroscope->turn_on_bias->mean.x(), update.gyroscope->turn_on_bias->mean.y(),
               update.gyroscope->turn_on_bias->mean.z(), update.gyroscope->turn_on_bias->spread.x(),
               update.gyroscope->turn_on_bias->spread.y(), update.gyroscope->turn_on_bias->spread.z());
  }
  if (!ab.empty() && update.accelerometer) {
    update.accelerometer->turn_on_bias = tob(ab);
    fmt::print("accelerometer turn-on bias (level, z up) over {} recording(s): mean {:.4g} {:.4g} {:.4g} m/s^2\n",
               ab.size(), update.accelerometer->turn_on_bias->mean.x(),
               update.accelerometer->turn_on_bias->mean.y(), update.accelerometer->turn_on_bias->mean.z());
  }
  update_profile(args.output, update);
  fmt::print("wrote noise sections to {}\n", args.output);

  if (!args.kalibr.empty()) {
    // Kalibr's imu.yaml holds continuous-time densities (its own discretisation uses the rate);
    // one value per sensor, so the largest axis is taken (conservative for a filter).
    auto mx = [](const std::optional<TriadNoise>& t, int term) {
      double v = 0;
      if (t)
        for (const auto& a : t->axes) v = std::max(v, a.fit.value[size_t(term)]);
      return v;
    };
    auto out = fmt::output_file(args.kalibr);
    out.print("# written by imukit characterize from {}; continuous-time densities (Kalibr convention)\n"
              "rostopic: /imu0\nupdate_rate: {:.6g}  # Hz, measured from the time stamps\n"
              "accelerometer_noise_density: {:.6g}  # m/s^2/sqrt(Hz)\naccelerometer_random_walk: {:.6g}  # m/s^3/sqrt(Hz)\n"
              "gyroscope_noise_density: {:.6g}  # rad/s/sqrt(Hz)\ngyroscope_random_walk: {:.6g}  # rad/s^2/sqrt(Hz)\n",
              longest->name, 1.0 / (acc ? acc->allan.tau0_s : gyr->allan.tau0_s), mx(acc, hwmodel::kWhite),
              mx(acc, hwmodel::kRandomWalk), mx(gyr, hwmodel::kWhite), mx(gyr, hwmodel::kRandomWalk));
    fmt::print("wrote Kalibr noise parameters to {}\n", args.kalibr);
  }
  if (!args.plot_dir.empty()) {
    std::filesystem::create_directories(args.plot_dir);
    if (acc) plot_triad(args.plot_dir, "accelerometer", "m/s^2", *acc);
    if (gyr) plot_triad(args.plot_dir, "gyroscope", "rad/s", *gyr);
    fmt::print("plots in {}\n", args.plot_dir);
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(characterize, CommandSpec{
    "characterize", "Noise of each axis (Allan deviation, model fit), turn-on bias -> device profile", 50,
    [](CLI::App& sub) -> std::function<int()> {
      auto args = std::make_shared<CharacterizeArgs>();
      sub.allow_extras();
      sub.add_option("-o,--output", args->output, "profile JSON to create or update (imukit.profile/1)")->required();
      sub.add_option("--plot", args->plot_dir, "folder for SVG plots (gnuplot)");
      sub.add_option("--kalibr", args->kalibr, "also write Kalibr's imu.yaml here");
      sub.add_option("--gravity", args->gravity, "local gravity, m/s^2 (recorded in the profile)");
      sub.add_option("--points-per-decade", args->points_per_decade, "tau grid density (default 10)");
      sub.add_option("--fit-tau-min", args->fit_tau_min_s,
                     "fit the noise model only where tau >= this (s): leave out a sensor filter's or a vibration's mark");
      sub.add_flag("--level", args->level, "recordings were taken level with z up: also give the accelerometer turn-on bias");
      sub.footer(input_options_help() +
                 "\n\nExamples:\n"
                 "  imukit characterize imu_data.txt --columns t,gx,gy,gz,ax,ay,az --accel-unit g -o profile.json\n"
                 "  imukit characterize run1.csv run2.csv run3.csv -o profile.json --plot plots --kalibr imu.yaml\n");
      return [&sub, args] { return run_characterize(*args, sub.remaining()); };
    }});

}  // namespace imukit::cli
