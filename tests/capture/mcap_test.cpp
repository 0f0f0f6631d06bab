#include "capture/mcap.hpp"

#include <gtest/gtest.h>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/rng.hpp"
#include "tests/support/test_data.hpp"

namespace imukit::capture {
namespace {

struct Msg {
  uint16_t channel;
  uint32_t sequence;
  uint64_t log_time;
  uint64_t publish_time;
  std::vector<uint8_t> data;
  bool operator==(const Msg&) const = default;
};

std::vector<uint8_t> slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
}

void spit(const std::string& path, std::span<const uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

std::vector<Msg> read_all(const std::string& path, McapReadSummary* summary = nullptr,
                          McapReadOptions options = {}) {
  std::vector<Msg> out;
  auto s = read_mcap(
      path,
      [&](const McapMessageView& m) {
        out.push_back({m.channel_id, m.sequence, m.log_time, m.publish_time,
                       std::vector<uint8_t>(m.data.begin(), m.data.end())});
      },
      options);
  if (summary) *summary = s;
  return out;
}

// Writes `count` messages at `rate_hz` on two channels; returns what was written.
std::vector<Msg> write_file(const std::string& path, int count, double rate_hz,
                            McapCompression compression = McapCompression::zstd,
                            uint64_t payload_spread = 40) {
  McapWriterOptions options;
  options.compression = compression;
  McapWriter w(path, options);
  const uint16_t schema = w.add_schema("test/msg/Blob", "ros2msg", "uint8[] data\n");
  const uint16_t a = w.add_channel(schema, "/imu/a", "cdr", {{"device", "mock a"}});
  const uint16_t b = w.add_channel(schema, "/imu/a/raw", "cdr");
  w.write_metadata("device", {{"vendor", "imukit"}, {"model", "mock"}});
  Rng rng(11);
  std::vector<Msg> written;
  for (int i = 0; i < count; ++i) {
    const uint64_t t = 1'700'000'000'000'000'000ull + static_cast<uint64_t>(i * 1e9 / rate_hz);
    for (uint16_t ch : {a, b}) {
      std::vector<uint8_t> data(4 + rng.uniform_index(payload_spread));
      for (auto& byte : data) byte = static_cast<uint8_t>(rng.next_u64());
      const uint32_t seq = static_cast<uint32_t>(i);
      w.write_message(ch, t, t + 2'000'000, data);
      written.push_back({ch, seq, t, t + 2'000'000, data});
    }
  }
  w.close();
  return written;
}

TEST(Mcap, RoundTripKeepsEveryMessageSchemaChannelAndMetadata) {
  testing::TempDir dir;
  const std::string path = (dir / "a.mcap").string();
  const auto written = write_file(path, 2000, 1000.0);
  McapReadSummary s;
  const auto read = read_all(path, &s);
  EXPECT_TRUE(s.complete) << s.truncation_note;
  EXPECT_EQ(s.profile, "ros2");
  EXPECT_EQ(read, written);
  ASSERT_EQ(s.schemas.size(), 1u);
  EXPECT_EQ(s.schemas[0].name, "test/msg/Blob");
  ASSERT_EQ(s.channels.size(), 2u);
  EXPECT_EQ(s.channels[0].topic, "/imu/a");
  EXPECT_EQ(s.channels[0].metadata.at("device"), "mock a");
  ASSERT_EQ(s.metadata.size(), 1u);
  EXPECT_EQ(s.metadata[0].entries.at("model"), "mock");
  // 2 s of data at one chunk per 250 ms of log time.
  EXPECT_EQ(s.chunks, 8u);
}

TEST(Mcap, UncompressedChunksRoundTripToo) {
  testing::TempDir dir;
  const std::string path = (dir / "u.mcap").string();
  const auto written = write_file(path, 300, 100.0, McapCompression::none);
  EXPECT_EQ(read_all(path), written);
}

// Power loss or kill -9 at any moment: every prefix of a file reads without an error and keeps
// exactly the messages of the chunks that were complete.
TEST(Mcap, EveryTruncationReadsBackToTheLastCompleteChunk) {
  testing::TempDir dir;
  const std::string path = (dir / "small.mcap").string();
  // 2 s at 100 Hz: 8 chunks, about 16 KB.
  const auto written = write_file(path, 200, 100.0, McapCompression::zstd, 12);
  const std::vector<uint8_t> bytes = slurp(path);
  ASSERT_GT(bytes.size(), 12000u);
  ASSERT_LT(bytes.size(), 20000u);
  // Where each chunk (with its message indexes) ends, and how many messages precede that.
  std::vector<std::pair<std::size_t, std::size_t>> chunk_ends;
  {
    std::size_t pos = 8;
    std::size_t messages = 0;
    while (pos + 9 <= bytes.size()) {
      uint64_t len = 0;
      std::memcpy(&len, &bytes[pos + 1], 8);
      const uint8_t op = bytes[pos];
      if (op == 0x06) {
        McapReadSummary one;
        spit((dir / "one.mcap").string(), std::span(bytes).first(pos + 9 + len));
        messages = read_all((dir / "one.mcap").string(), &one).size();
        chunk_ends.emplace_back(pos + 9 + len, messages);
      }
      if (op == 0x0F) break;
      pos += 9 + len;
    }
  }
  ASSERT_EQ(chunk_ends.size(), 8u);
  const std::string cut = (dir / "cut.mcap").string();
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    McapReadSummary s;
    std::vector<Msg> got;
    const auto collect = [&](const McapMessageView& m) {
      got.push_back({m.channel_id, m.sequence, m.log_time, m.publish_time,
                     std::vector<uint8_t>(m.data.begin(), m.data.end())});
    };
    ASSERT_NO_THROW(s = read_mcap(std::span(bytes).first(k), cut, collect)) << "cut at " << k;
    std::size_t expected = 0;
    for (const auto& [end, count] : chunk_ends) {
      if (end <= k) expected = count;
    }
    ASSERT_EQ(got.size(), expected) << "cut at " << k;
    ASSERT_TRUE(std::equal(got.begin(), got.end(), written.begin())) << "cut at " << k;
    ASSERT_FALSE(s.complete) << "cut at " << k;
    ASSERT_NE(s.truncation_note.find("the file ends at byte " + std::to_string(k)),
              std::string::npos)
        << s.truncation_note;
    if (k % 997 == 0) {  // the file path gives the same answer as memory
      spit(cut, std::span(bytes).first(k));
      ASSERT_EQ(read_all(cut).size(), got.size());
    }
  }
}

TEST(Mcap, RecoverRewritesACutFileAsAValidOne) {
  testing::TempDir dir;
  const std::string path = (dir / "big.mcap").string();
  const auto written = write_file(path, 20000, 1000.0);  // 20 s, 80 chunks
  const std::vector<uint8_t> bytes = slurp(path);
  Rng rng(5);
  const std::string cut = (dir / "cut.mcap").string();
  const std::string fixed = (dir / "fixed.mcap").string();
  std::size_t previous = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t k = rng.uniform_index(bytes.size());
    spit(cut, std::span(bytes).first(k));
    McapReadSummary s;
    const auto got = read_all(cut, &s);
    ASSERT_FALSE(s.complete);
    ASSERT_TRUE(std::equal(got.begin(), got.end(), written.begin()));
    if (trial % 30 == 0) {
      recover_mcap(cut, fixed);
      McapReadSummary r;
      EXPECT_EQ(read_all(fixed, &r), got);
      EXPECT_TRUE(r.complete);
    }
    previous = got.size();
  }
  EXPECT_GT(previous, 0u);
}

