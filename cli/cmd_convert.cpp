// imukit convert: rewrite a recording as MCAP, EuRoC CSV (Kalibr, OpenVINS, pandas) or NumPy
// arrays, or rescue an MCAP file cut short by a crash.
#include <fmt/core.h>
#include <algorithm>
#include <filesystem>

#include "command.hpp"
#include "imukit/capture/mcap.hpp"
#include "imukit/capture/recording_mcap.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/npy.hpp"
#include "inputs.hpp"

namespace imukit::cli {
namespace {

namespace fs = std::filesystem;

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
  const fs::path p(out);
  const std::string t_path = (p.parent_path() / (p.stem().string() + "_t.npy")).string();
  write_npy(t_path, std::span<const int64_t>(s.t), t_shape);
  fmt::print("wrote {} ({} x 6 float64: ax ay az gx gy gz) and {} (int64 ns)\n", out, s.size(),
             t_path);
}

const ImuSeries& only_stream(const Recording& r, const std::string& out) {
  if (r.streams.size() != 1) {
    throw UsageError(
        fmt::format("convert: the input holds {} streams; write them to a folder "
                    "(-o DIR/) instead of the single file {}",
                    r.streams.size(), out));
  }
  return r.streams.begin()->second;
}

// What the output format cannot hold is said, not dropped silently (found in review): EuRoC CSV
// and .npy hold accelerometer and gyroscope, MCAP the magnetometer too; temperature none of them.
void warn_of_dropped_channels(const Recording& r, const std::string& ext) {
  for (const auto& [name, s] : r.streams) {
    std::string lost;
    if (s.has_mag() && ext != ".mcap") lost = "magnetometer";
    if (s.temperature_c.size() > 0)
      lost += (lost.empty() ? "" : " and ") + std::string("temperature");
    if (!lost.empty()) {
      fmt::print(stderr, "imukit: warning: convert: {}'s {} not written ({} holds {})\n", name,
                 lost,
                 ext == ".mcap" ? "MCAP"
                 : ext.empty()  ? "a folder of EuRoC CSVs"
                                : ext,
                 ext == ".mcap" ? "accelerometer, gyroscope and magnetometer"
                                : "accelerometer and gyroscope");
    }
  }
}

int run_convert(const std::vector<std::string>& tokens, const std::string& out, bool recover) {
  const std::vector<InputArg> inputs = parse_input_args(tokens);
  if (inputs.size() != 1) throw UsageError("convert: give exactly one input file (and -o OUT)");
  // Rewriting the only copy in place (accepted without --recover until review, 2026-11-27,
  // which lost the raw counts of a recording that way).
  std::error_code ec;
  if (fs::equivalent(inputs.front().path, out, ec)) {
    throw UsageError(fmt::format("convert{}: {} is the input; write to a new name",
                                 recover ? " --recover" : "", out));
  }
  if (recover) {
    if (fs::path(inputs.front().path).extension() != ".mcap" ||
        fs::path(out).extension() != ".mcap") {
      throw UsageError("convert --recover: input and output must both be .mcap files");
    }
    // Recordings of `imukit record` also get their clocks refitted over the samples kept.
    const capture::RecoveredRecording r = capture::recover_recording(inputs.front().path, out);
    const capture::McapReadSummary& s = r.read;
    fmt::print("{}\n", s.complete ? inputs.front().path + " was complete" : s.truncation_note);
    for (const std::string& d : s.damage) fmt::print("  damaged: {}\n", d);
    if (s.damaged_records > s.damage.size())
      fmt::print("  ... and {} more damaged records\n", s.damaged_records - s.damage.size());
    if (s.orphan_messages)
      fmt::print("  {} messages left out: the Channel record they belong to is damaged\n",
                 s.orphan_messages);
    if (r.undecodable_messages)
      fmt::print("  {} messages left out: they do not decode\n", r.undecodable_messages);
    fmt::print(
        "wrote {}: {} messages of {} chunks{}\n", out, s.messages - r.undecodable_messages,
        s.chunks,
        s.damaged_records ? fmt::format("; {} damaged records skipped", s.damaged_records) : "");
    for (const auto& [device, fit] : r.clocks) {
      fmt::print("  {}: clock refitted over {} packets ({:+.3f} ppm)\n", device, fit.packets,
                 fit.skew_ppm);
    }
    for (const auto& [device, l] : r.losses) {
      if (!l.counts_lost) continue;
      fmt::print(
          "  {}: {} samples kept, {} missing by sample_index gaps; the codec's, corrupt-frame and "
          "recorder loss counts were lost with the crash\n",
          device, l.samples, l.missing_by_index);
    }
    // Nothing recovered exited 0 beside an empty file, where `info` on the same input exits 1
    // (review, 2026-11-27).
    if (s.messages == r.undecodable_messages) {
      std::filesystem::remove(out, ec);
      throw Error(fmt::format("convert --recover: no message of {} could be read; nothing written",
                              inputs.front().path));
    }
    return 0;
  }
  std::vector<std::string> other_topics;
  const Recording r = load_recording(inputs.front(), &other_topics);
  for (const auto& [name, series] : r.streams)
    series.validate(r.streams.size() == 1 ? inputs.front().path : inputs.front().path + " " + name);
  const std::string ext = fs::path(out).extension().string();
  if (ext == ".mcap" || ext == ".csv" || ext == ".npy" || ext.empty()) {
    warn_of_dropped_channels(r, ext);
    // EuRoC CSV and .npy keep no orientation either (an MCAP output lists it with the other
    // topics it does not write, below).
    if (ext != ".mcap") {
      for (const std::string& t : other_topics) {
        if (t.rfind("the orientation of ", 0) == 0)
          fmt::print(stderr,
                     "imukit: warning: convert: {} is not written ({} holds accelerometer "
                     "and gyroscope)\n",
                     t, ext.empty() ? "a folder of EuRoC CSVs" : ext);
      }
    }
    // Pose columns are read by `identify --pose`, not kept in an IMU recording.
    std::string pose;
    if (!inputs.front().columns.empty()) {
      const ColumnSpec spec = column_spec(inputs.front());
      for (const Column c :
           {Column::qw, Column::qx, Column::qy, Column::qz, Column::px, Column::py, Column::pz}) {
        if (spec.has(c)) pose += (pose.empty() ? "" : ",") + std::string(column_name(c));
      }
    }
    if (!pose.empty()) {
      fmt::print(stderr,
                 "imukit: warning: convert: the pose columns {} are not written (a recording holds "
                 "IMU channels; `identify --pose` reads them)\n",
                 pose);
    }
  }
  if (ext == ".mcap") {
    if (!other_topics.empty()) {
      std::string topics;
      for (const std::string& t : other_topics) topics += (topics.empty() ? "" : ", ") + t;
      fmt::print(stderr,
                 "imukit: warning: convert: {} gets the IMU streams, events and metadata of {}; "
                 "its other topics are not written: {} (`convert --recover` copies a file "
                 "whole)\n",
                 out, inputs.front().path, topics);
    }
    capture::write_recording_mcap(out, r);
    fmt::print("wrote {} ({} streams, {} events)\n", out, r.streams.size(), r.events.size());
  } else if (ext == ".csv") {
    const ImuSeries& s = only_stream(r, out);
    write_euroc_csv(out, s.view());
    fmt::print("wrote {} ({} samples, EuRoC CSV)\n", out, s.size());
  } else if (ext == ".npy") {
    write_npy_pair(out, only_stream(r, out));
  } else if (ext.empty()) {
    fs::create_directories(out);
    for (const auto& [name, series] : r.streams) {
      // A topic below a device (/imu/belt/truth) becomes belt.truth.csv.
      std::string file = name;
      std::replace(file.begin(), file.end(), '/', '.');
      const std::string path = (fs::path(out) / (file + ".csv")).string();
      write_euroc_csv(path, series.view());
      fmt::print("wrote {} ({} samples, EuRoC CSV)\n", path, series.size());
    }
  } else {
    throw UsageError(fmt::format(
        "convert: output '{}' must be OUT.mcap, OUT.csv (EuRoC), OUT.npy or a folder", out));
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    convert,
    CommandSpec{
        "convert", "Rewrite a recording as MCAP, EuRoC CSV or NumPy .npy; rescue a cut MCAP file",
        20, [](CLI::App& sub) -> std::function<int()> {
          auto out = std::make_shared<std::string>();
          auto recover = std::make_shared<bool>(false);
          sub.add_option(
                 "-o,--output", *out,
                 "OUT.mcap, OUT.csv (EuRoC), OUT.npy, or a folder (one EuRoC CSV per stream)")
              ->required();
          sub.add_flag(
              "--recover", *recover,
              "rewrite an MCAP file cut short by a crash or damaged as a valid file (damaged "
              "records skipped, every intact chunk kept, clocks refitted over what was kept)");
          sub.allow_extras();
          sub.footer(
              input_options_help() +
              "\n\nExamples:\n"
              "  imukit convert session.mcap -o session/            one EuRoC CSV per device\n"
              "  imukit convert --recover crashed.mcap -o fixed.mcap\n"
              "  imukit convert imu_data.txt --columns t,gx,gy,gz,ax,ay,az --accel-unit g -o "
              "imu0.mcap\n"
              "  imukit convert imu0.csv -o imu0.npy\n");
          return [&sub, out, recover] { return run_convert(sub.remaining(), *out, *recover); };
        }});

}  // namespace imukit::cli
