// libFuzzer target: the DualShock 4 / DualSense codec. Byte 0 picks the model, byte 1 the
// length of a calibration feature report taken from the input; the rest is cut into reports of
// lengths drawn from the input (mostly 64).
#include <cmath>
#include <cstdlib>

#include "imukit/core/error.hpp"
#include "imukit/drivers/playstation_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace imukit::drivers;
  if (size < 2) return 0;
  PlaystationCodec codec((data[0] & 1) ? PlaystationModel::kDualSense
                                       : PlaystationModel::kDualShock4);
  std::size_t cal = data[1] % 48;
  data += 2;
  size -= 2;
  cal = std::min(cal, size);
  try {
    codec.on_feature_report(0, std::span<const uint8_t>(data, cal));
  } catch (const imukit::Error&) {
    // a short or foreign calibration report is rejected, and the default stays
  }
  data += cal;
  size -= cal;
  std::vector<Sample> out;
  std::size_t pos = 0;
  while (pos < size) {
    const std::size_t len =
        std::min<std::size_t>((data[pos] & 0x80) ? data[pos] % 80 : 64, size - pos);
    codec.feed(std::span<const uint8_t>(data + pos, len), 0, out);
    pos += len == 0 ? 1 : len;
  }
  for (const Sample& s : out) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(s.accel[k]) || !std::isfinite(s.gyro[k])) std::abort();
    }
  }
  const CodecStats& st = codec.stats();
  if (st.bytes_received != st.bytes_accepted + st.bytes_discarded) std::abort();
  return 0;
}
