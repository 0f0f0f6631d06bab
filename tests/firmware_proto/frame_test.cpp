#include "imukit/firmware_proto/frame.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "imukit/firmware_proto/crc32c.hpp"
#include "imukit/firmware_proto/messages.hpp"
#include "proto_test_util.hpp"

namespace imukit::proto {
namespace {

using test::Bytes;
using test::encode_raw;
using test::feed_chunked;
using test::OwnedFrame;
using test::TestRng;

Bytes random_payload(TestRng& rng, size_t n) {
  Bytes p(n);
  for (auto& b : p) b = rng.below(5) == 0 ? 0 : rng.byte();
  return p;
}

void expect_accounting(const FrameDecoder& d) {
  const DecoderStats& s = d.stats();
  EXPECT_EQ(s.bytes_received, s.bytes_accepted + s.bytes_discarded + d.pending());
}

// The body (header + payload + CRC) of a frame, before COBS.
Bytes body_of(uint8_t type, uint16_t seq, const Bytes& payload) {
  Bytes body(kHeaderSize + payload.size());
  body[0] = kProtocolVersion;
  body[1] = type;
  body[2] = static_cast<uint8_t>(seq);
  body[3] = static_cast<uint8_t>(seq >> 8);
  std::copy(payload.begin(), payload.end(), body.begin() + kHeaderSize);
  const uint32_t crc = crc32c(body.data(), body.size());
  for (int i = 0; i < 4; ++i) body.push_back(static_cast<uint8_t>(crc >> (8 * i)));
  return body;
}

Bytes cobs_frame(const Bytes& body) {
  Bytes out(cobs_max_encoded_size(body.size()) + 1);
  size_t n = cobs_encode(body.data(), body.size(), out.data(), out.size());
  out[n++] = 0;
  out.resize(n);
  return out;
}

TEST(FrameEncoder, ProducesCobsOfHeaderPayloadAndCrc) {
  TestRng rng(20);
  for (size_t n : {size_t{0}, size_t{1}, size_t{100}, size_t{250}, size_t{251}, size_t{500},
                   kMaxPayloadSize}) {
    const Bytes payload = random_payload(rng, n);
    EXPECT_EQ(encode_raw(0x42, 0x1234, payload), cobs_frame(body_of(0x42, 0x1234, payload))) << n;
  }
}

TEST(FrameEncoder, RefusesOversizePayloadAndSmallBuffers) {
  Bytes payload(kMaxPayloadSize + 1, 1);
  Bytes out(2000);
  EXPECT_EQ(encode_frame(1, 0, payload.data(), payload.size(), out.data(), out.size()), 0u);
  EXPECT_EQ(encode_frame(1, 0, payload.data(), 10, out.data(), 10), 0u);
  // The worst case (no zero anywhere in a full body) fits kMaxFrameSize exactly.
  EXPECT_EQ(cobs_max_encoded_size(kMaxBodySize) + 1, kMaxFrameSize);
  EXPECT_GT(encode_frame(1, 0x0101, payload.data(), kMaxPayloadSize, out.data(), kMaxFrameSize),
            0u);
}

TEST(FrameEncoder, NumbersFramesPerDirection) {
  FrameEncoder enc;
  Bytes out(kMaxFrameSize);
  FrameDecoder dec;
  std::vector<uint16_t> seqs;
  for (int i = 0; i < 70000; ++i) {
    const size_t n = enc.encode(0x85, nullptr, 0, out.data(), out.size());
    ASSERT_GT(n, 0u);
    dec.feed(out.data(), n, [&](const Frame& f) { seqs.push_back(f.sequence); });
  }
  ASSERT_EQ(seqs.size(), 70000u);
  EXPECT_EQ(seqs[65535], 65535);
  EXPECT_EQ(seqs[65536], 0);  // wraps without counting a gap
  EXPECT_EQ(dec.stats().sequence_gaps, 0u);
}

TEST(FrameDecoder, DecodesAnyChunkingIdentically) {
  TestRng rng(21);
  Bytes stream;
  std::vector<OwnedFrame> sent;
  for (uint16_t i = 0; i < 300; ++i) {
    OwnedFrame f{rng.byte(), i, random_payload(rng, rng.below(kMaxPayloadSize + 1))};
    const Bytes wire = encode_raw(f.type, f.sequence, f.payload);
    stream.insert(stream.end(), wire.begin(), wire.end());
    sent.push_back(f);
  }
  for (size_t max_chunk : {1u, 2u, 7u, 64u, 663u, 4096u, 1000000u}) {
    FrameDecoder dec;
    const auto frames = feed_chunked(dec, stream, rng, max_chunk);
    ASSERT_EQ(frames.size(), sent.size()) << max_chunk;
    EXPECT_TRUE(frames == sent) << max_chunk;
    EXPECT_EQ(dec.stats().frames_ok, 300u);
    EXPECT_EQ(dec.stats().bytes_accepted, stream.size());
    EXPECT_EQ(dec.stats().bytes_discarded, 0u);
    EXPECT_EQ(dec.pending(), 0u);
  }
}

TEST(FrameDecoder, ConsumeStopsRightAfterEachFrame) {
  const Bytes a = encode_raw(1, 0, {1, 2, 3});
  const Bytes b = encode_raw(2, 1, {});
  Bytes stream = a;
  stream.insert(stream.end(), b.begin(), b.end());
  FrameDecoder dec;
  size_t used = dec.consume(stream.data(), stream.size());
  EXPECT_EQ(used, a.size());
  ASSERT_TRUE(dec.has_frame());
  EXPECT_EQ(dec.frame().type, 1);
  EXPECT_EQ(dec.frame().payload_size, 3u);
  used += dec.consume(stream.data() + used, stream.size() - used);
  EXPECT_EQ(used, stream.size());
  ASSERT_TRUE(dec.has_frame());
  EXPECT_EQ(dec.frame().type, 2);
  EXPECT_EQ(dec.consume(stream.data(), 0), 0u);
  EXPECT_FALSE(dec.has_frame());
}

TEST(FrameDecoder, CountsEachKindOfRejectAndEveryDiscardedByte) {
  const Bytes good = encode_raw(0x85, 0, {3, 0, 0});
  FrameDecoder dec;
  uint64_t fed = 0;
  auto feed = [&](const Bytes& b) {
    int frames = 0;
    fed += b.size();
    dec.feed(b.data(), b.size(), [&](const Frame&) { ++frames; });
    return frames;
  };
  // Idle fill: lone delimiters.
  EXPECT_EQ(feed({0, 0, 0}), 0);
  EXPECT_EQ(dec.stats().empty_frames, 3u);
  EXPECT_EQ(dec.stats().bytes_discarded, 3u);
  // A frame with a wrong CRC.
  Bytes body = body_of(0x85, 1, {3, 0, 0});
  body[5] ^= 0x10;
  EXPECT_EQ(feed(cobs_frame(body)), 0);
  EXPECT_EQ(dec.stats().crc_errors, 1u);
  // Invalid COBS: a code byte pointing past the delimiter.
  EXPECT_EQ(feed({0x09, 0x01, 0x02, 0x00}), 0);
  EXPECT_EQ(dec.stats().cobs_errors, 1u);
  // Too short for header + CRC.
  EXPECT_EQ(feed(cobs_frame({1, 0x85, 0, 0, 0, 0, 0})), 0);
  EXPECT_EQ(dec.stats().short_frames, 1u);
  // Valid CRC, unknown version.
  body = body_of(0x85, 2, {});
  body[0] = 2;
  const uint32_t crc = crc32c(body.data(), body.size() - 4);
  for (int i = 0; i < 4; ++i) body[body.size() - 4 + i] = static_cast<uint8_t>(crc >> (8 * i));
  EXPECT_EQ(feed(cobs_frame(body)), 0);
  EXPECT_EQ(dec.stats().version_errors, 1u);
  // Oversize: 5000 non-zero bytes, then a delimiter.
  EXPECT_EQ(feed(Bytes(5000, 0x55)), 0);
  EXPECT_EQ(dec.pending(), 0u);
  EXPECT_EQ(feed({0}), 0);
  EXPECT_EQ(dec.stats().oversize_frames, 1u);
  // A frame that decodes to more than the largest body: 661 zeros are 662 bytes of 0x01, short
  // enough to be buffered but two bytes too long once decoded.
  const Bytes big = cobs_frame(Bytes(661, 0));
  ASSERT_EQ(big.size(), kMaxEncodedBodySize + 1);
  EXPECT_EQ(feed(big), 0);
  EXPECT_EQ(dec.stats().oversize_frames, 2u);
  // Then a good frame still comes through.
  EXPECT_EQ(feed(good), 1);
  const DecoderStats& s = dec.stats();
  EXPECT_EQ(s.frames_ok, 1u);
  EXPECT_EQ(s.frames_rejected(), 6u);
  EXPECT_EQ(s.bytes_accepted, good.size());
  EXPECT_EQ(s.bytes_received, fed);
  EXPECT_EQ(s.bytes_discarded, fed - good.size());
  expect_accounting(dec);
}

TEST(FrameDecoder, BuffersNothingBeyondOneFrameAndResyncsAfterOversize) {
  FrameDecoder dec;
  TestRng rng(22);
  Bytes junk(10000);
  for (auto& b : junk) b = static_cast<uint8_t>(1 + rng.below(255));
  const Bytes good = encode_raw(0x87, 5, {1, 2, 3, 4});
  Bytes stream = junk;
  stream.push_back(0);
  stream.insert(stream.end(), good.begin(), good.end());
  for (size_t max_chunk : {1u, 100u, 20000u}) {
    FrameDecoder d;
    const auto frames = feed_chunked(d, stream, rng, max_chunk);
    ASSERT_EQ(frames.size(), 1u);
    EXPECT_EQ(frames[0].sequence, 5);
    EXPECT_EQ(d.stats().oversize_frames, 1u);
    EXPECT_EQ(d.stats().bytes_discarded, junk.size() + 1);
    expect_accounting(d);
  }
}

TEST(FrameDecoder, CountsSequenceGapsAndMissedFrames) {
  FrameDecoder dec;
  Bytes stream;
  for (uint16_t seq : {10, 11, 13, 14, 20, 65535, 1}) {
    const Bytes f = encode_raw(0x82, seq, {0});
    stream.insert(stream.end(), f.begin(), f.end());
  }
  dec.feed(stream.data(), stream.size(), [](const Frame&) {});
  EXPECT_EQ(dec.stats().frames_ok, 7u);
  EXPECT_EQ(dec.stats().sequence_gaps, 4u);  // 11->13, 14->20, 20->65535, 65535->1
  EXPECT_EQ(dec.stats().frames_missed, 1u + 5u + 65514u + 1u);  // 12; 15..19; 21..65534; 0
  dec.reset_sequence();
  const Bytes f = encode_raw(0x82, 500, {0});
  dec.feed(f.data(), f.size(), [](const Frame&) {});
  EXPECT_EQ(dec.stats().sequence_gaps, 4u);
  // Numbering restarted at 0 (a DeviceInfo after a reboot): frames 1 and 2 lost before 3 count.
  dec.restart_sequence(0);
  const Bytes g = encode_raw(0x82, 3, {0});
  dec.feed(g.data(), g.size(), [](const Frame&) {});
  EXPECT_EQ(dec.stats().sequence_gaps, 5u);
  EXPECT_EQ(dec.stats().frames_missed, 1u + 5u + 65514u + 1u + 2u);
}

// Found in review (2026-11-26): a frame repeated by the link (its number again) counted 65535
// missed frames, one delivered late 65533 and the next frame 2 more. Both are out of order,
// flagged on the frame, and the newest number stays the reference: no gap.
TEST(FrameDecoder, ARepeatedOrLateFrameIsNoGap) {
  FrameDecoder dec;
  Bytes stream;
  for (uint16_t seq : {23, 24, 25, 25, 23, 26, 27}) {
    const Bytes f = encode_raw(0x82, seq, {0});
    stream.insert(stream.end(), f.begin(), f.end());
  }
  std::vector<bool> flags;
  dec.feed(stream.data(), stream.size(),
           [&](const Frame&) { flags.push_back(dec.out_of_order()); });
  EXPECT_EQ(flags, (std::vector<bool>{false, false, false, true, true, false, false}));
  EXPECT_EQ(dec.stats().frames_ok, 7u);
  EXPECT_EQ(dec.stats().frames_out_of_order, 2u);
  EXPECT_EQ(dec.stats().sequence_gaps, 0u);
  EXPECT_EQ(dec.stats().frames_missed, 0u);
}

// ---- corruption -------------------------------------------------------------------------------

// Feeds `wire` (a corrupted frame, delimiter included, or any bytes) followed by a valid
// sentinel frame, and checks what comes out:
//  - no frame but the sentinel and the original (uncorrupted) frame may be accepted; accepting
//    the original is right when the corruption left the frame itself intact (e.g. a 0x00 inserted
//    just before its delimiter only adds an idle delimiter);
//  - the sentinel must come out whenever `wire` ends in a delimiter (resync within one frame);
//  - every byte that was not part of an accepted frame is counted as discarded, and discarding
//    anything counts at least one rejected (or empty) frame.
struct Corruption {
  FrameDecoder decoder;
  Bytes sentinel = encode_raw(0x05, 0x7777, {9, 8, 7, 6, 5, 4, 3, 2});
  uint64_t trials = 0;
  uint64_t false_accepts = 0;
  uint64_t intact = 0;
  uint64_t missed_sentinels = 0;
  uint64_t accounting_errors = 0;

