#include "imukit/firmware_proto/crc32c.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <vector>

#include "imukit/firmware_proto/frame.hpp"
#include "proto_test_util.hpp"

namespace imukit::proto {

// The one-table variant that 32-bit targets compile, built on the host under these names
// (tests/firmware_proto/CMakeLists.txt).
uint32_t crc32c_compact(const void* data, size_t n);
uint32_t crc32c_extend_compact(uint32_t crc, const void* data, size_t n);

namespace {

using test::Bytes;
using test::TestRng;

// Bit-at-a-time CRC-32C straight from the definition (reflected register, polynomial 0x82F63B78),
// independent of the table code under test.
uint32_t crc32c_bitwise(const uint8_t* p, size_t n) {
  uint32_t r = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    r ^= p[i];
    for (int b = 0; b < 8; ++b) r = (r >> 1) ^ ((r & 1u) ? 0x82F63B78u : 0u);
  }
  return ~r;
}

TEST(Crc32c, MatchesTheCheckValue) {
  const char* check = "123456789";
  EXPECT_EQ(crc32c(check, 9), 0xE3069283u);
  EXPECT_EQ(crc32c(check, 9), kCrc32cCheckValue);
  EXPECT_EQ(crc32c(nullptr, 0), 0u);
  EXPECT_EQ(crc32c_compact(check, 9), 0xE3069283u);
  EXPECT_EQ(crc32c_bitwise(reinterpret_cast<const uint8_t*>(check), 9), 0xE3069283u);
}

// RFC 3720 appendix B.4 (iSCSI), the 32-byte test patterns.
TEST(Crc32c, MatchesTheIscsiTestPatterns) {
  uint8_t buf[32];
  std::memset(buf, 0x00, 32);
  EXPECT_EQ(crc32c(buf, 32), 0x8A9136AAu);
  EXPECT_EQ(crc32c_compact(buf, 32), 0x8A9136AAu);
  std::memset(buf, 0xFF, 32);
  EXPECT_EQ(crc32c(buf, 32), 0x62A8AB43u);
  for (int i = 0; i < 32; ++i) buf[i] = static_cast<uint8_t>(i);
  EXPECT_EQ(crc32c(buf, 32), 0x46DD794Eu);
  for (int i = 0; i < 32; ++i) buf[i] = static_cast<uint8_t>(31 - i);
  EXPECT_EQ(crc32c(buf, 32), 0x113FDB5Cu);
}

TEST(Crc32c, AgreesWithTheBitwiseDefinitionAtEveryLengthAndAlignment) {
  TestRng rng(1);
  Bytes data(1100);
  for (auto& b : data) b = rng.byte();
  for (size_t offset = 0; offset < 8; ++offset) {
    for (size_t n = 0; n + offset <= data.size(); n += (n < 80 ? 1 : 37)) {
      const uint32_t expected = crc32c_bitwise(data.data() + offset, n);
      ASSERT_EQ(crc32c(data.data() + offset, n), expected)
          << "offset " << offset << " length " << n;
      ASSERT_EQ(crc32c_compact(data.data() + offset, n), expected) << offset << " " << n;
    }
  }
}

TEST(Crc32c, ExtendEqualsOneShotForEverySplit) {
  TestRng rng(2);
  Bytes data(300);
  for (auto& b : data) b = rng.byte();
  const uint32_t whole = crc32c(data.data(), data.size());
  for (size_t split = 0; split <= data.size(); ++split) {
    const uint32_t head = crc32c(data.data(), split);
    ASSERT_EQ(crc32c_extend(head, data.data() + split, data.size() - split), whole) << split;
    ASSERT_EQ(crc32c_extend_compact(head, data.data() + split, data.size() - split), whole);
  }
  EXPECT_EQ(crc32c_extend(0, data.data(), data.size()), whole);
}

// syndrome[d] for a body of n bytes: the check value change caused by flipping the bit at
// distance d from the end of the body (transmission order: bytes in order, bits of a byte from the
// least significant, as the reflected CRC consumes them). check(body) = crc32c(data) ^ stored CRC.
std::vector<uint32_t> single_bit_syndromes(size_t n) {
  Bytes body(n, 0);
  const size_t checked = n - 4;
  auto check = [&] {
    const uint32_t stored = static_cast<uint32_t>(body[checked]) |
                            static_cast<uint32_t>(body[checked + 1]) << 8 |
                            static_cast<uint32_t>(body[checked + 2]) << 16 |
                            static_cast<uint32_t>(body[checked + 3]) << 24;
    return crc32c(body.data(), checked) ^ stored;
  };
  const uint32_t base = check();
  const size_t bits = n * 8;
  std::vector<uint32_t> syndrome(bits);
  for (size_t pos = 0; pos < bits; ++pos) {
    body[pos / 8] ^= static_cast<uint8_t>(1u << (pos % 8));
    syndrome[bits - 1 - pos] = check() ^ base;
    body[pos / 8] ^= static_cast<uint8_t>(1u << (pos % 8));
  }
  return syndrome;
}

// Given (syndrome << 32 | largest distance) for all error patterns of one weight w, sorted: the
// shortest body (in bits) holding two patterns with the same syndrome, i.e. an undetected error of
// weight 2w (the two patterns are disjoint when no lighter undetected error exists). Within a run
// of equal syndromes the first two entries have the smallest largest distances.
size_t shortest_collision_bits(const std::vector<uint64_t>& sorted) {
  size_t shortest = SIZE_MAX;
  for (size_t k = 1; k < sorted.size(); ++k) {
    if ((sorted[k] >> 32) == (sorted[k - 1] >> 32) &&
        (k < 2 || (sorted[k - 2] >> 32) != (sorted[k] >> 32))) {
      shortest = std::min<size_t>(shortest, (sorted[k] & 0xFFFFFFFFu) + 1);
    }
  }
  return shortest;
}

// The guarantee docs/protocol.md states: CRC-32C has Hamming distance 6 for data words up to 5243
// bits (Koopman, "32-Bit Cyclic Redundancy Codes for Internet Applications", DSN 2002; his CRC
// Zoo lists HD=6 up to 5243 bits for 0x8f6e37a0, the same polynomial in his notation), so every
// corruption of 1 to 5 bits of a frame body is detected, and a v1 body (at most 655 checked bytes)
// is inside that length. Verified here from the implementation itself, by linear algebra:
//   for bodies of one length, check(body) = crc32c(data) ^ stored CRC is affine in the body bits,
//   so an error pattern e goes undetected iff syndrome(e) = XOR of its single-bit syndromes = 0.
// A single-bit syndrome depends only on the bit's distance from the end of the body, so one table
// of syndromes for the longest body serves every shorter one.
//   weight 1, 2: syndromes non-zero and pairwise distinct;
//   weight 3, 5 (odd): every single-bit syndrome has odd parity (the generator has the factor
//     x + 1), so no odd number of them can XOR to zero;
//   weight 4: s_a ^ s_b == s_c ^ s_d for two disjoint pairs. The shortest body with such a pair
//     of pairs is found exactly by sorting all pair syndromes; Koopman's figure predicts
//     5243 + 1 data bits + 32 CRC bits = 5276 bits.
TEST(Crc32c, HasHammingDistanceSixUpTo5243DataBitsCoveringTheLargestFrame) {
  constexpr size_t kBodyBytes = 660;  // longer than any v1 body (659) to see where HD=6 ends
  constexpr size_t kBits = kBodyBytes * 8;
  const std::vector<uint32_t> syndrome = single_bit_syndromes(kBodyBytes);
  for (size_t d = 0; d < kBits; ++d) {
    ASSERT_NE(syndrome[d], 0u) << d;
    ASSERT_EQ(std::popcount(syndrome[d]) % 2, 1) << "odd-weight errors must be detected, " << d;
  }
  std::vector<uint32_t> sorted = syndrome;
  std::sort(sorted.begin(), sorted.end());
  ASSERT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end())
      << "two single-bit errors share a syndrome: a 2-bit error would go undetected";

