// Helpers for the codec tests: feed a byte stream in random chunks, corrupt bytes.
#pragma once

#include <vector>

#include "imukit/core/rng.hpp"
#include "imukit/drivers/codec.hpp"

namespace imukit::drivers::testing {

// Feeds `bytes` in chunks of 1..max_chunk bytes (sizes drawn from rng), then finish().
inline std::vector<Sample> feed_split(Codec& codec, const std::vector<uint8_t>& bytes, Rng& rng,
                                      std::size_t max_chunk = 64) {
  std::vector<Sample> out;
  std::size_t pos = 0;
  TimeNs t = 0;
  while (pos < bytes.size()) {
    const std::size_t n =
        std::min<std::size_t>(1 + rng.uniform_index(max_chunk), bytes.size() - pos);
    codec.feed(std::span<const uint8_t>(bytes.data() + pos, n), t += 1000, out);
    pos += n;
  }
  codec.finish(t, out);
  return out;
}

inline void expect_byte_accounting(const Codec& c) {
  const CodecStats& s = c.stats();
  EXPECT_EQ(s.bytes_received, s.bytes_accepted + s.bytes_discarded + c.bytes_pending())
      << "accepted " << s.bytes_accepted << " discarded " << s.bytes_discarded << " pending "
      << c.bytes_pending();
}

}  // namespace imukit::drivers::testing
