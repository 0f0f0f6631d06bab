// Fuzzes the column-mapped text reader: the first line of the input is the column map (and
// optional gaps after a '|'), the rest is the file. Only imukit::Error may escape the parser.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t nl = input.find('\n');
  if (nl == std::string_view::npos) return 0;
  const std::string_view map_line = input.substr(0, nl);
  const std::size_t bar = map_line.find('|');
  try {
    const imukit::ColumnSpec spec = imukit::ColumnSpec::parse(
        map_line.substr(0, bar),
        bar == std::string_view::npos ? std::string_view() : map_line.substr(bar + 1),
        static_cast<imukit::TimeUnit>(size % 4));
    const imukit::ColumnTable table =
        imukit::parse_column_text(input.substr(nl + 1), "fuzz.txt", spec);
    if (table.has(imukit::Column::t)) (void)imukit::to_imu_series(table);
  } catch (const imukit::Error&) {
  }
  return 0;
}
