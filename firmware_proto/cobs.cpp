#include "imukit/firmware_proto/cobs.hpp"

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

// Decoding in two modes, in place or into a separate buffer alike.
//  1. Shift everything left by one byte: out[i] = in[i + 1]. While no block has code 0xFF, this
//     is already the decoded data except that each later code byte must become 0x00, so a walk
//     along the chain of code bytes (p += code) writing zeros finishes the job. IMU samples near
//     zero are full of 0x00 bytes, so blocks are short (3 to 4 bytes for a device at rest) and
//     this walk, one dependent load per block, is what bounds the decoding speed (about 5 cycles
//     per block); with the copying done in one bulk move it runs about 20 % faster than a copy
//     per block.
//  2. After a 0xFF block (254 non-zero bytes, no zero follows) the next code byte is dropped, not
//     replaced, so the rest moves block by block. Runs that long are rare in IMU data.
size_t cobs_decode_zero_free(const uint8_t* in, size_t n, uint8_t* out) {
  if (n == 0 || in[0] == 0) return kCobsError;
  const size_t first = in[0];
  memmove(out, in + 1, n - 1);  // out[i] = in[i + 1]
  // codes[p - 1] is the input byte in[p]: read from the untouched input when out is a separate
  // buffer (25 % faster than reading bytes the bulk move has just written), from out in place.
  const uint8_t* codes = out == in ? out : in + 1;
  size_t p = first;         // position in the input of the next code byte
  size_t previous = first;  // code of the block that ends at p
  while (p < n && previous != 0xFF) {
    previous = codes[p - 1];
    // A zero code would never move on: the caller broke the promise of zero-free input (a
    // firmware must not hang on it; review of 2026-11-27).
    if (previous == 0) return kCobsError;
    out[p - 1] = 0;
    p += previous;
  }
  if (p >= n) return p == n ? n - 1 : kCobsError;  // past the end: the last block was too long
  size_t w = p - 1;  // decoded bytes so far; the block before p was a 0xFF block (no zero)
  while (p < n) {
    const size_t code = out[p - 1];
    const size_t run = code - 1;
    if (run > n - p - 1) return kCobsError;
    memmove(out + w, out + p, run);  // the block's bytes in[p + 1, p + code) sit at out[p, ...)
    w += run;
    p += code;
    if (code != 0xFF && p < n) out[w++] = 0;
  }
  return w;
}

size_t cobs_decode(const uint8_t* in, size_t n, uint8_t* out) {
  if (n == 0 || memchr(in, 0, n) != nullptr) return kCobsError;
  return cobs_decode_zero_free(in, n, out);
}

}  // namespace imukit::proto