  void run(const Bytes& wire, const OwnedFrame& original) {
    ++trials;
    decoder.reset_sequence();
    bool saw_sentinel = false;
    auto on_frame = [&](const Frame& f) {
      const OwnedFrame got{f.type, f.sequence, Bytes(f.payload, f.payload + f.payload_size)};
      if (f.type == 0x05 && f.sequence == 0x7777 && f.payload_size == 8) {
        saw_sentinel = true;
      } else if (got == original) {
        ++intact;
      } else {
        ++false_accepts;
      }
    };
    const DecoderStats before = decoder.stats();
    decoder.feed(wire.data(), wire.size(), on_frame);
    decoder.feed(sentinel.data(), sentinel.size(), on_frame);
    const DecoderStats& after = decoder.stats();
    if (!wire.empty() && wire.back() == 0 && !saw_sentinel) ++missed_sentinels;
    const uint64_t accepted = after.bytes_accepted - before.bytes_accepted;
    const uint64_t discarded = after.bytes_discarded - before.bytes_discarded;
    if (accepted + discarded != wire.size() + sentinel.size() || decoder.pending() != 0) {
      ++accounting_errors;
    }
    const uint64_t rejects = after.frames_rejected() + after.empty_frames -
                             before.frames_rejected() - before.empty_frames;
    if (discarded > 0 && rejects == 0) ++accounting_errors;
  }
};

// Every error of 1, 2 or 3 bits in a frame body (COBS applied after the corruption, as a channel
// that flips bits of the stuffed bytes cannot always do) lies within CRC-32C's guaranteed
// Hamming distance of 6 and must be rejected: exhaustively, for three frames.
TEST(FrameCorruption, RejectsEveryOneTwoAndThreeBitBodyError) {
  const Bytes bodies[] = {
      body_of(0x05, 4, {0xef, 0xcd, 0xab, 0x89, 0x67, 0x45, 0x23, 0x01}),  // ping, 16 bytes
      body_of(0x85, 3, {0x02, 0x01, 0x00}),                                // ack, 11 bytes
      body_of(0x02, 1, {0x40, 0x42, 0x0f, 0x00, 0x0b, 0x01, 0x00, 0x00, 0x00, 0x08}),  // 18 bytes
  };
  Corruption c;
  uint64_t patterns = 0;
  const OwnedFrame none{};  // nothing but the sentinel may come out
  for (const Bytes& body : bodies) {
    const size_t bits = body.size() * 8;
    auto flip = [](Bytes& b, size_t bit) { b[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8)); };
    for (size_t i = 0; i < bits; ++i) {
      Bytes b1 = body;
      flip(b1, i);
      c.run(cobs_frame(b1), none);
      ++patterns;
      for (size_t j = i + 1; j < bits; ++j) {
        Bytes b2 = b1;
        flip(b2, j);
        c.run(cobs_frame(b2), none);
        ++patterns;
        for (size_t k = j + 1; k < bits; ++k) {
          Bytes b3 = b2;
          flip(b3, k);
          c.run(cobs_frame(b3), none);
          ++patterns;
        }
      }
    }
  }
  // C(128,1..3) + C(88,1..3) + C(144,1..3) patterns.
  EXPECT_EQ(patterns,
            (128u + 8128u + 341376u) + (88u + 3828u + 109736u) + (144u + 10296u + 487344u));
  EXPECT_EQ(c.false_accepts, 0u);
  EXPECT_EQ(c.missed_sentinels, 0u);
  EXPECT_EQ(c.accounting_errors, 0u);
  EXPECT_EQ(c.decoder.stats().crc_errors, patterns);  // a body error can only fail the CRC
}

// The same exhaustively on the wire: 1, 2 and 3 flipped bits anywhere in the stuffed bytes and
// the delimiter. A flipped COBS code byte moves zeros around, so these are not all within the
// CRC's guarantee; each is then caught by COBS or by the CRC with probability 1 - 2^-32 (the
// chance that any of the ~5e5 patterns slips through is about 1e-4).
TEST(FrameCorruption, RejectsEveryOneTwoAndThreeBitWireError) {
  const Bytes wire = encode_raw(0x05, 4, {0xef, 0xcd, 0xab, 0x89, 0x67, 0x45, 0x23, 0x01});
  ASSERT_EQ(wire.size(), 18u);
  Corruption c;
  const OwnedFrame none{};
  const size_t bits = wire.size() * 8;
  auto flip = [](Bytes& b, size_t bit) { b[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8)); };
  for (size_t i = 0; i < bits; ++i) {
    Bytes w1 = wire;
    flip(w1, i);
    c.run(w1, none);
    for (size_t j = i + 1; j < bits; ++j) {
      Bytes w2 = w1;
      flip(w2, j);
      c.run(w2, none);
      for (size_t k = j + 1; k < bits; ++k) {
        Bytes w3 = w2;
        flip(w3, k);
        c.run(w3, none);
      }
    }
  }
  EXPECT_EQ(c.trials, 144u + 10296u + 487344u);
  EXPECT_EQ(c.false_accepts, 0u);
  EXPECT_EQ(c.missed_sentinels, 0u);
  EXPECT_EQ(c.accounting_errors, 0u);
}

