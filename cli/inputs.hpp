// Input files on the command line, with the column grammar of core/column_text.hpp. Options
// that follow a file apply to that file; options before the first file apply to every file:
//   imukit calibrate acc.txt --columns t,ax,ay,az gyro.txt --columns t,gx,gy,gz
//   imukit info --time-unit ms a.txt b.txt --columns t,ax,ay,az
#pragma once

#include <string>
#include <vector>

#include "imukit/core/column_text.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/sim/bvh.hpp"

namespace CLI {
class App;
}

namespace imukit::cli {

struct InputArg {
  std::string path;
  std::string columns;  // empty: the format is recognised from the file (EuRoC CSV)
  std::string gaps;
  std::string time_unit = "s";
  std::string accel_unit = "m/s^2";
  std::string gyro_unit = "rad/s";
  std::string mag_unit = "uT";
};

// Splits the tokens CLI11 left over into inputs; throws imukit::Error on an unknown option or
// an option without its value.
std::vector<InputArg> parse_input_args(const std::vector<std::string>& tokens);

// The input's --columns, --gaps and --time-unit as a ColumnSpec; a mistake in them is a usage
// error (UsageError).
ColumnSpec column_spec(const InputArg& input);

// Help text describing the per-input options, for a subcommand's footer.
std::string input_options_help();

// Reads one input as an IMU stream in SI units (an MCAP file must hold exactly one stream).
// `context`, when given, receives the recording's metadata and events (MCAP only).
ImuSeries load_imu_series(const InputArg& input, Recording* context = nullptr);

// Reads one input as a Recording: an MCAP file as recorded (a file cut short is read up to its
// last complete chunk, with a note on stderr), any other input as one stream named after the
// file's stem. other_topics: an MCAP's topics that are not its IMU streams, their magnetometers
// or its events (what a Recording cannot hold).
Recording load_recording(const InputArg& input, std::vector<std::string>* other_topics = nullptr);

// How to read a BVH motion file, as --bvh-scale and --up give it.
struct BvhArgs {
  double scale = 1.0;    // metres per BVH length unit
  std::string up = "y";  // y or z
};

// Adds --bvh-scale and --up to a subcommand, checked at parse time.
void add_bvh_options(CLI::App& sub, BvhArgs& args);

// Reads a BVH file with those options.
sim::BvhData load_bvh(const std::string& path, const BvhArgs& args);

}  // namespace imukit::cli
