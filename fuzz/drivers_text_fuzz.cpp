// libFuzzer target: the text codec on arbitrary bytes in arbitrary chunks.
#include "drivers_codec_fuzz.hpp"
#include "imukit/drivers/text_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace imukit::drivers;
  TextCodec codec;
  // Xsens may carry any float (NaN included) in a checksummed frame, so only the others promise
  // finite values.
  fuzz::run_stream(codec, data, size, true);
  return 0;
}
