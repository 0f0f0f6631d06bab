#include "firmware_proto/cobs.hpp"

#include <string.h>

namespace imukit::proto {

size_t cobs_encode(const uint8_t* in, size_t n, uint8_t* out, size_t out_capacity) {
  // Exact size first, so the loop below needs no bounds checks: one code byte per block, where a
  // block ends at each zero, after 254 non-zero bytes, or at the end of the data.
  size_t blocks = 1;
  size_t run = 0;
  for (size_t i = 0; i < n; ++i) {
    if (in[i] == 0) {
      ++blocks;
      run = 0;
    } else if (++run == 254) {
      ++blocks;
      run = 0;
    }
  }
  size_t zeros = 0;
  for (size_t i = 0; i < n; ++i) zeros += in[i] == 0;
  const size_t size = n - zeros + blocks;
  if (size > out_capacity) return 0;

  size_t code_pos = 0;
  size_t w = 1;
  uint8_t code = 1;
  for (size_t i = 0; i < n; ++i) {
    if (in[i] == 0) {
      out[code_pos] = code;
      code_pos = w++;
      code = 1;
      continue;
    }
    out[w++] = in[i];
    if (++code == 0xFF) {
      out[code_pos] = code;
      code_pos = w++;
      code = 1;
    }
  }
  out[code_pos] = code;
  return w;
}

size_t cobs_decode(const uint8_t* in, size_t n, uint8_t* out) {
  if (n == 0 || memchr(in, 0, n) != nullptr) return kCobsError;
  size_t r = 0;
  size_t w = 0;
  while (r < n) {
    const size_t code = in[r];
    const size_t run = code - 1;
    if (run > n - r - 1) return kCobsError;  // the block would run past the end
    // memmove: when decoding in place the destination trails the source by one byte per block.
    memmove(out + w, in + r + 1, run);
    w += run;
    r += code;
    if (code != 0xFF && r < n) out[w++] = 0;
  }
  return w;
}

}  // namespace imukit::proto
