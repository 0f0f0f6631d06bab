// Helpers shared by the firmware_proto tests: hex strings, a deterministic RNG, random valid
// messages of every type, field-by-field comparison of messages, and chunked feeding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace imukit::proto::test {

using Bytes = std::vector<uint8_t>;

// "04 01 ff" (spaces optional) -> bytes. Fails the calling test on malformed input.
Bytes from_hex(const std::string& hex);
std::string to_hex(const uint8_t* data, size_t n);
inline std::string to_hex(const Bytes& b) { return to_hex(b.data(), b.size()); }

// std::mt19937_64 is specified bit-exactly by the standard, so the same seed gives the same
// sequence everywhere; the helpers below avoid std::*_distribution, whose output is not.
class TestRng {
 public:
  explicit TestRng(uint64_t seed) : engine_(seed) {}
  uint64_t bits() { return engine_(); }
  // Uniform in [0, n) (n > 0); the modulo bias is below 2^-40 for the n used here.
  uint64_t below(uint64_t n) { return engine_() % n; }
  uint8_t byte() { return static_cast<uint8_t>(engine_()); }
  int16_t i16() { return static_cast<int16_t>(engine_()); }
  // Mostly small magnitudes (many 0x00 and 0xFF bytes, like a real IMU at rest), sometimes any.
  int16_t imu_value() {
    const uint64_t r = engine_();
    if ((r & 3) == 0) return static_cast<int16_t>(r >> 16);
    return static_cast<int16_t>(static_cast<int64_t>((r >> 16) % 2001) - 1000);
  }

 private:
  std::mt19937_64 engine_;
};

// Random valid instances of every message.
DeviceInfo random_device_info(TestRng& rng);
Configure random_configure(TestRng& rng);
Ping random_ping(TestRng& rng);
Pong random_pong(TestRng& rng);
CalibrationBlob random_blob(TestRng& rng);
Ack random_ack(TestRng& rng);
Nack random_nack(TestRng& rng);
Log random_log(TestRng& rng);
SampleBlock random_sample_block(TestRng& rng, uint8_t count, uint8_t channels);

// Field-by-field equality (only the meaningful part of fixed-capacity arrays).
bool same(const DeviceInfo& a, const DeviceInfo& b);
bool same(const Configure& a, const Configure& b);
bool same(const Ping& a, const Ping& b);
bool same(const Pong& a, const Pong& b);
bool same(const CalibrationBlob& a, const CalibrationBlob& b);
bool same(const Ack& a, const Ack& b);
bool same(const Nack& a, const Nack& b);
bool same(const Log& a, const Log& b);
bool same(const SampleBlock& a, const SampleBlock& b);

// A decoded frame copied out of the decoder's buffer.
struct OwnedFrame {
  uint8_t type = 0;
  uint16_t sequence = 0;
  Bytes payload;
  bool operator==(const OwnedFrame&) const = default;
};

// Feeds data to the decoder in chunks of random size in [1, max_chunk] and returns the frames.
std::vector<OwnedFrame> feed_chunked(FrameDecoder& decoder, const Bytes& data, TestRng& rng,
                                     size_t max_chunk);

// A complete encoded frame (delimiter included) for a message.
template <class M>
Bytes encode(const M& m, uint16_t sequence) {
  Bytes out(kMaxFrameSize);
  const size_t n = encode_message(m, sequence, out.data(), out.size());
  out.resize(n);
  return out;
}

Bytes encode_raw(uint8_t type, uint16_t sequence, const Bytes& payload);

}  // namespace imukit::proto::test
