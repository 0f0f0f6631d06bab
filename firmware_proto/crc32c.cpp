#include "imukit/firmware_proto/crc32c.hpp"

#include "imukit/firmware_proto/bytes.hpp"

namespace imukit::proto {
namespace {

constexpr uint32_t kReflectedPoly = 0x82F63B78u;  // 0x1EDC6F41 with its bits reversed

// Slicing-by-16 on three interleaved streams on 64-bit hosts (24 KiB of tables; about 1.5x the
// speed of plain slicing-by-16, which is 1.5x slicing-by-8); the one-table loop (1 KiB) on 32-bit
// targets, i.e. microcontrollers, where flash is scarce and a few hundred bytes per frame at a few
// hundred frames per second cost well under 1 % of the CPU. IMUKIT_PROTO_COMPACT_CRC /
// IMUKIT_PROTO_FAST_CRC override the choice.
#if defined(IMUKIT_PROTO_COMPACT_CRC)
#define IMUKIT_PROTO_CRC_SLICES 1
#elif defined(IMUKIT_PROTO_FAST_CRC) || UINTPTR_MAX > 0xFFFFFFFFu
#define IMUKIT_PROTO_CRC_SLICES 16
#else
#define IMUKIT_PROTO_CRC_SLICES 1
#endif
constexpr int kSlices = IMUKIT_PROTO_CRC_SLICES;
// The three-stream interleave pays on out-of-order CPUs (hosts), not on in-order microcontrollers.
#if IMUKIT_PROTO_CRC_SLICES == 16 && UINTPTR_MAX > 0xFFFFFFFFu
#define IMUKIT_PROTO_CRC_STREAMS 3
#else
#define IMUKIT_PROTO_CRC_STREAMS 1
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

#if IMUKIT_PROTO_CRC_SLICES == 16
// One slicing-by-16 step: 16 input bytes; byte k of the step is looked up in the table that
// advances it by the 15 - k bytes that follow it in the step, and the 16 lookups are independent.
inline uint32_t step16(uint32_t r, const uint8_t* p) {
  const auto& t = kTables.t;
  const uint32_t a = load_le32(p) ^ r;
  const uint32_t b = load_le32(p + 4);
  const uint32_t c = load_le32(p + 8);
  const uint32_t d = load_le32(p + 12);
  return t[15][a & 0xFFu] ^ t[14][(a >> 8) & 0xFFu] ^ t[13][(a >> 16) & 0xFFu] ^ t[12][a >> 24] ^
         t[11][b & 0xFFu] ^ t[10][(b >> 8) & 0xFFu] ^ t[9][(b >> 16) & 0xFFu] ^ t[8][b >> 24] ^
         t[7][c & 0xFFu] ^ t[6][(c >> 8) & 0xFFu] ^ t[5][(c >> 16) & 0xFFu] ^ t[4][c >> 24] ^
         t[3][d & 0xFFu] ^ t[2][(d >> 8) & 0xFFu] ^ t[1][(d >> 16) & 0xFFu] ^ t[0][d >> 24];
}

#endif

#if IMUKIT_PROTO_CRC_STREAMS == 3
// Three interleaved streams. A single slicing chain waits for each step's lookups before the next
// step can start; three independent chains keep the load units busy (about 1.5x faster on a
// frame of a few hundred bytes). It rests on the linearity of the CRC register over GF(2): for
// consecutive pieces A, B, C of S bytes each,
//   reg(A B C) = shift_2S(reg(A)) ^ shift_S(reg0(B)) ^ reg0(C),
// where reg0 starts from a zero register and shift_n advances a register through n zero bytes,
// a linear map applied with four 256-entry tables (one per register byte).
constexpr size_t kStreamBytes = 32;

struct ShiftTable {
  uint32_t t[4][256];
};

constexpr ShiftTable make_shift(size_t zero_bytes) {
  uint32_t image[32] = {};  // shift of each single register bit
  for (int bit = 0; bit < 32; ++bit) {
    uint32_t r = 1u << bit;
    for (size_t i = 0; i < zero_bytes; ++i) r = (r >> 8) ^ kTables.t[0][r & 0xFFu];
    image[bit] = r;
  }
  ShiftTable s{};
  for (int k = 0; k < 4; ++k) {
    for (uint32_t v = 0; v < 256; ++v) {
      uint32_t r = 0;
      for (int bit = 0; bit < 8; ++bit) {
        if ((v >> bit) & 1u) r ^= image[8 * k + bit];
      }
      s.t[k][v] = r;
    }
  }
  return s;
}

constexpr ShiftTable kShift1 = make_shift(kStreamBytes);
constexpr ShiftTable kShift2 = make_shift(2 * kStreamBytes);

inline uint32_t shift(const ShiftTable& s, uint32_t r) {
  return s.t[0][r & 0xFFu] ^ s.t[1][(r >> 8) & 0xFFu] ^ s.t[2][(r >> 16) & 0xFFu] ^ s.t[3][r >> 24];
}
#endif

}  // namespace

uint32_t crc32c_extend(uint32_t crc, const void* data, size_t n) {
  const auto* p = static_cast<const uint8_t*>(data);
  uint32_t r = ~crc;  // undo the final xorout of the previous piece: the register state
#if IMUKIT_PROTO_CRC_STREAMS == 3
  while (n >= 3 * kStreamBytes) {
    uint32_t a = r;
    uint32_t b = 0;
    uint32_t c = 0;
    for (size_t i = 0; i < kStreamBytes; i += 16) {
      a = step16(a, p + i);
      b = step16(b, p + kStreamBytes + i);
      c = step16(c, p + 2 * kStreamBytes + i);
    }
    r = shift(kShift2, a) ^ shift(kShift1, b) ^ c;
    p += 3 * kStreamBytes;
    n -= 3 * kStreamBytes;
  }
#endif
#if IMUKIT_PROTO_CRC_SLICES == 16
  while (n >= 16) {
    r = step16(r, p);
    p += 16;
    n -= 16;
  }
#endif
  while (n > 0) {
    r = (r >> 8) ^ kTables.t[0][(r ^ *p) & 0xFFu];
    ++p;
    --n;
  }
  return ~r;
}

uint32_t crc32c(const void* data, size_t n) { return crc32c_extend(0, data, n); }

}  // namespace imukit::proto