  // Pair syndromes tagged with the pair's larger distance from the end (what decides the body
  // length needed to hold it).
  std::vector<uint64_t> pairs;
  pairs.reserve(kBits * (kBits - 1) / 2);
  for (size_t j = 1; j < kBits; ++j) {
    for (size_t i = 0; i < j; ++i) {
      pairs.push_back(static_cast<uint64_t>(syndrome[i] ^ syndrome[j]) << 32 | j);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  const size_t shortest_bits = shortest_collision_bits(pairs);
  EXPECT_EQ(shortest_bits, 5243u + 1u + 32u)
      << "the shortest body with an undetected 4-bit error; Koopman: HD=6 up to 5243 data bits";
  EXPECT_GT(shortest_bits, kMaxBodySize * 8) << "a v1 frame body must be shorter than that";
}

// Short frames get more: HD = 8 up to 177 data bits (22 bytes: header plus a payload of up to 18
// bytes, i.e. every v1 request, Ack, Nack and Pong), per the same table. Weight-6 errors are two
// triples with one syndrome (weights 1 to 5 are excluded for these lengths by the test above);
// the shortest such body must have 177 + 1 data bits.
TEST(Crc32c, HasHammingDistanceEightUpTo177DataBits) {
  constexpr size_t kBodyBytes = 27;  // 216 bits: beyond 178 + 32
  constexpr size_t kBits = kBodyBytes * 8;
  const std::vector<uint32_t> syndrome = single_bit_syndromes(kBodyBytes);
  std::vector<uint64_t> triples;
  triples.reserve(kBits * (kBits - 1) * (kBits - 2) / 6);
  for (size_t k = 2; k < kBits; ++k) {
    for (size_t j = 1; j < k; ++j) {
      for (size_t i = 0; i < j; ++i) {
        triples.push_back(static_cast<uint64_t>(syndrome[i] ^ syndrome[j] ^ syndrome[k]) << 32 | k);
      }
    }
  }
  std::sort(triples.begin(), triples.end());
  EXPECT_EQ(shortest_collision_bits(triples), 177u + 1u + 32u);
  EXPECT_LE((kHeaderSize + 18) * 8, 177u);
}

}  // namespace
}  // namespace imukit::proto
