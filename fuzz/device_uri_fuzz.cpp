// libFuzzer target: the device URI parser (only parsing: nothing is opened).
#include <string>

#include "imukit/core/error.hpp"
#include "imukit/drivers/uri.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    (void)imukit::drivers::parse_device_uri(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const imukit::Error&) {
  }
  return 0;
}
