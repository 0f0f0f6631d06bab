#include "imukit/core/euroc_csv.hpp"

#include <fmt/format.h>
#include <cerrno>
#include <cstring>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"

namespace imukit {
namespace {

const ColumnSpec& euroc_spec() {
  // EuRoC's timestamps are integer nanoseconds (found in review: 1000.5 and 1e3 were read).
  static const ColumnSpec spec = [] {
    ColumnSpec s = ColumnSpec::parse("t,gx,gy,gz,ax,ay,az", {}, TimeUnit::ns);
    s.integer_time = true;
    return s;
  }();
  return spec;
}

// The header must name the EuRoC columns in their order: a CSV of other columns (accelerometer
// first, or times in seconds) would otherwise be read with its columns swapped or its times
// scaled. The time first ('#timestamp' or 'timestamp'), then three gyroscope columns (names
// beginning with 'w' as EuRoC's w_RS_S_x, or 'g') and three accelerometer columns ('a'); a unit
// in brackets, where given, must be EuRoC's.
void check_header(const ColumnTable& table) {
  static constexpr std::string_view kUnits[] = {
      "[ns]", "[rad s^-1]", "[rad s^-1]", "[rad s^-1]", "[m s^-2]", "[m s^-2]", "[m s^-2]"};
  const auto fail = [&](std::size_t k, const std::string& what) {
    // At the header's field k where there is a header, else at the first row (none in a file of
    // no rows: the file alone).
    const int64_t column = k < table.header_columns.size() ? table.header_columns[k] : 1;
    const InputLocation at = table.first_row_line > 0
                                 ? InputLocation{table.source, table.first_row_line, column, {}}
                                 : InputLocation{table.source, {}, {}, {}};
    throw Error(at, fmt::format("not an EuRoC IMU CSV: {}; the header is '{}' (for other columns, "
                                "say what they are with --columns)",
                                what, kEurocHeader));
  };
  if (table.header.empty()) fail(0, "the first row must be the header");
  if (table.header.size() < std::size(kUnits))
    fail(0, fmt::format("the header has {} columns, EuRoC's 7", table.header.size()));
  for (std::size_t k = 0; k < std::size(kUnits); ++k) {
    std::string_view got = table.header[k];
    while (!got.empty() && got.front() == ' ') got.remove_prefix(1);
    const std::string_view name = got.substr(0, got.find(' '));
    const bool ok = k == 0   ? name == "#timestamp" || name == "timestamp"
                    : k <= 3 ? name.starts_with('w') || name.starts_with('g')
                             : name.starts_with('a');
    if (!ok) {
      fail(k, fmt::format("column {} is '{}', where EuRoC has the {}", k + 1, got,
                          k == 0   ? "time"
                          : k <= 3 ? "gyroscope"
                                   : "accelerometer"));
    }
    std::string_view unit = got.substr(name.size());
    while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
    if (!unit.empty() && unit != kUnits[k])
      fail(k, fmt::format("column {} is in {}, EuRoC's in {}", k + 1, unit, kUnits[k]));
  }
}

ImuSeries from_table(const ColumnTable& table) {
  check_header(table);  // an empty file has no rows to call it from
  return to_imu_series(table);
}

void write_block(std::FILE* out, const std::string& name, const fmt::memory_buffer& buffer) {
  if (std::fwrite(buffer.data(), 1, buffer.size(), out) != buffer.size()) {
    throw IoError(InputLocation{name, {}, {}, {}},
                  std::string("write failed: ") + std::strerror(errno));
  }
}

}  // namespace

void write_euroc_csv(std::FILE* out, const std::string& name, const ImuSeriesView& series) {
  // No samples is a header alone (reads back as no samples); a channel is present when it has
  // samples, so an empty series has neither.
  if (series.size() > 0 && (!series.has_accel() || !series.has_gyro())) {
    throw Error(fmt::format("{}: an EuRoC CSV needs both accelerometer and gyroscope", name));
  }
  // read_euroc_csv refuses times that go back: refused before anything is written (found in
  // review, 2026-11-27: the Python binding wrote such a file).
  check_time_order(series.t, name);
  fmt::memory_buffer buffer;
  fmt::format_to(std::back_inserter(buffer), "{}\n", kEurocHeader);
  for (std::size_t i = 0; i < series.size(); ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    fmt::format_to(std::back_inserter(buffer),
                   "{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", series.t[i],
                   series.gyro(0, c), series.gyro(1, c), series.gyro(2, c), series.accel(0, c),
                   series.accel(1, c), series.accel(2, c));
    if (buffer.size() > (1 << 16)) {
      write_block(out, name, buffer);
      buffer.clear();
    }
  }
  write_block(out, name, buffer);
  if (std::fflush(out) != 0) {
    throw IoError(InputLocation{name, {}, {}, {}},
                  std::string("write failed: ") + std::strerror(errno));
  }
}

void write_euroc_csv(const std::string& path, const ImuSeriesView& series) {
  write_file_atomically(path, [&](std::FILE* out) { write_euroc_csv(out, path, series); });
}

ImuSeries read_euroc_csv(const std::string& path) {
  return from_table(read_column_text(path, euroc_spec(), check_header));
}

ImuSeries parse_euroc_csv(std::string_view text, const std::string& source_name) {
  return from_table(parse_column_text(text, source_name, euroc_spec(), check_header));
}

}  // namespace imukit
