// libFuzzer target: the imukit codec on arbitrary bytes in arbitrary chunks.
#include "drivers_codec_fuzz.hpp"
#include "imukit/drivers/imukit_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace imukit::drivers;
  ImukitCodec codec(ImukitCodecOptions{true, 100.0, 8, 0, 1000, 1000});
  // Xsens may carry any float (NaN included) in a checksummed frame, so only the others promise
  // finite values.
  fuzz::run_stream(codec, data, size, true);
  return 0;
}
