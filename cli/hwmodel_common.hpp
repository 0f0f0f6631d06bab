// Helpers shared by `imukit characterize` and `imukit calibrate`: grouping input files into
// recordings (files with identical time stamps are channels of one recording and are merged),
// and gnuplot output (SVG) with the data and script left beside it.
#pragma once

#include <fmt/core.h>
#include <fmt/os.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/inputs.hpp"
#include "core/error.hpp"
#include "core/imu_series.hpp"

namespace imukit::cli {

struct LoadedRun {
  std::string name;  // the first file's path
  ImuSeries series;
};

// Loads every input; an input whose time stamps equal the previous run's adds its channels to
// that run (a channel present in both is an error), any other starts a new run.
inline std::vector<LoadedRun> load_runs(const std::vector<InputArg>& inputs) {
  std::vector<LoadedRun> runs;
  for (const InputArg& in : inputs) {
    ImuSeries s = load_imu_series(in);
    s.validate();
    if (!runs.empty() && runs.back().series.t == s.t) {
      ImuSeries& dst = runs.back().series;
      auto take = [&](Eigen::Matrix3Xd& to, Eigen::Matrix3Xd& from, const char* what) {
        if (from.cols() == 0) return;
        if (to.cols() != 0) {
          throw Error(fmt::format("{}: {} channel already given by {}", in.path, what, runs.back().name));
        }
        to = std::move(from);
      };
      take(dst.accel, s.accel, "accelerometer");
      take(dst.gyro, s.gyro, "gyroscope");
      take(dst.mag, s.mag, "magnetometer");
      continue;
    }
    runs.push_back({in.path, std::move(s)});
  }
  return runs;
}

// Writes DIR/NAME.gp and runs gnuplot on it to make DIR/NAME.svg. Returns false (after a
// note on stderr) when gnuplot is not installed: the script and data stay for later.
inline bool run_gnuplot(const std::filesystem::path& dir, const std::string& name, const std::string& script) {
  const auto gp = dir / (name + ".gp");
  {
    auto out = fmt::output_file(gp.string());
    out.print("set terminal svg size 900,600 dynamic enhanced font 'sans,12'\nset output '{}'\n{}",
              (dir / (name + ".svg")).string(), script);
  }
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    fmt::print(stderr, "imukit: note: gnuplot not found; run `gnuplot {}` to draw the plot\n", gp.string());
    return false;
  }
  const std::string cmd = fmt::format("gnuplot '{}'", gp.string());
  if (std::system(cmd.c_str()) != 0) throw Error(fmt::format("gnuplot failed on {}", gp.string()));
  return true;
}

}  // namespace imukit::cli
