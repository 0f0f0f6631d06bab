// libFuzzer target: the text codec on arbitrary bytes in arbitrary chunks. The first byte picks
// the time unit and the wrap of the time counter (time_bits 0..32), so unwrapping is fuzzed too.
#include "drivers_codec_fuzz.hpp"
#include "imukit/drivers/text_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace imukit::drivers;
  if (size == 0) return 0;
  TextCodecOptions options;
  options.time_bits = data[0] % 33u;
  options.time_digits = 3 * ((data[0] >> 6) & 3);
  TextCodec codec(options);
  // Xsens may carry any float (NaN included) in a checksummed frame, so only the others promise
  // finite values.
  fuzz::run_stream(codec, data + 1, size - 1, true);
  return 0;
}
