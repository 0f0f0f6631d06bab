// libFuzzer target: the xsens codec on arbitrary bytes in arbitrary chunks.
#include "drivers_codec_fuzz.hpp"
#include "imukit/drivers/xsens_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace imukit::drivers;
  XsensCodec codec(XsensCodecOptions{100, 50});
  // Xsens may carry any float (NaN included) in a checksummed frame, so only the others promise
  // finite values.
  fuzz::run_stream(codec, data, size, false);
  return 0;
}
