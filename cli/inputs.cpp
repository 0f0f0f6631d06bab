#include "inputs.hpp"

#include <fmt/core.h>
#include <cmath>

#include <filesystem>
#include <optional>

#include "command.hpp"
#include "imukit/capture/recording_mcap.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/units.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

// The unit g is standard gravity g_n by definition (not the local --gravity).
double accel_factor(const std::string& unit) {
  if (const auto f = acceleration_unit_factor(unit)) return *f;
  throw UsageError(fmt::format("--accel-unit '{}' is not one of m/s^2, g, mg", unit));
}

double gyro_factor(const std::string& unit) {
  if (const auto f = angular_rate_unit_factor(unit)) return *f;
  throw UsageError(fmt::format("--gyro-unit '{}' is not one of rad/s, deg/s", unit));
}

double mag_factor(const std::string& unit) {
  if (unit == "T") return 1.0;
  if (unit == "uT") return 1e-6;
  if (unit == "gauss" || unit == "G") return 1e-4;
  throw UsageError(fmt::format("--mag-unit '{}' is not one of T, uT, gauss", unit));
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Whether the file starts with MCAP's magic bytes.
bool has_mcap_magic(const std::string& path) {
  UniqueFile f;
  try {
    f = open_regular_file(path, "recording");
  } catch (const IoError&) {
    return false;  // the reader the name points to says what is wrong
  }
  char magic[5] = {};
  return std::fread(magic, 1, 5, f.get()) == 5 && std::string_view(magic, 5) == "\x89MCAP";
}

// MCAP files are recognised by their magic bytes, whatever their name.
bool is_mcap(const std::string& path) { return ends_with(path, ".mcap") || has_mcap_magic(path); }

}  // namespace

std::vector<InputArg> parse_input_args(const std::vector<std::string>& tokens) {
  std::vector<InputArg> inputs;
  InputArg defaults;
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    std::string token = tokens[i];
    if (token.empty() || token[0] != '-' || token == "-") {
      InputArg input = defaults;
      input.path = token;
      inputs.push_back(input);
      continue;
    }
    std::optional<std::string> value;
    const std::size_t eq = token.find('=');
    if (eq != std::string::npos) {
      value = token.substr(eq + 1);
      token.resize(eq);
    }
    InputArg& target = inputs.empty() ? defaults : inputs.back();
    std::string* field = token == "--columns"      ? &target.columns
                         : token == "--gaps"       ? &target.gaps
                         : token == "--time-unit"  ? &target.time_unit
                         : token == "--accel-unit" ? &target.accel_unit
                         : token == "--gyro-unit"  ? &target.gyro_unit
                         : token == "--mag-unit"   ? &target.mag_unit
                                                   : nullptr;
    // The name first: an unknown option at the end of the line is unknown, not short of a value
    // (found in review: `info --frobnicate` said it needed one).
    if (field == nullptr) throw UsageError(fmt::format("unknown option {} (see --help)", token));
    if (!value) {
      if (i + 1 >= tokens.size()) throw UsageError(fmt::format("option {} needs a value", token));
      value = tokens[++i];
    }
    *field = std::move(*value);
  }
  return inputs;
}

ColumnSpec column_spec(const InputArg& input) {
  try {
    return ColumnSpec::parse(input.columns, input.gaps, parse_time_unit(input.time_unit));
  } catch (const Error& e) {
    throw UsageError(e.what());
  }
}

std::string input_options_help() {
  return "Inputs: MCAP recordings and EuRoC CSV files are recognised by their ending (.mcap, "
         ".csv);\n"
         "any other numeric text needs a column map. Options after a file apply to that file,\n"
         "options before the first file to all files:\n"
         "  --columns MAP      e.g. t,ax,ay,az,gx,gy,gz (names t ax..az gx..gz mx..mz qw..qz\n"
         "                     px..pz temp; _ skips a column, _N skips N, a final _* ignores the "
         "rest)\n"
         "  --time-unit U      s (default), ms, us or ns\n"
         "  --gaps COLS        columns that may hold NaN or be empty, e.g. qw,qx,qy,qz\n"
         "  --accel-unit U     m/s^2 (default), g (= " +
         fmt::format("{}", kStandardGravity) +
         " m/s^2) or mg\n"
         "  --gyro-unit U      rad/s (default) or deg/s\n"
         "  --mag-unit U       uT (default), T or gauss\n"
         "Details: docs/formats.md, section 'Column-mapped text'.";
}

