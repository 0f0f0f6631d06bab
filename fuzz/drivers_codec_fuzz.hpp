// Shared body of the drivers codec fuzzers: the first input byte picks the chunk sizes, the rest
// is the byte stream. Checks what must hold for any input: no crash or sanitizer report, every
// byte accounted for (accepted + discarded + pending == received), every value finite.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/drivers/codec.hpp"

namespace imukit::drivers::fuzz {

inline void run_stream(Codec& codec, const uint8_t* data, std::size_t size, bool finite_values) {
  if (size == 0) return;
  const std::size_t chunk = 1 + data[0] % 97;
  ++data;
  --size;
  std::vector<Sample> out;
  try {
    codec.start(0);
    TimeNs t = 0;
    for (std::size_t pos = 0; pos < size; pos += chunk) {
      const std::size_t n = std::min(chunk, size - pos);
      codec.feed(std::span<const uint8_t>(data + pos, n), t += 1000, out);
      codec.tick(t);
      (void)codec.take_outgoing();
    }
    codec.finish(t, out);
  } catch (const imukit::Error&) {
    return;  // a codec may end a stream with an error (e.g. the device refused its configuration)
  }
  const CodecStats& s = codec.stats();
  if (s.bytes_received != s.bytes_accepted + s.bytes_discarded + codec.bytes_pending())
    std::abort();
  if (s.samples_decoded != out.size()) std::abort();
  if (finite_values) {
    for (const Sample& x : out) {
      for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(x.accel[k]) || !std::isfinite(x.gyro[k])) std::abort();
      }
    }
  }
}

}  // namespace imukit::drivers::fuzz
