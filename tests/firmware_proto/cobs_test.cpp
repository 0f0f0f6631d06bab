#include "imukit/firmware_proto/cobs.hpp"

#include <gtest/gtest.h>

#include "proto_test_util.hpp"

namespace imukit::proto {
namespace {

using test::Bytes;
using test::from_hex;
using test::TestRng;
using test::to_hex;

// Concatenation (building these with vector::insert into a one-byte vector trips a GCC 12
// -Warray-bounds false positive).
Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) {
    for (uint8_t b : p) out.push_back(b);
  }
  return out;
}

Bytes encode(const Bytes& in) {
  Bytes out(cobs_max_encoded_size(in.size()));
  const size_t n = cobs_encode(in.data(), in.size(), out.data(), out.size());
  EXPECT_GT(n, 0u);
  out.resize(n);
  return out;
}

Bytes decode(const Bytes& in) {
  Bytes out(in.size() + 1);
  const size_t n = cobs_decode(in.data(), in.size(), out.data());
  if (n == kCobsError) return {0xEE, 0xEE, 0xEE};  // marker no valid test expects
  out.resize(n);
  return out;
}

// The examples of Cheshire and Baker's paper / the usual COBS test table, written out by hand.
TEST(Cobs, EncodesTheEdgeCasesByHand) {
  EXPECT_EQ(to_hex(encode({})), "01");
  EXPECT_EQ(to_hex(encode({0x00})), "01 01");
  EXPECT_EQ(to_hex(encode({0x00, 0x00})), "01 01 01");
  EXPECT_EQ(to_hex(encode({0x11, 0x22, 0x00, 0x33})), "03 11 22 02 33");
  EXPECT_EQ(to_hex(encode({0x11, 0x22, 0x33, 0x44})), "05 11 22 33 44");
  EXPECT_EQ(to_hex(encode({0x11, 0x00, 0x00, 0x00})), "02 11 01 01 01");
  EXPECT_EQ(to_hex(encode(Bytes(5, 0x00))), "01 01 01 01 01 01");
}

TEST(Cobs, SplitsRunsOf254NonZeroBytes) {
  Bytes run254(254);
  for (size_t i = 0; i < run254.size(); ++i) run254[i] = static_cast<uint8_t>(1 + i % 255);
  EXPECT_EQ(encode(run254), cat({{0xFF}, run254, {0x01}}));  // 01: the phantom zero's block
  EXPECT_EQ(encode(run254).size(), cobs_max_encoded_size(254));

  const Bytes run255 = cat({run254, {0xAB}});
  EXPECT_EQ(encode(run255), cat({{0xFF}, run254, {0x02, 0xAB}}));

  const Bytes run253(run254.begin(), run254.begin() + 253);
  EXPECT_EQ(encode(cat({run253, {0x00}})), cat({{0xFE}, run253, {0x01}}));
  EXPECT_EQ(encode(cat({run254, {0x00}})), cat({{0xFF}, run254, {0x01, 0x01}}));
}

TEST(Cobs, SizeNeverExceedsTheBound) {
  Bytes ones(2000, 0x01);
  for (size_t n : {0u, 1u, 253u, 254u, 255u, 507u, 508u, 509u, 659u, 2000u}) {
    const Bytes in(ones.begin(), ones.begin() + n);
    EXPECT_EQ(encode(in).size(), cobs_max_encoded_size(n)) << n;
  }
  EXPECT_EQ(cobs_max_encoded_size(659), 662u);
}

TEST(Cobs, RefusesTooSmallOutput) {
  const Bytes in = {1, 2, 3};
  uint8_t out[4];
  EXPECT_EQ(cobs_encode(in.data(), in.size(), out, 3), 0u);
  EXPECT_EQ(cobs_encode(in.data(), in.size(), out, 4), 4u);
}

