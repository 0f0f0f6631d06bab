// imukit calibrate: multi-position calibration (Tedaldi et al., ICRA 2014) of an accelerometer
// and a gyroscope from one recording with static poses, written as the calibration sections
// of an imukit.profile/1 file; with --raw the inputs are ADC counts and the calibration maps
// counts to SI.
#include <fmt/core.h>
#include <fmt/os.h>

#include <cmath>
#include <filesystem>

#include "cli/command.hpp"
#include "cli/hwmodel_common.hpp"
#include "cli/inputs.hpp"
#include "core/error.hpp"
#include "core/profile.hpp"
#include "hwmodel/calibration.hpp"

namespace imukit::cli {
namespace {

struct CalibrateArgs {
  std::string output;
  std::string plot_dir;
  bool raw = false;
  bool no_gyro = false;
  double gravity = 9.80665;
  double init_static_s = 50.0;
};

Calibration to_profile(const hwmodel::TriadCalibration& c, bool raw, double rms, double max, int64_t count) {
  Calibration p;
  p.scale = c.forward_scale();
  p.misalignment = c.forward_misalignment();
  p.bias = c.bias;
  p.raw_counts = raw;
  p.residual = CalibrationResidual{rms, max, count};
  return p;
}

void print_triad(const char* name, const hwmodel::TriadCalibration& c, bool raw, const char* unit) {
  fmt::print("{}: true = T diag(scale) (reading - bias)\n", name);
  fmt::print("  scale  {:.8g} {:.8g} {:.8g} {}\n", c.scale.x(), c.scale.y(), c.scale.z(),
             raw ? fmt::format("{} per count", unit) : std::string("(dimensionless)"));
  if (raw) {
    fmt::print("         ({:.6g} {:.6g} {:.6g} counts per {})\n", 1 / c.scale.x(), 1 / c.scale.y(),
               1 / c.scale.z(), unit);
  }
  fmt::print("  bias   {:.6g} {:.6g} {:.6g} {}\n", c.bias.x(), c.bias.y(), c.bias.z(), raw ? "counts" : unit);
  fmt::print("  T      [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(0, 0), c.T(0, 1), c.T(0, 2));
  fmt::print("         [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(1, 0), c.T(1, 1), c.T(1, 2));
  fmt::print("         [{:+.6f} {:+.6f} {:+.6f}]\n", c.T(2, 0), c.T(2, 1), c.T(2, 2));
}

int run_calibrate(const CalibrateArgs& args, const std::vector<std::string>& tokens) {
  const auto inputs = parse_input_args(tokens);
  if (inputs.empty()) throw Error("calibrate: name the input file(s)");
  auto runs = load_runs(inputs);
  if (runs.size() != 1) {
    throw Error(fmt::format("calibrate: the inputs form {} recordings with different time stamps; "
                            "give one recording (files with equal time stamps are merged)", runs.size()));
  }
  const ImuSeries& s = runs.front().series;
  if (!s.has_accel()) throw Error("calibrate: the input has no accelerometer channels (ax, ay, az)");
  const bool gyro = !args.no_gyro && s.has_gyro();
  hwmodel::CalibrationOptions opt;
  opt.gravity = args.gravity;
  opt.calibrate_gyro = gyro;
  opt.detector.init_static_s = args.init_static_s;
  const auto r = hwmodel::calibrate(s.t, s.accel, gyro ? s.gyro : Eigen::Matrix3Xd(3, 0), opt);
  fmt::print("{} static poses (threshold {} x the initial static variance), fit in {:.3f} s\n", r.poses.size(),
             r.threshold_factor, r.seconds);
  print_triad("accelerometer", r.accel, args.raw, "m/s^2");
  fmt::print("  residual |a| - g over the poses: rms {:.5f} m/s^2, max {:.5f} m/s^2 (g = {})\n", r.accel_rms,
             r.accel_max, args.gravity);
  if (gyro) {
    print_triad("gyroscope", r.gyro, args.raw, "rad/s");
    fmt::print("  residual gravity direction between consecutive poses: rms {:.4f} deg, max {:.4f} deg\n",
               r.gyro_rms_rad * 180 / M_PI, r.gyro_max_rad * 180 / M_PI);
  }
  DeviceProfile update;
  update.gravity = args.gravity;
  update.accelerometer = SensorProfile{};
  update.accelerometer->calibration =
      to_profile(r.accel, args.raw, r.accel_rms, r.accel_max, int64_t(r.accel_norm_error.size()));
  if (gyro) {
    update.gyroscope = GyroscopeProfile{};
    update.gyroscope->calibration = to_profile(r.gyro, args.raw, r.gyro_rms_rad, r.gyro_max_rad,
                                               int64_t(r.gyro_direction_error_rad.size()));
  }
  update_profile(args.output, update);
  fmt::print("wrote calibration sections to {}\n", args.output);

  if (!args.plot_dir.empty()) {
    std::filesystem::create_directories(args.plot_dir);
    const auto dat = (std::filesystem::path(args.plot_dir) / "calibration_residuals.dat").string();
    {
      auto out = fmt::output_file(dat);
      out.print("# pose start_s norm_error_mps2 gyro_direction_error_deg(to next pose)\n");
      for (size_t i = 0; i < r.poses.size(); ++i) {
        out.print("{} {:.6f} {:.9g} {}\n", i, to_seconds(s.t[size_t(r.poses[i].begin)] - s.t.front()),
                  r.accel_norm_error[i],
                  i < r.gyro_direction_error_rad.size() ? fmt::format("{:.9g}", r.gyro_direction_error_rad[i] * 180 / M_PI)
                                                        : std::string("NaN"));
      }
    }
    const std::string script = fmt::format(
        "set multiplot layout 2,1 title 'multi-position calibration residuals'\nset grid\n"
        "set ylabel '|a_{{cal}}| - g [m/s^2]'\nset style fill solid 0.6\nset boxwidth 0.7\n"
        "plot '{d}' u 1:3 w boxes lc 1 t 'accelerometer, per pose'\n"
        "set xlabel 'pose'\nset ylabel 'angle [deg]'\n"
        "plot '{d}' u 1:4 w boxes lc 2 t 'gyroscope: carried vs measured gravity direction'\nunset multiplot\n",
        fmt::arg("d", dat));
    run_gnuplot(args.plot_dir, "calibration_residuals", script);
    fmt::print("plots in {}\n", args.plot_dir);
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(calibrate, CommandSpec{
    "calibrate", "Multi-position calibration: scale, misalignment, bias -> device profile", 55,
    [](CLI::App& sub) -> std::function<int()> {
      auto args = std::make_shared<CalibrateArgs>();
      sub.allow_extras();
      sub.add_option("-o,--output", args->output, "profile JSON to create or update (imukit.profile/1)")->required();
      sub.add_option("--plot", args->plot_dir, "folder for SVG plots of the residuals (gnuplot)");
      sub.add_flag("--raw", args->raw, "the readings are ADC counts: the calibration maps counts to SI");
      sub.add_flag("--no-gyro", args->no_gyro, "calibrate the accelerometer only");
      sub.add_option("--gravity", args->gravity, "local gravity, m/s^2");
      sub.add_option("--init-static", args->init_static_s, "length of the initial static period, s (default 50)");
      sub.footer(input_options_help() +
                 "\n\nExample (the imu_tk Xsens recording, raw counts):\n"
                 "  imukit calibrate xsens_acc.txt --columns t,ax,ay,az xsens_gyro.txt --columns t,gx,gy,gz \\\n"
                 "      --raw --gravity 9.81744 -o calib.json --plot plots\n");
      return [&sub, args] { return run_calibrate(*args, sub.remaining()); };
    }});

}  // namespace imukit::cli
