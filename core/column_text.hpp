// Column-mapped text: the one grammar imukit uses to read numeric text files people already
// have (DESIGN.md, "Column-mapped text"). `--columns t,ax,ay,az,gx,gy,gz` names the file's
// columns in order; see docs/formats.md for the full grammar:
//   names   t ax ay az gx gy gz mx my mz qw qx qy qz px py pz temp
//   _       skip one column;  _N skips N columns;  _* (last) ignores any further columns
//   time    --time-unit s|ms|us|ns (default s), parsed exactly to int64 nanoseconds
//   rows    commas or blanks separate fields; a non-numeric first row is a header; blank lines
//           are skipped; every other row must have exactly the mapped number of fields
//   gaps    NaN (or an empty field) is an error unless the column is declared gappy (--gaps);
//           Inf is always an error
#pragma once

#include <array>
#include <bitset>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imukit/core/imu_series.hpp"
#include "imukit/core/time.hpp"

namespace imukit {

enum class Column : uint8_t {
  t,
  ax,
  ay,
  az,
  gx,
  gy,
  gz,
  mx,
  my,
  mz,
  qw,
  qx,
  qy,
  qz,
  px,
  py,
  pz,
  temp
};
inline constexpr std::size_t kColumnCount = 18;

std::string_view column_name(Column c);
std::optional<Column> column_from_name(std::string_view name);

enum class TimeUnit { s, ms, us, ns };
// "s", "ms", "us" (or "µs"), "ns"; throws imukit::Error otherwise.
TimeUnit parse_time_unit(std::string_view text);

struct ColumnSpec {
  std::vector<std::optional<Column>> columns;  // file column -> name, nullopt = skipped
  bool ignore_extra = false;                   // the map ended with "_*"
  TimeUnit time_unit = TimeUnit::s;
  // Times are whole numbers of time_unit, written as plain integers (EuRoC's nanoseconds): a
  // fraction or an exponent is an error rather than rounded.
  bool integer_time = false;
  std::bitset<kColumnCount> gappy;

  // Parses "--columns" and "--gaps" text; throws imukit::Error naming the bad token.
  static ColumnSpec parse(std::string_view columns, std::string_view gaps = {},
                          TimeUnit time_unit = TimeUnit::s);
  bool has(Column c) const;
  // Throws imukit::Error (no location: the map is the command line's) when the map names a
  // triad (ax..az, gx..gz, mx..mz) in part, which to_imu_series refuses; a reader of IMU samples
  // calls it before reading any row, so the map's mistake is not hidden behind a row's.
  void require_whole_triads() const;
  // The map written back in the grammar, e.g. "t,ax,ay,az,_2".
  std::string to_string() const;
};

// The numbers of a column-mapped file, one vector per named column.
struct ColumnTable {
  std::string source;
  std::vector<std::string> header;      // the header row's fields, if the file had one
  std::vector<int64_t> header_columns;  // where each header field starts (1-based character)
  int64_t first_row_line = 0;           // the line of the first row, header or data (1-based)
  std::vector<TimeNs> t;                // empty when the map has no t column
  std::array<std::vector<double>, kColumnCount> values;  // empty for columns not in the map
  std::bitset<kColumnCount> present;                     // the columns the map named
  std::size_t rows = 0;

  bool has(Column c) const { return present[static_cast<std::size_t>(c)]; }
  const std::vector<double>& operator[](Column c) const {
    return values[static_cast<std::size_t>(c)];
  }
  // The file line of data row `row` (0-based), for messages.
  int64_t line_of(std::size_t row) const;

  // Data rows whose line is not the line after the row before's (blank lines, a header):
  // (row, line) pairs in order, so line_of costs no memory per row.
  std::vector<std::pair<std::size_t, int64_t>> line_jumps;
};

// check_header, when given, sees the table once its header row is read (table.header; empty
// when the first row is data) and before any data row, so a format with a fixed header can
// refuse a file by its header rather than by whatever its first row breaks.
using HeaderCheck = std::function<void(const ColumnTable& table)>;
ColumnTable read_column_text(const std::string& path, const ColumnSpec& spec,
                             const HeaderCheck& check_header = {});
ColumnTable parse_column_text(std::string_view text, const std::string& source_name,
                              const ColumnSpec& spec, const HeaderCheck& check_header = {});

// Factors that turn a file's values into SI units (multiply), e.g. accel = 9.80665 for a file
// in g, gyro = pi/180 for deg/s, mag = 1e-6 for microtesla.
struct ChannelScale {
  double accel = 1.0;
  double gyro = 1.0;
  double mag = 1.0;
};

// An ImuSeries from a table with a t column. A triad (ax..az) is taken only when all three
// columns are mapped; a partly mapped triad is an error, as is a table without t.
ImuSeries to_imu_series(const ColumnTable& table, const ChannelScale& scale = {});

}  // namespace imukit