namespace {

// Without --columns the file says its own layout and units (EuRoC CSV: ns, rad/s, m/s^2; MCAP:
// ROS units), so the options for column-mapped text would be ignored (found in review:
// `--accel-unit g` on an EuRoC CSV left the values in m/s^2 without a word).
void refuse_column_options(const InputArg& input) {
  const InputArg defaults;
  std::string given;
  const auto name = [&](bool differs, const char* option) {
    if (differs) given += (given.empty() ? "" : ", ") + std::string(option);
  };
  name(!input.gaps.empty(), "--gaps");
  name(input.time_unit != defaults.time_unit, "--time-unit");
  name(input.accel_unit != defaults.accel_unit, "--accel-unit");
  name(input.gyro_unit != defaults.gyro_unit, "--gyro-unit");
  name(input.mag_unit != defaults.mag_unit, "--mag-unit");
  if (!given.empty()) {
    throw UsageError(fmt::format(
        "{}: {} describe(s) column-mapped text and go(es) with --columns; an EuRoC CSV (ns, "
        "rad/s, m/s^2) or an MCAP recording (SI units) states its own",
        input.path, given));
  }
}

// An MCAP recording, its options checked by the caller.
Recording read_mcap_recording(const InputArg& input,
                              std::vector<std::string>* other_topics = nullptr) {
  capture::RecordingRead read = capture::read_recording_mcap(input.path);
  if (other_topics != nullptr) {
    // What a recording holds beyond its IMU streams, magnetometers and events (a recorder's raw
    // counts and time sync, a simulation's truth): a rewrite as a Recording drops it.
    for (const capture::McapChannel& c : read.summary.channels) {
      bool kept = c.topic == "/events";
      for (const auto& [name, series] : read.recording.streams)
        kept = kept || c.topic == "/imu/" + name || c.topic == "/imu/" + name + "/mag";
      if (!kept) other_topics->push_back(c.topic);
    }
    // The orientation inside kept topics goes too (a simulation's true orientation was
    // dropped without a word; found in review, 2026-11-27).
    for (const std::string& name : read.streams_with_orientation)
      other_topics->push_back("the orientation of /imu/" + name);
  }
  if (read.recording.streams.empty()) {
    // An empty file, or one cut before its first complete chunk: nothing to work on.
    std::string why = read.summary.truncation_note;
    if (why.rfind(input.path + ": ", 0) == 0) why.erase(0, input.path.size() + 2);
    throw Error(fmt::format("{}: holds no IMU samples{}", input.path,
                            read.summary.complete ? "" : " (" + why + ")"));
  }
  if (!read.summary.complete) {
    fmt::print(stderr, "imukit: note: {} (imukit convert --recover rewrites it as a valid file)\n",
               read.summary.truncation_note);
  }
  return std::move(read.recording);
}

}  // namespace

Recording load_recording(const InputArg& input, std::vector<std::string>* other_topics) {
  (void)open_regular_file(input.path, "recording");  // a missing file or a device, said first
  if (input.columns.empty()) refuse_column_options(input);
  if (input.columns.empty() && is_mcap(input.path)) return read_mcap_recording(input, other_topics);
  Recording r;
  r.streams[std::filesystem::path(input.path).stem().string()] = load_imu_series(input);
  return r;
}

ImuSeries load_imu_series(const InputArg& input, Recording* context) {
  (void)open_regular_file(input.path, "recording");  // a missing file or a device, said first
  if (input.columns.empty()) refuse_column_options(input);
  if (input.columns.empty() && is_mcap(input.path)) {
    Recording r = read_mcap_recording(input);
    if (r.streams.size() != 1) {
      throw Error(fmt::format("{}: holds {} IMU streams; this command reads one", input.path,
                              r.streams.size()));
    }
    ImuSeries s = std::move(r.streams.begin()->second);
    if (context != nullptr) {
      r.streams.clear();
      *context = std::move(r);
    }
    return s;
  }
  if (input.columns.empty()) {
    if (ends_with(input.path, ".csv")) return read_euroc_csv(input.path);
    throw UsageError(fmt::format(
        "{}: say what its columns are with --columns, e.g. --columns t,ax,ay,az,gx,gy,gz",
        input.path));
  }
  // A column map on a recording is the command line's mistake (found in review: the MCAP was
  // read as text).
  if (has_mcap_magic(input.path)) {
    throw UsageError(fmt::format(
        "{}: an MCAP recording states its own layout: give it without --columns", input.path));
  }
  const ColumnSpec spec = column_spec(input);
  // The map's own mistakes are the command line's, said before any row is read (found in
  // review: a partial triad exited 1, or behind a row's column count error).
  try {
    spec.require_whole_triads();
  } catch (const Error& e) {
    throw UsageError(input.path + ": " + e.what());
  }
  const ChannelScale scale{accel_factor(input.accel_unit), gyro_factor(input.gyro_unit),
                           mag_factor(input.mag_unit)};
  ImuSeries series = to_imu_series(read_column_text(input.path, spec), scale);
  // An empty text file read as "0 samples over 0.000 s", exit 0, where an MCAP without samples
  // is an error (review, 2026-11-27).
  if (series.empty()) throw Error(fmt::format("{}: no data rows", input.path));
  return series;
}

void add_bvh_options(CLI::App& sub, BvhArgs& args) {
  sub.add_option("--bvh-scale", args.scale,
                 "BVH length unit in metres (1 m, 0.01 cm, 0.056444 CMU units)")
      ->check(bvh_scale_range());
  sub.add_option("--up", args.up, "Up axis of the BVH file: y (default) or z")
      ->check(CLI::IsMember({"y", "z"}));
}

sim::BvhData load_bvh(const std::string& path, const BvhArgs& args) {
  sim::BvhOptions o;
  o.scale = args.scale;
  o.up = args.up == "z" ? sim::UpAxis::z : sim::UpAxis::y;
  return sim::read_bvh(path, o);
}

}  // namespace imukit::cli
