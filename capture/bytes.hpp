// Little-endian byte building and bounds-checked parsing for the binary formats of capture/
// (MCAP records, ROS 2 CDR messages). Every read checks the remaining length first and throws
// imukit::Error naming the byte offset, so a corrupt or hostile file cannot read out of bounds.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/error.hpp"

namespace imukit::capture {

class ByteWriter {
 public:
  explicit ByteWriter(std::vector<uint8_t>& out) : out_(out) {}
  void u8(uint8_t v) { out_.push_back(v); }
  void u16(uint16_t v) { le(v); }
  void u32(uint32_t v) { le(v); }
  void u64(uint64_t v) { le(v); }
  void i32(int32_t v) { le(static_cast<uint32_t>(v)); }
  void f64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    le(bits);
  }
  void bytes(std::span<const uint8_t> b) { out_.insert(out_.end(), b.begin(), b.end()); }
  void bytes(std::string_view s) { out_.insert(out_.end(), s.begin(), s.end()); }
  // MCAP String: u32 length + UTF-8 bytes.
  void string(std::string_view s) {
    u32(static_cast<uint32_t>(s.size()));
    bytes(s);
  }
  std::size_t size() const { return out_.size(); }
  // Overwrites 4 bytes at `at` (for length prefixes filled in after the fact).
  void patch_u32(std::size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i)
      out_[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
  }
  void patch_u64(std::size_t at, uint64_t v) {
    for (int i = 0; i < 8; ++i)
      out_[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
  }

 private:
  // One insert of the value's bytes: a push_back per byte (each checking the capacity) was
  // the largest part of encoding a message (perf, 2026-11-27).
  template <typename T>
  void le(T v) {
    uint8_t b[sizeof(T)];
    for (std::size_t i = 0; i < sizeof(T); ++i) b[i] = static_cast<uint8_t>(v >> (8 * i));
    out_.insert(out_.end(), b, b + sizeof(T));
  }
  std::vector<uint8_t>& out_;
};

class ByteReader {
 public:
  // `base_offset` is the position of data[0] in the file, for error messages.
  ByteReader(std::span<const uint8_t> data, std::string source, uint64_t base_offset)
      : data_(data), source_(std::move(source)), base_(base_offset) {}

  uint8_t u8() { return static_cast<uint8_t>(le<uint8_t>("u8")); }
  uint16_t u16() { return le<uint16_t>("u16"); }
  uint32_t u32() { return le<uint32_t>("u32"); }
  uint64_t u64() { return le<uint64_t>("u64"); }
  int32_t i32() { return static_cast<int32_t>(le<uint32_t>("i32")); }
  double f64() {
    const uint64_t bits = le<uint64_t>("f64");
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
  }
  std::span<const uint8_t> bytes(uint64_t n, const char* what) {
    need(n, what);
    auto out = data_.subspan(pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return out;
  }
  std::string string(const char* what) {
    const uint32_t n = u32();
    auto b = bytes(n, what);
    return std::string(b.begin(), b.end());
  }
  void skip(uint64_t n, const char* what) { (void)bytes(n, what); }
  void align(std::size_t boundary, std::size_t origin) {
    const std::size_t rel = pos_ - origin;
    const std::size_t pad = (boundary - rel % boundary) % boundary;
    skip(pad, "alignment padding");
  }
  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return data_.size() - pos_; }
  bool done() const { return pos_ == data_.size(); }
  uint64_t file_offset() const { return base_ + pos_; }
  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const std::string& what) const {
    throw Error(InputLocation{source_, {}, {}, static_cast<int64_t>(file_offset())}, what);
  }

 private:
  void need(uint64_t n, const char* what) const {
    if (n > remaining()) {
      fail(std::string(what) + ": needs " + std::to_string(n) + " bytes, only " +
           std::to_string(remaining()) + " left in the record");
    }
  }
  template <typename T>
  T le(const char* what) {
    need(sizeof(T), what);
    T v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i)
      v |= static_cast<T>(static_cast<T>(data_[pos_ + i]) << (8 * i));
    pos_ += sizeof(T);
    return v;
  }

  std::span<const uint8_t> data_;
  std::string source_;
  uint64_t base_ = 0;
  std::size_t pos_ = 0;
};

}  // namespace imukit::capture