TEST(Mcap, CorruptChunkIsAnErrorNamingItsOffsetAndRecoverySkipsIt) {
  testing::TempDir dir;
  const std::string path = (dir / "c.mcap").string();
  const auto written = write_file(path, 400, 200.0);
  std::vector<uint8_t> bytes = slurp(path);
  // Find the third chunk and flip a bit in its compressed records.
  std::size_t pos = 8;
  int chunk = 0;
  std::size_t third = 0;
  while (pos < bytes.size()) {
    uint64_t len = 0;
    std::memcpy(&len, &bytes[pos + 1], 8);
    if (bytes[pos] == 0x06 && ++chunk == 3) {
      third = pos;
      break;
    }
    pos += 9 + len;
  }
  ASSERT_GT(third, 0u);
  uint64_t records_len = 0;  // the compressed records start 44 bytes into the chunk body
  std::memcpy(&records_len, &bytes[third + 9 + 36], 8);
  bytes[third + 9 + 44 + records_len / 2] ^= 0x10;
  spit(path, bytes);
  try {
    read_all(path);
    FAIL() << "corruption not detected";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(third)), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("corrupt chunk"), std::string::npos) << e.what();
  }
  const std::string fixed = (dir / "fixed.mcap").string();
  const McapReadSummary s = recover_mcap(path, fixed);
  EXPECT_EQ(s.corrupt_chunks, 1u);
  const auto got = read_all(fixed);
  EXPECT_EQ(got.size(), written.size() - 2 * 50);  // one chunk of 50 time steps x 2 channels
}

