// Frame layer of the imukit wire protocol v1 (docs/protocol.md): constants, message type codes,
// the frame encoder and the incremental frame decoder.
//
// On the wire a frame is COBS(body) followed by one 0x00 delimiter, where
//   body = version u8 | type u8 | sequence u16 LE | payload | CRC-32C u32 LE
// and the CRC covers version..payload. The payload is at most kMaxPayloadSize bytes, chosen so
// that the CRC-covered part is at most 655 bytes = 5240 bits, inside the 5243-bit range where
// CRC-32C has Hamming distance 6 (every error of up to 5 bits is detected).
//
// FrameDecoder takes bytes in any chunking, returns whole valid frames and counts every byte and
// frame it throws away, so a host can account for all data a device sent. It never allocates:
// its buffers are members, sized for the largest legal frame.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "imukit/firmware_proto/bytes.hpp"
#include "imukit/firmware_proto/cobs.hpp"

namespace imukit::proto {

inline constexpr uint8_t kProtocolVersion = 1;
inline constexpr size_t kHeaderSize = 4;  // version, type, sequence
inline constexpr size_t kCrcSize = 4;
inline constexpr size_t kMaxPayloadSize = 651;
inline constexpr size_t kMaxCheckedSize = kHeaderSize + kMaxPayloadSize;  // 655 bytes under CRC
inline constexpr size_t kMinBodySize = kHeaderSize + kCrcSize;
inline constexpr size_t kMaxBodySize = kMaxCheckedSize + kCrcSize;                  // 659
inline constexpr size_t kMaxEncodedBodySize = cobs_max_encoded_size(kMaxBodySize);  // 662
inline constexpr size_t kMaxFrameSize = kMaxEncodedBodySize + 1;  // with the delimiter: 663
// A link repeats or reorders frames over a few at most; a number further back is taken as the
// gap forward it also is modulo 2^16 (16 bits cannot tell; hosts count losses by sample index).
inline constexpr uint16_t kReorderWindow = 16;

// Koopman's CRC tables give CRC-32C Hamming distance 6 for data words up to 5243 bits.
static_assert(kMaxCheckedSize * 8 <= 5243, "frames must stay inside CRC-32C's HD=6 length");

// Message type codes. Bit 7 set: sent by the device; clear: sent by the host.
enum class MessageType : uint8_t {
  kGetDeviceInfo = 0x01,
  kConfigure = 0x02,
  kStart = 0x03,
  kStop = 0x04,
  kPing = 0x05,
  kCalibrationRead = 0x06,
  kCalibrationWrite = 0x07,
  kDeviceInfo = 0x81,
  kSampleBlock = 0x82,
  kPong = 0x83,
  kCalibrationData = 0x84,
  kAck = 0x85,
  kNack = 0x86,
  kLog = 0x87,
};

// A decoded frame. payload points into the decoder's buffer and stays valid until the next call
// that feeds the decoder.
struct Frame {
  uint8_t version = 0;
  uint8_t type = 0;  // a MessageType code, or an unknown one the caller must reject
  uint16_t sequence = 0;
  const uint8_t* payload = nullptr;
  size_t payload_size = 0;
};

// Encodes one frame (COBS body + delimiter) into out. Returns the bytes written, or 0 if
// payload_size > kMaxPayloadSize or out_capacity < cobs_max_encoded_size(body) + 1 (use
// kMaxFrameSize to be safe for any payload).
size_t encode_frame(uint8_t type, uint16_t sequence, const uint8_t* payload, size_t payload_size,
                    uint8_t* out, size_t out_capacity);

// Per-direction sequence numbering: each frame sent takes the next number (mod 2^16).
class FrameEncoder {
 public:
  size_t encode(uint8_t type, const uint8_t* payload, size_t payload_size, uint8_t* out,
                size_t out_capacity) {
    const size_t n = encode_frame(type, next_sequence_, payload, payload_size, out, out_capacity);
    if (n > 0) ++next_sequence_;
    return n;
  }
  uint16_t next_sequence() const { return next_sequence_; }
  // Consumes a sequence number without sending (a frame that could not be written: the receiver
  // then sees the gap and counts the frame as missed).
  void skip() { ++next_sequence_; }

