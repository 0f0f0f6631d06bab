// imukit calibrate: multi-position calibration (Tedaldi et al., ICRA 2014) of an accelerometer
// and a gyroscope from one recording with static poses, written as the calibration sections
// of an imukit.profile/1 file; with --raw the inputs are ADC counts and the calibration maps
// counts to SI.
#include <fmt/core.h>
#include <fmt/os.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "command.hpp"
#include "hwmodel_common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/hwmodel/calibration.hpp"
#include "inputs.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct CalibrateArgs {
  std::string output;
  std::string plot_dir;
  bool raw = false;
  bool no_gyro = false;
  double gravity = kStandardGravity;
  std::optional<double> init_static_s;
};

int run_calibrate(const CalibrateArgs& args, const std::vector<std::string>& tokens) {
  const auto inputs = parse_input_args(tokens);
  if (inputs.empty()) throw UsageError("calibrate: name the input file(s)");
  // An MCAP recording and a EuRoC CSV hold SI values; taken for counts they made a profile of
  // raw_counts that simulate then refused (review, 2026-11-27).
  if (args.raw) {
    for (const InputArg& input : inputs) {
      const std::string ext = std::filesystem::path(input.path).extension().string();
      if (input.columns.empty() && (ext == ".mcap" || ext == ".csv")) {
        throw UsageError(fmt::format(
            "calibrate: --raw reads ADC counts from text files mapped with --columns; {} has no "
            "column map, so it is an MCAP recording or EuRoC CSV, whose values are SI (m/s^2, "
            "rad/s): calibrate it without --raw",
            input.path));
      }
    }
  }
  check_profile_to_update(args.output);  // before the work
  auto runs = load_runs(inputs);
  if (runs.size() != 1) {
    throw UsageError(
        fmt::format("calibrate: the inputs form {} recordings with different time stamps; "
                    "give one recording (files with equal time stamps are merged)",
                    runs.size()));
  }
  ImuSeries s = std::move(runs.front().series);
  CalibrateOptions options;
  options.gravity = args.gravity;
  options.raw = args.raw;
  options.gyro = !args.no_gyro;
  if (args.init_static_s) {
    options.init_static_s = *args.init_static_s;
  } else if (const auto guided = guided_initial_still(runs.front())) {
    // A guided capture says how long the device lay still and from when: start there.
    options.init_static_s = guided->seconds;
    const auto first = std::lower_bound(s.t.begin(), s.t.end(), guided->start);
    const auto skip = static_cast<std::size_t>(first - s.t.begin());
    fmt::print("initial static period: {:g} s from {:.3f} s, as the guided capture recorded\n",
               guided->seconds, s.empty() ? 0.0 : to_seconds(guided->start - s.t.front()));
    if (skip > 0) s = s.slice(skip, s.size() - skip).copy();
  }
  CalibrateResult r;
  try {
    r = calibrate_series(s, options);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", runs.front().name, e.what()));  // which recording
  }
  update_profile(args.output, r.update);
  fmt::print("wrote calibration sections to {}\n", args.output);
  if (!args.plot_dir.empty()) {
    plot_calibration(args.plot_dir, s, r);
    fmt::print("plots in {}\n", args.plot_dir);
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    calibrate,
    CommandSpec{"calibrate",
                "Multi-position calibration: scale, misalignment, bias -> device profile", 55,
                [](CLI::App& sub) -> std::function<int()> {
                  auto args = std::make_shared<CalibrateArgs>();
                  sub.allow_extras();
                  sub.add_option("-o,--output", args->output,
                                 "profile JSON to create or update (imukit.profile/1)")
                      ->required();
                  sub.add_option("--plot", args->plot_dir,
                                 "folder for SVG plots of the residuals (gnuplot)");
                  sub.add_flag("--raw", args->raw,
                               "the readings are ADC counts: the calibration maps counts to SI");
                  sub.add_flag("--no-gyro", args->no_gyro, "calibrate the accelerometer only");
                  sub.add_option("--gravity", args->gravity, "local gravity, m/s^2")
                      ->check(gravity_range());
                  sub.add_option("--init-static", args->init_static_s,
                                 "length of the initial static period, s (default: what a guided "
                                 "capture recorded, else 50)")
                      ->check(real_in(0, 3600, "s", LowEnd::open));
                  sub.footer(input_options_help() +
                             "\n\nExample (the imu_tk Xsens recording, raw counts):\n"
                             "  imukit calibrate xsens_acc.txt --columns t,ax,ay,az xsens_gyro.txt "
                             "--columns t,gx,gy,gz \\\n"
                             "      --raw --gravity 9.81744 -o calib.json --plot plots\n");
                  return [&sub, args] { return run_calibrate(*args, sub.remaining()); };
                }});

}  // namespace imukit::cli