// Random 4- and 5-bit body errors at the largest body size (inside HD = 6 as well).
TEST(FrameCorruption, RejectsFourAndFiveBitBodyErrorsInTheLargestFrame) {
  TestRng rng(23);
  const Bytes body = body_of(0x82, 77, random_payload(rng, kMaxPayloadSize));
  ASSERT_EQ(body.size(), kMaxBodySize);
  Corruption c;
  const OwnedFrame none{};
  for (int trial = 0; trial < 20000; ++trial) {
    Bytes b = body;
    const size_t weight = 4 + trial % 2;
    size_t chosen[5];
    for (size_t k = 0; k < weight; ++k) {
      bool fresh;
      do {
        chosen[k] = rng.below(body.size() * 8);
        fresh = std::find(chosen, chosen + k, chosen[k]) == chosen + k;
      } while (!fresh);
      b[chosen[k] / 8] ^= static_cast<uint8_t>(1u << (chosen[k] % 8));
    }
    c.run(cobs_frame(b), none);
  }
  EXPECT_EQ(c.false_accepts, 0u);
  EXPECT_EQ(c.missed_sentinels, 0u);
  EXPECT_EQ(c.accounting_errors, 0u);
  EXPECT_EQ(c.decoder.stats().crc_errors, 20000u);
}

