// CRC-32C (Castagnoli): the frame check sequence of the imukit wire protocol.
//
// Parameters (Williams' model): width 32, polynomial 0x1EDC6F41 (reflected 0x82F63B78), input and
// output reflected, init 0xFFFFFFFF, xorout 0xFFFFFFFF; check value crc32c("123456789") =
// 0xE3069283. Castagnoli, Braeuer, Herrmann, "Optimization of cyclic redundancy-check codes with 24
// and 32 parity bits", IEEE Trans. Commun. 41(6), 1993; the same CRC as iSCSI (RFC 3720) and ext4.
//
// 64-bit hosts use slicing-by-16 (sixteen 256-entry tables: one table lookup per input byte but
// sixteen independent lookups per step; Kounavis and Berry, "A systematic approach to building
// high performance software-based CRC generators", ISCC 2005) on three interleaved streams
// combined by linearity (24 KiB of tables in all, about 6 GB/s). 32-bit targets
// (microcontrollers) use the classic one-table byte-at-a-time loop (1 KiB).
// IMUKIT_PROTO_COMPACT_CRC or IMUKIT_PROTO_FAST_CRC force one or the other. Both give identical
// results; no hardware CRC instruction is used, so the code stays freestanding.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace imukit::proto {

inline constexpr uint32_t kCrc32cCheckValue = 0xE3069283u;  // crc32c("123456789")

// CRC-32C of data[0, n).
uint32_t crc32c(const void* data, size_t n);

// CRC-32C of (A followed by data[0, n)) given crc = crc32c(A); crc32c_extend(0, d, n) equals
// crc32c(d, n), so a message can be checked in pieces.
uint32_t crc32c_extend(uint32_t crc, const void* data, size_t n);

}  // namespace imukit::proto