TEST(Cobs, RoundTripsRandomDataWithAnyZeroDensity) {
  TestRng rng(3);
  for (int trial = 0; trial < 3000; ++trial) {
    const size_t n = rng.below(trial < 2000 ? 80 : 1200);
    const uint64_t zero_per_256 = rng.below(257);
    Bytes in(n);
    for (auto& b : in)
      b = rng.below(256) < zero_per_256 ? 0 : static_cast<uint8_t>(1 + rng.below(255));
    const Bytes enc = encode(in);
    ASSERT_LE(enc.size(), cobs_max_encoded_size(n));
    for (uint8_t b : enc) ASSERT_NE(b, 0) << "encoded data must not contain the delimiter";
    ASSERT_EQ(decode(enc), in) << "trial " << trial;
    // In place: the output overwrites the input.
    Bytes buf = enc;
    const size_t m = cobs_decode(buf.data(), buf.size(), buf.data());
    ASSERT_EQ(m, n);
    ASSERT_TRUE(std::equal(in.begin(), in.end(), buf.begin()));
  }
}

TEST(Cobs, StreamEncoderMatchesOneShotEncoder) {
  TestRng rng(4);
  for (int trial = 0; trial < 500; ++trial) {
    Bytes in(rng.below(700));
    for (auto& b : in) b = rng.below(4) == 0 ? 0 : rng.byte();
    Bytes out(cobs_max_encoded_size(in.size()) + 1);
    CobsStreamEncoder stream(out.data());
    stream.put(in.data(), in.size());
    out.resize(stream.finish());
    Bytes expected = encode(in);
    expected.push_back(0x00);
    ASSERT_EQ(out, expected);
  }
}

TEST(Cobs, AcceptsTheVariantWithoutATrailingEmptyBlock) {
  const Bytes run254(254, 0x42);
  EXPECT_EQ(decode(cat({{0xFF}, run254})), run254);          // no final 0x01
  EXPECT_EQ(decode(cat({{0xFF}, run254, {0x01}})), run254);  // canonical
}

TEST(Cobs, RejectsMalformedInput) {
  EXPECT_EQ(decode({}), Bytes({0xEE, 0xEE, 0xEE}));                          // nothing at all
  EXPECT_EQ(decode(from_hex("03 11")), Bytes({0xEE, 0xEE, 0xEE}));           // block past the end
  EXPECT_EQ(decode(from_hex("05 11 22 33")), Bytes({0xEE, 0xEE, 0xEE}));     // one byte short
  EXPECT_EQ(decode(from_hex("03 11 00 02 33")), Bytes({0xEE, 0xEE, 0xEE}));  // a zero inside
  EXPECT_EQ(decode(from_hex("00")), Bytes({0xEE, 0xEE, 0xEE}));
  EXPECT_EQ(decode(from_hex("02 11 03 22")), Bytes({0xEE, 0xEE, 0xEE}));  // last block short
  EXPECT_EQ(decode(from_hex("02 11 02 22")), Bytes({0x11, 0x00, 0x22}));  // and the fixed one
  // The zero-free decoder given a zero anyway (its promise broken): an error, never a hang on a
  // code of 0 (review of 2026-11-27).
  for (const char* hex : {"00 11 22", "02 11 00 22", "03 11 22 00"}) {
    Bytes in = from_hex(hex), out(in.size());
    EXPECT_EQ(cobs_decode_zero_free(in.data(), in.size(), out.data()), kCobsError) << hex;
  }
}

TEST(Cobs, NeverWritesPastTheInputLengthOnGarbage) {
  // Any non-zero input decodes to fewer bytes than it has, or is rejected; ASan checks that the
  // output buffer of exactly n bytes is never overrun.
  TestRng rng(5);
  for (int trial = 0; trial < 20000; ++trial) {
    Bytes in(1 + rng.below(600));
    for (auto& b : in) b = static_cast<uint8_t>(1 + rng.below(255));
    std::vector<uint8_t> out(in.size());
    const size_t n = cobs_decode(in.data(), in.size(), out.data());
    if (n != kCobsError) {
      ASSERT_LT(n, in.size());
    }
  }
}

}  // namespace
}  // namespace imukit::proto
