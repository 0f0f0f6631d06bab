// Fuzzes the .npy reader; only imukit::Error may escape, and a parsed array's byte count must
// match its shape.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "imukit/core/error.hpp"
#include "imukit/core/npy.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const imukit::NpyArray a = imukit::parse_npy(
        std::span<const std::byte>(reinterpret_cast<const std::byte*>(data), size), "fuzz.npy");
    const std::size_t item = a.dtype == imukit::NpyDtype::float32 ? 4 : 8;
    if (a.bytes.size() != a.size() * item) std::abort();
    (void)a.to_double();
  } catch (const imukit::Error&) {
  }
  return 0;
}