// One million random corruptions of random frames: bit flips (1..16 bits, anywhere, delimiter
// included), dropped bytes, inserted bytes, bursts of random bytes, truncation (with and
// without the delimiter), a zero written into the frame. Beyond the CRC's guarantee each
// corrupted frame passes the CRC with probability about 2^-32 = 2.3e-10, so the chance of any
// false accept in 1e6 trials is about 1e6 * 2.3e-10 = 2.3e-4 (and the seed is fixed, so the
// outcome is deterministic). Checked for each trial as Corruption::run describes.
TEST(FrameCorruption, RejectsAMillionRandomCorruptions) {
  TestRng rng(24);
  Corruption c;
  uint64_t by_kind[7] = {};
  while (c.trials < 1000000) {
    const size_t n = rng.below(8) == 0 ? rng.below(kMaxPayloadSize + 1) : rng.below(40);
    const OwnedFrame original{rng.byte(), static_cast<uint16_t>(rng.bits()),
                              random_payload(rng, n)};
    const Bytes wire = encode_raw(original.type, original.sequence, original.payload);
    Bytes w = wire;
    const int kind = static_cast<int>(rng.below(7));
    switch (kind) {
      case 0: {  // flip 1..16 distinct bits
        const size_t k = 1 + rng.below(16);
        std::vector<size_t> bits;
        while (bits.size() < k) {
          const size_t b = rng.below(w.size() * 8);
          if (std::find(bits.begin(), bits.end(), b) == bits.end()) bits.push_back(b);
        }
        for (size_t b : bits) w[b / 8] ^= static_cast<uint8_t>(1u << (b % 8));
        break;
      }
      case 1: {  // drop 1..3 bytes (the delimiter too)
        const size_t k = 1 + rng.below(3);
        for (size_t i = 0; i < k && w.size() > 1; ++i) w.erase(w.begin() + rng.below(w.size()));
        break;
      }
      case 2: {  // insert 1..3 random bytes before the delimiter
        const size_t k = 1 + rng.below(3);
        for (size_t i = 0; i < k; ++i) w.insert(w.begin() + rng.below(w.size()), rng.byte());
        break;
      }
      case 3: {  // burst: 2..12 consecutive random bytes
        const size_t len = std::min<size_t>(2 + rng.below(11), w.size());
        const size_t at = rng.below(w.size() - len + 1);
        for (size_t i = 0; i < len; ++i) w[at + i] = rng.byte();
        break;
      }
      case 4:  // truncated: the sender stopped mid-frame (no delimiter)
        w.resize(rng.below(w.size()));
        break;
      case 5:  // truncated, then a delimiter (the sender restarted its frame)
        w.resize(rng.below(w.size() - 1));
        w.push_back(0);
        break;
      case 6:  // a zero written inside the frame (splits it)
        w[rng.below(w.size() - 1)] = 0;
        break;
    }
    // A burst can rewrite the same bytes: not a corruption. An empty remainder sends nothing.
    if (w == wire || w.empty()) continue;
    ++by_kind[kind];
    c.run(w, original);
  }
  for (uint64_t k : by_kind) EXPECT_GT(k, 100000u);
  EXPECT_EQ(c.trials, 1000000u);
  // Inserting a 0x00 right before the delimiter or a byte before the frame leaves it intact; a
  // handful of the ~143000 insertions do that.
  EXPECT_LT(c.intact, 1000u);
  EXPECT_EQ(c.false_accepts, 0u);
  EXPECT_EQ(c.missed_sentinels, 0u);
  EXPECT_EQ(c.accounting_errors, 0u);
  expect_accounting(c.decoder);
}

