#include "firmware_proto/crc32c.hpp"

namespace imukit::proto {
namespace {

constexpr uint32_t kReflectedPoly = 0x82F63B78u;  // 0x1EDC6F41 with its bits reversed

#ifdef IMUKIT_PROTO_COMPACT_CRC
constexpr int kSlices = 1;
#else
constexpr int kSlices = 8;
#endif

struct Tables {
  uint32_t t[kSlices][256];
};

// t[0][b] is the CRC register after shifting in byte b (reflected, bit by bit); t[k][b] is the
// same register advanced by k further zero bytes, which is what slicing-by-N needs to combine N
// input bytes with independent lookups.
constexpr Tables make_tables() {
  Tables tables{};
  for (uint32_t b = 0; b < 256; ++b) {
    uint32_t r = b;
    for (int bit = 0; bit < 8; ++bit) r = (r & 1u) ? (r >> 1) ^ kReflectedPoly : r >> 1;
    tables.t[0][b] = r;
  }
  for (int k = 1; k < kSlices; ++k) {
    for (uint32_t b = 0; b < 256; ++b) {
      const uint32_t prev = tables.t[k - 1][b];
      tables.t[k][b] = (prev >> 8) ^ tables.t[0][prev & 0xFFu];
    }
  }
  return tables;
}

constexpr Tables kTables = make_tables();
static_assert(kTables.t[0][1] == 0xF26B8303u, "CRC-32C table entry 1 (reflected 0x82F63B78)");

#ifndef IMUKIT_PROTO_COMPACT_CRC
// Little-endian 32-bit load; compilers merge the four byte loads into one on little-endian targets.
inline uint32_t load_le32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}
#endif

}  // namespace

uint32_t crc32c_extend(uint32_t crc, const void* data, size_t n) {
  const auto* p = static_cast<const uint8_t*>(data);
  const auto& t = kTables.t;
  uint32_t r = ~crc;  // undo the final xorout of the previous piece: the register state
#ifndef IMUKIT_PROTO_COMPACT_CRC
  while (n >= 8) {
    const uint32_t lo = load_le32(p) ^ r;
    const uint32_t hi = load_le32(p + 4);
    r = t[7][lo & 0xFFu] ^ t[6][(lo >> 8) & 0xFFu] ^ t[5][(lo >> 16) & 0xFFu] ^ t[4][lo >> 24] ^
        t[3][hi & 0xFFu] ^ t[2][(hi >> 8) & 0xFFu] ^ t[1][(hi >> 16) & 0xFFu] ^ t[0][hi >> 24];
    p += 8;
    n -= 8;
  }
#endif
  while (n > 0) {
    r = (r >> 8) ^ t[0][(r ^ *p) & 0xFFu];
    ++p;
    --n;
  }
  return ~r;
}

uint32_t crc32c(const void* data, size_t n) { return crc32c_extend(0, data, n); }

}  // namespace imukit::proto