 private:
  uint16_t next_sequence_ = 0;
};

// What the decoder has seen. Invariant after every call:
//   bytes_received == bytes_accepted + bytes_discarded + pending bytes (FrameDecoder::pending()).
struct DecoderStats {
  uint64_t bytes_received = 0;
  uint64_t bytes_accepted = 0;   // bytes of valid frames, delimiters included
  uint64_t bytes_discarded = 0;  // bytes of everything rejected, delimiters included
  uint32_t frames_ok = 0;
  uint32_t crc_errors = 0;       // CRC mismatch
  uint32_t cobs_errors = 0;      // not a valid COBS encoding
  uint32_t short_frames = 0;     // decoded body shorter than header + CRC
  uint32_t oversize_frames = 0;  // more bytes than the largest legal frame before a delimiter
  uint32_t version_errors = 0;   // CRC fine but a protocol version this decoder does not speak
  uint32_t empty_frames = 0;     // a delimiter right after a delimiter (idle fill, not an error)
  uint32_t sequence_gaps = 0;    // valid frames whose sequence did not follow the previous one
  uint32_t frames_missed = 0;    // total frames skipped over by those gaps
  // Valid frames numbered as the newest one so far or up to kReorderWindow - 1 before it: the
  // link repeated them or delivered them late. No gap (a repeat once counted 65535 missed
  // frames), and the newest number stays the reference for the next frame.
  uint32_t frames_out_of_order = 0;

  uint32_t frames_rejected() const {
    return crc_errors + cobs_errors + short_frames + oversize_frames + version_errors;
  }
};

class FrameDecoder {
 public:
  // Consumes input up to and including the delimiter of the next valid frame, or all of it.
  // Returns the number of bytes consumed; has_frame() tells whether a frame ended there. Call in
  // a loop until all input is consumed (or use feed()).
  size_t consume(const uint8_t* data, size_t n);

  bool has_frame() const { return has_frame_; }
  const Frame& frame() const { return frame_; }
  // The frame just returned was numbered as the newest before it or up to kReorderWindow - 1
  // earlier: repeated or delivered late by the link (DecoderStats::frames_out_of_order).
  bool out_of_order() const { return out_of_order_; }

  // Feeds all of data[0, n) and calls on_frame(const Frame&) for each valid frame, in order.
  template <class OnFrame>
  void feed(const uint8_t* data, size_t n, OnFrame&& on_frame) {
    while (n > 0) {
      const size_t used = consume(data, n);
      data += used;
      n -= used;
      if (has_frame_) on_frame(frame_);
    }
  }

  const DecoderStats& stats() const { return stats_; }
  // Bytes of an unfinished frame held in the buffer (0 while skipping an oversize frame, whose
  // bytes are counted as discarded as they arrive).
  size_t pending() const { return skipping_ ? 0 : size_; }
  // Forget the last sequence number (e.g. after the peer was reset), so the next frame does not
  // count as a gap.
  void reset_sequence() { have_sequence_ = false; }
  // The numbering begins again at `sequence` (the peer was reset and said so in a frame of that
  // number): the next frame is compared with it alone.
  void restart_sequence(uint16_t sequence) {
    have_sequence_ = true;
    last_sequence_ = sequence;
  }

 private:
  void append(const uint8_t* data, size_t n);
  // Ends the frame whose encoded bytes are enc[0, enc_size) (delimiter excluded); total_bytes is
  // what the frame occupied in the input, delimiter included. Returns true for a valid frame.
  bool finish(const uint8_t* enc, size_t enc_size, uint64_t total_bytes);
  void discard(uint64_t bytes, uint32_t& counter) {
    stats_.bytes_discarded += bytes;
    ++counter;
  }

  // Encoded bytes of the frame being received, then its decoded body.
  uint8_t buf_[kMaxEncodedBodySize];
  size_t size_ = 0;
  bool skipping_ = false;
  bool has_frame_ = false;
  bool have_sequence_ = false;
  bool out_of_order_ = false;  // beside the other flags: no padding added (firmware RAM)
  uint16_t last_sequence_ = 0;
  Frame frame_;
  DecoderStats stats_;
};

}  // namespace imukit::proto
