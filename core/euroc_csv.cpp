#include "imukit/core/euroc_csv.hpp"

#include <fmt/format.h>
#include <cerrno>
#include <cstring>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"

namespace imukit {
namespace {

const ColumnSpec& euroc_spec() {
  static const ColumnSpec spec = ColumnSpec::parse("t,gx,gy,gz,ax,ay,az", {}, TimeUnit::ns);
  return spec;
}

ImuSeries from_table(const ColumnTable& table) {
  const bool header_ok =
      !table.header.empty() && (table.header.front().rfind("#timestamp", 0) == 0 ||
                                table.header.front().rfind("timestamp", 0) == 0);
  if (!header_ok) {
    throw Error(InputLocation{table.source, 1, 1, {}},
                "not an EuRoC IMU CSV: the first row must be the header starting with "
                "'#timestamp [ns]'");
  }
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
  if (!series.has_accel() || !series.has_gyro()) {
    throw Error(fmt::format("{}: an EuRoC CSV needs both accelerometer and gyroscope", name));
  }
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
  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (!out) {
    throw IoError(InputLocation{path, {}, {}, {}},
                  std::string("cannot open for writing: ") + std::strerror(errno));
  }
  try {
    write_euroc_csv(out, path, series);
  } catch (...) {
    std::fclose(out);
    throw;
  }
  if (std::fclose(out) != 0) {
    throw IoError(InputLocation{path, {}, {}, {}},
                  std::string("close failed: ") + std::strerror(errno));
  }
}

ImuSeries read_euroc_csv(const std::string& path) {
  return from_table(read_column_text(path, euroc_spec()));
}

ImuSeries parse_euroc_csv(std::string_view text, const std::string& source_name) {
  return from_table(parse_column_text(text, source_name, euroc_spec()));
}

}  // namespace imukit
