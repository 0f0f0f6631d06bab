// imukit characterize: noise of each accelerometer and gyroscope axis from static recordings
// (Allan deviation, noise-model fit and the textbook slope readings), turn-on bias across
// recordings, written as the noise and turn_on_bias sections of an imukit.profile/1 file, plus
// optional Kalibr imu.yaml and SVG plots.
#include <fmt/core.h>
#include <fmt/os.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "command.hpp"
#include "hwmodel_common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/hwmodel/allan.hpp"
#include "imukit/hwmodel/calibration.hpp"
#include "imukit/hwmodel/noise_fit.hpp"
#include "inputs.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct CharacterizeArgs {
  std::string output;
  std::string plot_dir;
  std::string kalibr;
  double gravity = kStandardGravity;
  int points_per_decade = 10;
  bool level = false;
  bool keep_bad_fit = false;
  double fit_tau_min_s = 0.0;
};

int run_characterize(const CharacterizeArgs& args, const std::vector<std::string>& tokens) {
  const auto inputs = parse_input_args(tokens);
  if (inputs.empty()) throw UsageError("characterize: name at least one input file");
  if (args.output.empty())
    throw UsageError("characterize: say where the profile goes with -o profile.json");
  check_profile_to_update(args.output);  // before the work
  if (!args.kalibr.empty()) check_updatable_file(args.kalibr, "Kalibr file");
  const auto runs = load_runs(inputs);
  if (!args.kalibr.empty()) {
    // Kalibr's imu.yaml describes both; a missing triad written as 0 would tell Kalibr's filter
    // that sensor is perfect (found in review), so it is refused before any file is written.
    const bool acc = std::any_of(runs.begin(), runs.end(),
                                 [](const LoadedRun& r) { return r.series.has_accel(); });
    const bool gyr = std::any_of(runs.begin(), runs.end(),
                                 [](const LoadedRun& r) { return r.series.has_gyro(); });
    if (!acc || !gyr) {
      throw Error(
          fmt::format("--kalibr {}: Kalibr's imu.yaml needs accelerometer and gyroscope "
                      "noise; the input has no {}",
                      args.kalibr, acc ? "gyroscope" : "accelerometer"));
    }
  }
  CharacterizeOptions options;
  options.gravity = args.gravity;
  options.points_per_decade = args.points_per_decade;
  options.fit_tau_min_s = args.fit_tau_min_s;
  options.level = args.level;
  const CharacterizeResult r = characterize_runs(runs, options);
  const std::optional<hwmodel::TriadNoise>& acc = r.accel;
  const std::optional<hwmodel::TriadNoise>& gyr = r.gyro;
  // The plots first: they answer the question a refused fit asks (was the device still?).
  if (!args.plot_dir.empty()) {
    plot_noise(args.plot_dir, r);
    fmt::print("plots in {}\n", args.plot_dir);
  }
  // A profile is what simulate and augment take as the sensor's noise: numbers the model does
  // not describe are not written without being asked for (review, 2026-11-27: the warning was
  // printed and the profile written all the same).
  const std::vector<std::string> bad = axes_without_noise_model(r);
  if (!bad.empty()) {
    std::string axes;
    for (const std::string& b : bad) axes += (axes.empty() ? "" : ", ") + b;
    if (!args.keep_bad_fit) {
      throw Error(fmt::format(
          "{}: the noise model does not describe the Allan deviation of {}: was the device "
          "still? No profile written; --fit-tau-min leaves out a filter's or a vibration's mark, "
          "--keep-bad-fit writes the numbers all the same",
          r.noise_run, axes));
    }
    fmt::print(stderr,
               "imukit: warning: --keep-bad-fit: writing numbers that are no noise model ({})\n",
               axes);
  }
  update_profile(args.output, r.update);
  fmt::print("wrote noise sections to {}\n", args.output);

  if (!args.kalibr.empty()) {
    // Kalibr's imu.yaml holds continuous-time densities (its own discretisation uses the rate);
    // one value per sensor, so the largest axis is taken (conservative for a filter).
    auto mx = [](const std::optional<hwmodel::TriadNoise>& t, int term) {
      double v = 0;
      if (t)
        for (const auto& a : t->axes) v = std::max(v, a.fit.value[size_t(term)]);
      return v;
    };
    auto out = fmt::output_file(args.kalibr);
    out.print(
        "# written by imukit characterize from {}; continuous-time densities (Kalibr convention)\n"
        "rostopic: /imu0\nupdate_rate: {:.6g}  # Hz, measured from the time stamps\n"
        "accelerometer_noise_density: {:.6g}  # m/s^2/sqrt(Hz)\naccelerometer_random_walk: {:.6g}  "
        "# m/s^3/sqrt(Hz)\n"
        "gyroscope_noise_density: {:.6g}  # rad/s/sqrt(Hz)\ngyroscope_random_walk: {:.6g}  # "
        "rad/s^2/sqrt(Hz)\n",
        r.noise_run, 1.0 / (acc ? acc->allan.tau0_s : gyr->allan.tau0_s), mx(acc, hwmodel::kWhite),
        mx(acc, hwmodel::kRandomWalk), mx(gyr, hwmodel::kWhite), mx(gyr, hwmodel::kRandomWalk));
    fmt::print("wrote Kalibr noise parameters to {}\n", args.kalibr);
    // 0 tells Kalibr's filter the bias never wanders, which no real sensor does.
    for (const auto& [name, triad] :
         {std::pair{"accelerometer", &acc}, std::pair{"gyroscope", &gyr}}) {
      if (*triad && mx(*triad, hwmodel::kRandomWalk) == 0.0) {
        fmt::print(stderr,
                   "imukit: warning: no {} random walk seen in {} (too short a recording?): "
                   "Kalibr's {}_random_walk is 0, which says its bias never drifts; record for "
                   "hours, or set a value from the datasheet\n",
                   name, r.noise_run, name);
      }
    }
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    characterize,
    CommandSpec{
        "characterize",
        "Noise of each axis (Allan deviation, model fit), turn-on bias -> device profile", 50,
        [](CLI::App& sub) -> std::function<int()> {
          auto args = std::make_shared<CharacterizeArgs>();
          sub.allow_extras();
          sub.add_option("-o,--output", args->output,
                         "profile JSON to create or update (imukit.profile/1)")
              ->required();
          sub.add_option("--plot", args->plot_dir, "folder for SVG plots (gnuplot)");
          sub.add_option("--kalibr", args->kalibr, "also write Kalibr's imu.yaml here");
          sub.add_option("--gravity", args->gravity,
                         "local gravity, m/s^2, for --level's turn-on bias (recorded in the "
                         "profile with --level; noise needs none)")
              ->check(gravity_range());
          sub.add_option("--points-per-decade", args->points_per_decade,
                         "tau grid density (default 10)")
              ->check(whole_in(1, 100));
          sub.add_option("--fit-tau-min", args->fit_tau_min_s,
                         "fit the noise model only where tau >= this (s): leave out a sensor "
                         "filter's or a vibration's mark")
              ->check(real_in(0, 1e7, "s"));
          sub.add_flag("--keep-bad-fit", args->keep_bad_fit,
                       "write the profile even where the noise model does not describe an "
                       "axis' Allan deviation (chi2/dof above 100; refused otherwise)");
          sub.add_flag(
              "--level", args->level,
              "recordings were taken level with z up: also give the accelerometer turn-on bias");
          sub.footer(input_options_help() +
                     "\n\nExamples:\n"
                     "  imukit characterize imu_data.txt --columns t,gx,gy,gz,ax,ay,az "
                     "--accel-unit g -o profile.json\n"
                     "  imukit characterize run1.csv run2.csv run3.csv -o profile.json --plot "
                     "plots --kalibr imu.yaml\n");
          return [&sub, args] { return run_characterize(*args, sub.remaining()); };
        }});

}  // namespace imukit::cli
