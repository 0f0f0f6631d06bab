// imukit convert: rewrite a recording as EuRoC CSV (Kalibr, OpenVINS, pandas) or NumPy arrays.
#include <filesystem>
#include <fmt/core.h>

#include "cli/command.hpp"
#include "cli/inputs.hpp"
#include "core/error.hpp"
#include "core/euroc_csv.hpp"
#include "core/npy.hpp"

namespace imukit::cli {
namespace {

// OUT.npy gets float64 (N, 6) in the dataset channel order ax ay az gx gy gz (SI units) and
// OUT_t.npy the int64 time stamps in ns (docs/formats.md).
void write_npy_pair(const std::string& out, const ImuSeries& s) {
  if (!s.has_accel() || !s.has_gyro()) {
    throw Error(fmt::format("{}: .npy output needs accelerometer and gyroscope columns", out));
  }
  std::vector<double> values(6 * s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    for (int k = 0; k < 3; ++k) {
      values[6 * i + static_cast<std::size_t>(k)] = s.accel(k, c);
      values[6 * i + 3 + static_cast<std::size_t>(k)] = s.gyro(k, c);
    }
  }
  const std::vector<std::size_t> shape = {s.size(), 6};
  const std::vector<std::size_t> t_shape = {s.size()};
  write_npy(out, std::span<const double>(values), shape);
  const std::filesystem::path p(out);
  const std::string t_path = (p.parent_path() / (p.stem().string() + "_t.npy")).string();
  write_npy(t_path, std::span<const int64_t>(s.t), t_shape);
  fmt::print("wrote {} ({} x 6 float64: ax ay az gx gy gz) and {} (int64 ns)\n", out, s.size(), t_path);
}

int run_convert(const std::vector<std::string>& tokens, const std::string& out) {
  const std::vector<InputArg> inputs = parse_input_args(tokens);
  if (inputs.size() != 1) throw Error("convert: give exactly one input file (and -o OUT)");
  const ImuSeries s = load_imu_series(inputs.front());
  s.validate();
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext == ".csv") {
    write_euroc_csv(out, s.view());
    fmt::print("wrote {} ({} samples, EuRoC CSV)\n", out, s.size());
  } else if (ext == ".npy") {
    write_npy_pair(out, s);
  } else {
    throw Error(fmt::format("convert: output '{}' must end in .csv (EuRoC) or .npy", out));
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(convert, CommandSpec{
    "convert", "Rewrite a recording as EuRoC CSV or NumPy .npy", 20,
    [](CLI::App& sub) -> std::function<int()> {
      auto out = std::make_shared<std::string>();
      sub.add_option("-o,--output", *out, "output file: OUT.csv (EuRoC) or OUT.npy")->required();
      sub.allow_extras();
      sub.footer(input_options_help() +
                 "\n\nExamples:\n"
                 "  imukit convert imu_data.txt --columns t,gx,gy,gz,ax,ay,az --accel-unit g -o imu0.csv\n"
                 "  imukit convert imu0.csv -o imu0.npy\n");
      return [&sub, out] { return run_convert(sub.remaining(), *out); };
    }});

}  // namespace imukit::cli
