// Consistent Overhead Byte Stuffing (Cheshire and Baker, "Consistent overhead byte stuffing",
// IEEE/ACM Trans. Networking 7(2), 1999): rewrites a byte string so that it contains no 0x00, at a
// cost of at most one byte per 254 plus one, so 0x00 can delimit frames on a byte stream.
//
// Encoding used by imukit (the paper's form): the data is treated as if followed by one phantom
// 0x00; each run of up to 254 non-zero bytes becomes a code byte (run length + 1) and the run; a
// code of 0xFF means "254 bytes, no zero follows". The phantom zero is not transmitted, so the
// encoding of n bytes always ends with the code of the last (possibly empty) run and has exactly
// n + 1 + floor(n / 254) bytes when the data has no zeros. Examples: {} -> 01; {00} -> 01 01;
// {11 22 00 33} -> 03 11 22 02 33; 254 x {01} -> FF (254 x 01) 01.
//
// Decoding accepts the canonical form and the common variant that omits the final 01 after a
// trailing 0xFF block (both decode to the same bytes). It rejects a 0x00 anywhere in the input
// and a code byte that points past the end.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace imukit::proto {

// Largest encoding of n bytes (n + 1 + floor(n / 254)), without the 0x00 delimiter.
constexpr size_t cobs_max_encoded_size(size_t n) { return n + 1 + n / 254; }

// Encodes in[0, n) into out, which must not overlap in. Returns the encoded size, or 0 when
// out_capacity is smaller than that size (the encoding of anything is at least one byte, so 0
// is never a valid size). No delimiter is written.
size_t cobs_encode(const uint8_t* in, size_t n, uint8_t* out, size_t out_capacity);

inline constexpr size_t kCobsError = static_cast<size_t>(-1);

// Decodes in[0, n) into out; out may equal in (decoding in place: the output never overtakes the
// input) but must not overlap it otherwise. out must have room for n bytes (the decoded size is at
// most n - 1). Returns the decoded size, or kCobsError when the input is not a valid encoding
// (empty, contains 0x00, or a code byte runs past the end).
size_t cobs_decode(const uint8_t* in, size_t n, uint8_t* out);

// cobs_decode for input the caller knows holds no 0x00 (e.g. the bytes between two delimiters
// found with memchr), skipping that scan. out must equal in or not overlap it at all. A 0x00 in
// a code byte is still an error (kCobsError), never an endless loop.
size_t cobs_decode_zero_free(const uint8_t* in, size_t n, uint8_t* out);

// Incremental encoder: feed bytes one at a time (or in runs) into a caller's buffer that has room
// for cobs_max_encoded_size(total) + 1 bytes, then finish() writes the last code byte and the
// delimiter. Lets the frame encoder stuff header, payload and CRC without an intermediate copy.
class CobsStreamEncoder {
 public:
  explicit CobsStreamEncoder(uint8_t* out) : out_(out) {}

  void put(uint8_t byte) {
    if (byte == 0) {
      close_block();
      return;
    }
    out_[size_++] = byte;
    if (++code_ == 0xFF) close_block();
  }
  void put(const uint8_t* data, size_t n) {
    for (size_t i = 0; i < n; ++i) put(data[i]);
  }
  // Closes the last block and appends the 0x00 delimiter; returns the total size written.
  size_t finish() {
    out_[code_pos_] = code_;
    out_[size_++] = 0;
    return size_;
  }

 private:
  void close_block() {
    out_[code_pos_] = code_;
    code_pos_ = size_++;
    code_ = 1;
  }

  uint8_t* out_;
  size_t code_pos_ = 0;  // where the current block's code byte goes
  size_t size_ = 1;      // byte 0 is reserved for the first code byte
  uint8_t code_ = 1;     // 1 + bytes in the current block
};

}  // namespace imukit::proto
