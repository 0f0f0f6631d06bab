// Little-endian byte writer and reader with bounds checks, for the fixed message layouts of the
// imukit wire protocol (docs/protocol.md). Every value is (de)serialised byte by byte, so the
// result never depends on struct padding or the host's byte order.
//
// Both classes are sticky on failure: once a write would overflow or a read would run past the
// end, ok() stays false and every later call is a no-op (reads return 0). Callers check ok() once
// at the end instead of after every field. Freestanding: <stdint.h>, <stddef.h>, <string.h> only.
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <string.h>

namespace imukit::proto {

static_assert(sizeof(float) == 4, "the wire format carries IEEE-754 binary32 values");

// The little-endian 32-bit value at p; compilers merge the four byte loads into one load on
// little-endian targets.
inline uint32_t load_le32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

// A read-only run of bytes (the freestanding stand-in for std::span<const uint8_t>).
struct ByteView {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

class ByteWriter {
 public:
  ByteWriter(uint8_t* out, size_t capacity) : out_(out), capacity_(capacity) {}

  void u8(uint8_t v) {
    if (!reserve(1)) return;
    out_[size_++] = v;
  }
  void u16(uint16_t v) {
    if (!reserve(2)) return;
    out_[size_++] = static_cast<uint8_t>(v);
    out_[size_++] = static_cast<uint8_t>(v >> 8);
  }
  void u32(uint32_t v) {
    if (!reserve(4)) return;
    for (int i = 0; i < 4; ++i) out_[size_++] = static_cast<uint8_t>(v >> (8 * i));
  }
  void u64(uint64_t v) {
    if (!reserve(8)) return;
    for (int i = 0; i < 8; ++i) out_[size_++] = static_cast<uint8_t>(v >> (8 * i));
  }
  void i16(int16_t v) { u16(static_cast<uint16_t>(v)); }
  // binary32 bit pattern, little-endian (the value's bytes are copied, not converted).
  void f32(float v) {
    uint32_t bits;
    memcpy(&bits, &v, 4);
    u32(bits);
  }
  void bytes(const void* data, size_t n) {
    if (!reserve(n)) return;
    if (n > 0) memcpy(out_ + size_, data, n);
    size_ += n;
  }
  // Marks the output invalid (a field failed validation while being written).
  void fail() { ok_ = false; }

  bool ok() const { return ok_; }
  size_t size() const { return size_; }

 private:
  bool reserve(size_t n) {
    if (!ok_ || n > capacity_ - size_) {
      ok_ = false;
      return false;
    }
    return true;
  }

  uint8_t* out_;
  size_t capacity_;
  size_t size_ = 0;
  bool ok_ = true;
};

class ByteReader {
 public:
  ByteReader(const uint8_t* in, size_t size) : in_(in), size_(size) {}

  uint8_t u8() {
    if (!take(1)) return 0;
    return in_[pos_++];
  }
  uint16_t u16() {
    if (!take(2)) return 0;
    const uint16_t v = static_cast<uint16_t>(in_[pos_] | (in_[pos_ + 1] << 8));
    pos_ += 2;
    return v;
  }
  uint32_t u32() {
    if (!take(4)) return 0;
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(in_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return v;
  }
  uint64_t u64() {
    if (!take(8)) return 0;
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(in_[pos_ + i]) << (8 * i);
    pos_ += 8;
    return v;
  }
  int16_t i16() { return static_cast<int16_t>(u16()); }
  float f32() {
    const uint32_t bits = u32();
    float v;
    memcpy(&v, &bits, 4);
    return v;
  }
  // Copies n bytes to out; on a short input nothing is copied and ok() turns false.
  void bytes(void* out, size_t n) {
    if (!take(n)) return;
    if (n > 0) memcpy(out, in_ + pos_, n);
    pos_ += n;
  }

  bool ok() const { return ok_; }
  size_t remaining() const { return size_ - pos_; }
  // True when every byte was consumed and no read failed: v1 payloads have exact sizes.
  bool done() const { return ok_ && pos_ == size_; }

 private:
  bool take(size_t n) {
    if (!ok_ || n > size_ - pos_) {
      ok_ = false;
      return false;
    }
    return true;
  }

  const uint8_t* in_;
  size_t size_;
  size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace imukit::proto