TEST(FrameCorruption, ResyncsWithinOneFrameInAContinuousStream) {
  // A stream of frames with one damaged frame in the middle: only it (and, if its delimiter was
  // hit, its successor) is lost; the sequence numbers account for exactly the lost frames.
  TestRng rng(25);
  for (int trial = 0; trial < 2000; ++trial) {
    Bytes stream;
    std::vector<size_t> starts;
    for (uint16_t i = 0; i < 10; ++i) {
      starts.push_back(stream.size());
      const Bytes f = encode_raw(0x82, i, random_payload(rng, rng.below(100)));
      stream.insert(stream.end(), f.begin(), f.end());
    }
    starts.push_back(stream.size());
    const size_t victim = 2 + rng.below(5);
    const size_t at = starts[victim] + rng.below(starts[victim + 1] - starts[victim]);
    stream[at] ^= static_cast<uint8_t>(1u << rng.below(8));
    const bool hit_delimiter = at == starts[victim + 1] - 1;
    FrameDecoder dec;
    const auto frames = feed_chunked(dec, stream, rng, 50);
    const size_t lost = hit_delimiter ? 2 : 1;
    ASSERT_EQ(frames.size(), 10 - lost) << trial;
    for (const auto& f : frames) {
      EXPECT_TRUE(f.sequence < victim || f.sequence >= victim + lost) << trial;
    }
    EXPECT_EQ(dec.stats().frames_missed, lost);
    EXPECT_EQ(dec.stats().sequence_gaps, 1u);
    EXPECT_EQ(dec.stats().bytes_discarded, starts[victim + lost] - starts[victim]) << trial;
    expect_accounting(dec);
  }
}

}  // namespace
}  // namespace imukit::proto