// Found by the fuzzer: a chunk header claiming 1.7 GB of uncompressed records made the reader
// allocate them. A claimed size must agree with the zstd frame's own before any allocation.
TEST(Mcap, ChunkSizeFieldsCannotForceHugeAllocations) {
  testing::TempDir dir;
  const std::string path = (dir / "s.mcap").string();
  write_file(path, 100, 100.0);
  const std::vector<uint8_t> good = slurp(path);
  std::size_t chunk = 8;
  while (good[chunk] != 0x06) {
    uint64_t len = 0;
    std::memcpy(&len, &good[chunk + 1], 8);
    chunk += 9 + len;
  }
  const std::pair<uint64_t, const char*> cases[] = {
      {1'700'000'000, "more than"},                    // above any chunk imukit accepts
      {200'000'000, "does not match its zstd frame"},  // plausible, but not what the frame says
      {12345, "does not match its zstd frame"}};
  for (const auto& [claimed, why] : cases) {
    std::vector<uint8_t> bad = good;
    std::memcpy(&bad[chunk + 9 + 16], &claimed, 8);  // uncompressed_size
    try {
      read_mcap(std::span<const uint8_t>(bad), "bad.mcap", nullptr);
      ADD_FAILURE() << "accepted a chunk claiming " << claimed << " bytes";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("corrupt chunk"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(chunk)), std::string::npos)
          << e.what();
    }
  }
}

TEST(Mcap, NotAnMcapFileIsRejectedAtByteZero) {
  testing::TempDir dir;
  const std::string path = (dir / "x.mcap").string();
  const std::string text = "#timestamp [ns],w_RS_S_x\n";
  spit(path, std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
  try {
    read_all(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": byte 0: not an MCAP file"), std::string::npos)
        << e.what();
  }
}

TEST(Mcap, DiskFullIsAClearErrorAndEarlierChunksStayReadable) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "/dev/full is not available";
  try {
    McapWriter w("/dev/full");
    const uint16_t s = w.add_schema("s", "ros2msg", "uint8 x\n");
    const uint16_t c = w.add_channel(s, "/t", "cdr");
    const std::vector<uint8_t> data(100, 7);
    for (int i = 0; i < 100000; ++i)
      w.write_message(c, static_cast<uint64_t>(i) * 1'000'000, 0, data);
    w.close();
    FAIL() << "writing to /dev/full succeeded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

TEST(Mcap, Crc32MatchesTheStandardCheckValue) {
  const std::string check = "123456789";
  EXPECT_EQ(mcap_crc32(std::span(reinterpret_cast<const uint8_t*>(check.data()), check.size())),
            0xCBF43926u);
}

}  // namespace
}  // namespace imukit::capture
