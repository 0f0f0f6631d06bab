#include "imukit/firmware_proto/frame.hpp"

#include <string.h>

#include "imukit/firmware_proto/bytes.hpp"
#include "imukit/firmware_proto/crc32c.hpp"

namespace imukit::proto {

size_t encode_frame(uint8_t type, uint16_t sequence, const uint8_t* payload, size_t payload_size,
                    uint8_t* out, size_t out_capacity) {
  if (payload_size > kMaxPayloadSize) return 0;
  const size_t body_size = kHeaderSize + payload_size + kCrcSize;
  if (out_capacity < cobs_max_encoded_size(body_size) + 1) return 0;
  const uint8_t header[kHeaderSize] = {kProtocolVersion, type, static_cast<uint8_t>(sequence),
                                       static_cast<uint8_t>(sequence >> 8)};
  uint32_t crc = crc32c(header, kHeaderSize);
  crc = crc32c_extend(crc, payload, payload_size);
  const uint8_t crc_bytes[kCrcSize] = {static_cast<uint8_t>(crc), static_cast<uint8_t>(crc >> 8),
                                       static_cast<uint8_t>(crc >> 16),
                                       static_cast<uint8_t>(crc >> 24)};
  CobsStreamEncoder cobs(out);
  cobs.put(header, kHeaderSize);
  cobs.put(payload, payload_size);
  cobs.put(crc_bytes, kCrcSize);
  return cobs.finish();
}

void FrameDecoder::append(const uint8_t* data, size_t n) {
  if (skipping_) {
    stats_.bytes_discarded += n;
    return;
  }
  if (n > kMaxEncodedBodySize - size_) {
    // No legal frame is this long: drop what we have and everything up to the next delimiter.
    discard(size_ + n, stats_.oversize_frames);
    size_ = 0;
    skipping_ = true;
    return;
  }
  memcpy(buf_ + size_, data, n);
  size_ += n;
}

bool FrameDecoder::finish(const uint8_t* enc, size_t enc_size, uint64_t total_bytes) {
  if (enc_size == 0) {
    discard(total_bytes, stats_.empty_frames);
    return false;
  }
  if (enc_size > kMaxEncodedBodySize) {
    discard(total_bytes, stats_.oversize_frames);
    return false;
  }
  // memchr found the delimiter, so enc holds no zero.
  const size_t body_size = cobs_decode_zero_free(enc, enc_size, buf_);
  if (body_size == kCobsError) {
    discard(total_bytes, stats_.cobs_errors);
    return false;
  }
  if (body_size < kMinBodySize) {
    discard(total_bytes, stats_.short_frames);
    return false;
  }
  if (body_size > kMaxBodySize) {
    discard(total_bytes, stats_.oversize_frames);
    return false;
  }
  const size_t checked = body_size - kCrcSize;
  if (crc32c(buf_, checked) != load_le32(buf_ + checked)) {
    discard(total_bytes, stats_.crc_errors);
    return false;
  }
  if (buf_[0] != kProtocolVersion) {
    discard(total_bytes, stats_.version_errors);
    return false;
  }
  frame_.version = buf_[0];
  frame_.type = buf_[1];
  frame_.sequence = static_cast<uint16_t>(buf_[2] | buf_[3] << 8);
  frame_.payload = buf_ + kHeaderSize;
  frame_.payload_size = checked - kHeaderSize;
  const auto behind = static_cast<uint16_t>(last_sequence_ - frame_.sequence);
  out_of_order_ = have_sequence_ && behind < kReorderWindow;
  if (out_of_order_) {
    ++stats_.frames_out_of_order;  // repeated or late: the reference stays at the newest
  } else {
    if (have_sequence_) {
      const uint16_t skipped = static_cast<uint16_t>(frame_.sequence - last_sequence_ - 1u);
      if (skipped != 0) {
        ++stats_.sequence_gaps;
        stats_.frames_missed += skipped;
      }
    }
    have_sequence_ = true;
    last_sequence_ = frame_.sequence;
  }
  ++stats_.frames_ok;
  stats_.bytes_accepted += total_bytes;
  return true;
}

size_t FrameDecoder::consume(const uint8_t* data, size_t n) {
  has_frame_ = false;
  size_t pos = 0;
  while (pos < n) {
    const uint8_t* start = data + pos;
    const size_t avail = n - pos;
    const auto* zero = static_cast<const uint8_t*>(memchr(start, 0, avail));
    if (zero == nullptr) {
      stats_.bytes_received += avail;
      append(start, avail);
      return n;
    }
    const size_t run = static_cast<size_t>(zero - start);
    pos += run + 1;
    stats_.bytes_received += run + 1;
    bool ok;
    if (skipping_) {
      // The oversize frame's bytes were counted as they arrived; only the delimiter is left.
      stats_.bytes_discarded += run + 1;
      skipping_ = false;
      ok = false;
    } else if (size_ == 0) {
      // Fast path: the whole frame is in this chunk, decode straight from the caller's bytes.
      ok = finish(start, run, run + 1);
    } else {
      const size_t held = size_;
      append(start, run);
      if (skipping_) {
        stats_.bytes_discarded += 1;  // the delimiter that ends the oversize frame
        skipping_ = false;
        ok = false;
      } else {
        ok = finish(buf_, size_, held + run + 1);
      }
    }
    size_ = 0;
    if (ok) {
      has_frame_ = true;
      return pos;
    }
  }
  return n;
}

}  // namespace imukit::proto
