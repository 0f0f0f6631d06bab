// Fuzzes the EuRoC CSV reader; only imukit::Error may escape.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const imukit::ImuSeries s = imukit::parse_euroc_csv(
        std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
    s.validate();
  } catch (const imukit::Error&) {
  }
  return 0;
}
