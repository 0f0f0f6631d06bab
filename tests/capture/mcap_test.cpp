#include "imukit/capture/mcap.hpp"

#include <gtest/gtest.h>
#include <zstd.h>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/core.h>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "support/test_data.hpp"

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

// A rewrite that fails half way (here the edit throws, as a full disk would) leaves the file
// that was at the output before, byte for byte, and no temporary beside it.
TEST(Mcap, AFailedRewriteLeavesTheEarlierFileAndNoTemporary) {
  testing::TempDir dir;
  const std::string in = (dir / "in.mcap").string();
  const std::string out = (dir / "out.mcap").string();
  write_file(in, 2000, 1000.0);  // 4000 messages, 8 chunks
  write_file(out, 10, 1000.0);
  const std::vector<uint8_t> earlier = slurp(out);
  int seen = 0;
  const McapMessageEdit fail_late = [&](const McapChannel&, McapMessageView&) {
    if (++seen == 3000) throw IoError("out.mcap: write failed: No space left on device");
    return true;
  };
  EXPECT_THROW(rewrite_mcap(in, out, fail_late), IoError);
  EXPECT_EQ(seen, 3000);
  EXPECT_EQ(slurp(out), earlier);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 2);
  // The same rewrite without the failure replaces it.
  rewrite_mcap(in, out, nullptr);
  McapReadSummary s;
  EXPECT_EQ(read_all(out, &s).size(), 4000u);
  EXPECT_TRUE(s.complete);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 2);
}

// A disk that holds `capacity` bytes: a FILE* whose writes go to `path` until it is full, then
// fail as write(2) does on a full disk (what fits, then ENOSPC). A test of the writer's handling
// of a full disk that touches no device (it wrote to /dev/full before, 2026-11-26 review).
class SmallDisk {
 public:
  SmallDisk(const std::string& path, std::size_t capacity)
      : out_(path, std::ios::binary | std::ios::trunc), capacity_(capacity) {
    file_ = fopencookie(this, "wb",
                        cookie_io_functions_t{nullptr, &SmallDisk::write, nullptr, nullptr});
    // Unbuffered: every fwrite reaches write() at once, as the writer's flushes would.
    if (file_) std::setvbuf(file_, nullptr, _IONBF, 0);
  }
  ~SmallDisk() {
    if (file_) std::fclose(file_);
  }
  SmallDisk(const SmallDisk&) = delete;
  SmallDisk& operator=(const SmallDisk&) = delete;
  std::FILE* file() const { return file_; }

 private:
  static ssize_t write(void* cookie, const char* data, std::size_t n) {
    auto& disk = *static_cast<SmallDisk*>(cookie);
    const std::size_t fits = std::min(n, disk.capacity_ - disk.used_);
    disk.out_.write(data, static_cast<std::streamsize>(fits));
    disk.out_.flush();
    disk.used_ += fits;
    if (fits < n) errno = ENOSPC;  // stdio writes again for the rest, and would get this
    return static_cast<ssize_t>(fits);
  }
  std::ofstream out_;
  std::size_t capacity_, used_ = 0;
  std::FILE* file_ = nullptr;
};

TEST(Mcap, DiskFullIsAClearErrorAndEarlierChunksStayReadable) {
  testing::TempDir dir;
  const std::string path = (dir / "full.mcap").string();
  SmallDisk disk(path, 50'000);
  ASSERT_NE(disk.file(), nullptr);
  McapWriterOptions options;
  options.compression = McapCompression::none;
  options.chunk_bytes = 4096;  // a dozen chunks fit on the disk
  uint64_t written = 0;
  try {
    McapWriter w(disk.file(), path, options);
    const uint16_t s = w.add_schema("s", "ros2msg", "uint8 x\n");
    const uint16_t c = w.add_channel(s, "/t", "cdr");
    std::vector<uint8_t> data(100);
    for (; written < 100'000; ++written) {
      std::fill(data.begin(), data.end(), static_cast<uint8_t>(written));
      w.write_message(c, written * 1'000'000, 0, data);
    }
    w.close();
    FAIL() << "writing 10 MB to a disk of 50 kB succeeded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("write failed: No space left on device"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(std::filesystem::file_size(path), 50'000u);
  // What reached the disk reads back up to its last complete chunk, every message intact.
  McapReadSummary summary;
  const std::vector<Msg> kept = read_all(path, &summary);
  // 32 messages close a chunk of 4096 bytes; the 11th chunk (messages 320..351, the write of the
  // 352nd closing it) did not fit.
  EXPECT_FALSE(summary.complete);
  EXPECT_EQ(summary.chunks, 10u);
  EXPECT_EQ(written, 351u);
  ASSERT_EQ(kept.size(), 320u);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    ASSERT_EQ(kept[i].log_time, i * 1'000'000) << i;
    ASSERT_EQ(kept[i].data, std::vector<uint8_t>(100, static_cast<uint8_t>(i))) << i;
  }
}

// The top-level records of a file: opcode, where the record starts, its whole length (opcode and
// length field included), and for chunks their time span.
struct Record {
  uint8_t op;
  std::size_t offset;
  std::size_t length;
  uint64_t start_time = 0, end_time = 0;
};

std::vector<Record> records_of(const std::vector<uint8_t>& bytes) {
  std::vector<Record> out;
  std::size_t pos = 8;
  while (pos + 9 <= bytes.size()) {
    uint64_t len = 0;
    std::memcpy(&len, &bytes[pos + 1], 8);
    Record r{bytes[pos], pos, static_cast<std::size_t>(9 + len)};
    if (r.op == 0x06) {
      std::memcpy(&r.start_time, &bytes[pos + 9], 8);
      std::memcpy(&r.end_time, &bytes[pos + 17], 8);
    }
    out.push_back(r);
    pos += r.length;
    if (r.op == 0x02) break;  // the footer; the closing magic follows
  }
  return out;
}

// The messages of `written` that were not in a lost chunk (chunks hold disjoint time spans).
std::vector<Msg> without_chunks(const std::vector<Msg>& written,
                                const std::vector<const Record*>& lost) {
  std::vector<Msg> kept;
  for (const Msg& m : written) {
    const bool in_lost = std::any_of(lost.begin(), lost.end(), [&](const Record* c) {
      return m.log_time >= c->start_time && m.log_time <= c->end_time;
    });
    if (!in_lost) kept.push_back(m);
  }
  return kept;
}

// The chunks a damaged byte range costs: every chunk it touches, except where it touches only
// the chunk's start and end times (bytes 9-24 of the record, which no CRC covers and nothing
// reads).
std::vector<const Record*> chunks_hit(const std::vector<Record>& records, std::size_t begin,
                                      std::size_t end) {
  std::vector<const Record*> hit;
  for (const Record& r : records) {
    if (r.op != 0x06) continue;
    for (std::size_t b = std::max(begin, r.offset); b < std::min(end, r.offset + r.length); ++b) {
      const std::size_t rel = b - r.offset;
      if (rel < 9 || rel >= 25) {
        hit.push_back(&r);
        break;
      }
    }
  }
  return hit;
}

std::string notes(const McapReadSummary& s) {
  std::string all;
  for (const std::string& d : s.damage) all += "\n  damage: " + d;
  return all + (s.truncation_note.empty() ? "" : "\n  note: " + s.truncation_note);
}

std::vector<Msg> recover_in_memory(const std::vector<uint8_t>& bytes, McapReadSummary* s) {
  std::vector<Msg> got;
  McapReadOptions options;
  options.recover = true;
  *s = read_mcap(std::span<const uint8_t>(bytes), "damaged.mcap",
                 McapHandlers{nullptr, nullptr,
                              [&](const McapMessageView& m) {
                                got.push_back({m.channel_id, m.sequence, m.log_time, m.publish_time,
                                               std::vector<uint8_t>(m.data.begin(), m.data.end())});
                              }},
                 options);
  return got;
}

// Issue 16, item 10: recovery skips whatever record is damaged and keeps every intact chunk. A
// closed 8-chunk file is damaged one byte at a time at the opcode, the length (its top byte, so
// the length no longer fits; one more; one less), the first, middle and last byte of the body
// of every record (header, schemas, channels, metadata, chunks, message indexes, Data End, each
// summary record, footer), at every 7th byte of the file, in both magics, and by zeroing 4 KB
// spans; each time exactly the messages of the chunks the damage touched are lost, and the
// recovered file reads as complete.
TEST(Mcap, RecoveryKeepsEveryIntactChunkWhateverRecordIsDamaged) {
  testing::TempDir dir;
  const std::string path = (dir / "good.mcap").string();
  const auto written = write_file(path, 200, 100.0, McapCompression::zstd, 12);
  const std::vector<uint8_t> good = slurp(path);
  const std::vector<Record> records = records_of(good);
  std::map<uint8_t, int> kinds;
  for (const Record& r : records) ++kinds[r.op];
  // Header, schema, 2 channels, metadata, 8 chunks with 2 message indexes each, Data End; the
  // summary's schema, channels, statistics, chunk indexes, metadata index, summary offsets;
  // footer.
  ASSERT_EQ(kinds[0x01], 1);
  ASSERT_EQ(kinds[0x03], 2);
  ASSERT_EQ(kinds[0x04], 4);
  ASSERT_EQ(kinds[0x0C], 1);
  ASSERT_EQ(kinds[0x06], 8);
  ASSERT_EQ(kinds[0x07], 16);
  ASSERT_EQ(kinds[0x0F], 1);
  ASSERT_EQ(kinds[0x0B], 1);
  ASSERT_EQ(kinds[0x08], 8);
  ASSERT_EQ(kinds[0x0D], 1);
  ASSERT_GE(kinds[0x0E], 5);
  ASSERT_EQ(kinds[0x02], 1);

  struct Case {
    std::string what;
    std::vector<uint8_t> bytes;
    std::vector<Msg> expected;
  };
  std::vector<Case> cases;
  const auto flip = [&](std::size_t at, const std::string& what) {
    Case c{what + " (byte " + std::to_string(at) + ")", good, {}};
    c.bytes[at] ^= 0xFF;
    c.expected = without_chunks(written, chunks_hit(records, at, at + 1));
    cases.push_back(std::move(c));
  };
  for (const Record& r : records) {
    const std::string name = fmt::format("record 0x{:02x} at byte {}", r.op, r.offset);
    flip(r.offset, name + ": opcode");
    flip(r.offset + 8, name + ": top byte of the length");
    const std::size_t body = r.length - 9;
    if (body > 0) {
      flip(r.offset + 9, name + ": first body byte");
      flip(r.offset + 9 + body / 2, name + ": middle body byte");
      flip(r.offset + r.length - 1, name + ": last body byte");
    }
    // A length one more or one less than the record's: a chunk one byte longer still parses
    // (its fields and CRC are intact) and is kept; one byte shorter cannot hold its records.
    for (const int64_t delta : {int64_t{1}, int64_t{-1}}) {
      if (body == 0 && delta < 0) continue;
      Case c{name + ": length " + (delta > 0 ? "+1" : "-1"), good, {}};
      uint64_t len = 0;
      std::memcpy(&len, &c.bytes[r.offset + 1], 8);
      len = static_cast<uint64_t>(static_cast<int64_t>(len) + delta);
      std::memcpy(&c.bytes[r.offset + 1], &len, 8);
      std::vector<const Record*> lost;
      if (r.op == 0x06 && delta < 0) lost.push_back(&r);
      c.expected = without_chunks(written, lost);
      cases.push_back(std::move(c));
    }
  }
  // And every 7th byte of the file that is not a length field (whose damage the cases above
  // cover: a longer chunk is kept).
  for (std::size_t at = 1; at < good.size(); at += 7) {
    const bool in_length = std::any_of(records.begin(), records.end(), [&](const Record& r) {
      return at > r.offset && at <= r.offset + 8;
    });
    if (!in_length) flip(at, "sweep");
  }
  for (const std::size_t at : {std::size_t{0}, std::size_t{4}, std::size_t{7}})
    flip(at, "leading magic");
  for (const std::size_t at : {good.size() - 8, good.size() - 1}) flip(at, "closing magic");
  for (const std::size_t start : {std::size_t{1000}, good.size() / 2, good.size() - 5000}) {
    Case c{"4 KB zeroed from byte " + std::to_string(start), good, {}};
    std::fill(c.bytes.begin() + static_cast<std::ptrdiff_t>(start),
              c.bytes.begin() + static_cast<std::ptrdiff_t>(start + 4096), uint8_t{0});
    c.expected = without_chunks(written, chunks_hit(records, start, start + 4096));
    cases.push_back(std::move(c));
  }
  ASSERT_GT(cases.size(), 2500u);

  const std::string damaged = (dir / "damaged.mcap").string();
  const std::string fixed = (dir / "fixed.mcap").string();
  std::size_t lossless = 0;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    McapReadSummary s;
    std::vector<Msg> got;
    ASSERT_NO_THROW(got = recover_in_memory(c.bytes, &s)) << c.what;
    ASSERT_EQ(got.size(), c.expected.size()) << c.what << notes(s);
    ASSERT_EQ(got, c.expected) << c.what;
    ASSERT_EQ(s.schemas.size(), 1u) << c.what;
    ASSERT_EQ(s.channels.size(), 2u) << c.what;
    EXPECT_EQ(s.channels[0].topic, "/imu/a") << c.what;
    EXPECT_EQ(s.channels[1].topic, "/imu/a/raw") << c.what;
    if (c.expected.size() == written.size()) ++lossless;
    // Every record damage is reported; a lost chunk is one of them.
    if (c.expected.size() < written.size()) {
      EXPECT_GE(s.damaged_records, 1u) << c.what;
    }
    if (k % 25 == 0) {  // through files too: the recovered file is complete, with what was kept
      spit(damaged, c.bytes);
      recover_mcap(damaged, fixed);
      McapReadSummary r;
      ASSERT_EQ(read_all(fixed, &r), c.expected) << c.what;
      EXPECT_TRUE(r.complete) << c.what;
    }
  }
  // Most damage outside the chunks costs no message at all.
  EXPECT_GT(lossless, cases.size() / 2);
  std::printf("%zu damaged files, %zu of them recovered with every message\n", cases.size(),
              lossless);
}

// The two errors of issue 16 item 10: without recovery, a damaged message index fails the data
// section CRC and a damaged chunk header fails to parse; recovery keeps every other chunk.
TEST(Mcap, DamagedMessageIndexOrChunkHeaderFailsReadingButNotRecovery) {
  testing::TempDir dir;
  const std::string path = (dir / "good.mcap").string();
  const auto written = write_file(path, 200, 100.0, McapCompression::zstd, 12);
  const std::vector<uint8_t> good = slurp(path);
  const std::vector<Record> records = records_of(good);
  const Record* index = nullptr;
  const Record* third_chunk = nullptr;
  int chunks = 0;
  for (const Record& r : records) {
    if (r.op == 0x07 && !index) index = &r;
    if (r.op == 0x06 && ++chunks == 3) third_chunk = &r;
  }
  ASSERT_TRUE(index && third_chunk);
  std::vector<uint8_t> bad_index = good;
  bad_index[index->offset + 9 + 6 + 3] ^= 0x40;  // inside the first entry's time
  std::vector<uint8_t> bad_header = good;
  bad_header[third_chunk->offset + 9 + 28 + 2] = 0x01;  // compression string length: 65540 + 4
  const std::pair<const std::vector<uint8_t>*, const char*> cases[] = {
      {&bad_index, "data section CRC-32"}, {&bad_header, "chunk compression: needs 65540 bytes"}};
  for (const auto& [bytes, error] : cases) {
    try {
      read_mcap(std::span<const uint8_t>(*bytes), "damaged.mcap", nullptr);
      ADD_FAILURE() << "read without an error: " << error;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(error), std::string::npos) << e.what();
    }
    McapReadSummary s;
    const auto got = recover_in_memory(*bytes, &s);
    const std::vector<const Record*> lost = bytes == &bad_header
                                                ? std::vector<const Record*>{third_chunk}
                                                : std::vector<const Record*>{};
    EXPECT_EQ(got, without_chunks(written, lost)) << error;
    EXPECT_EQ(got.size(), bytes == &bad_header ? 400u - 50u : 400u) << error;
    ASSERT_EQ(s.damage.size(), 1u) << error << notes(s);
    EXPECT_NE(s.damage[0].find(bytes == &bad_header ? "Chunk record skipped" : "data section CRC"),
              std::string::npos)
        << s.damage[0];
  }
}

// A file the recorder never closed has no summary: a damaged Channel record there costs that
// channel's messages (counted, never mistaken for another channel's), and nothing else.
TEST(Mcap, WithoutASummaryADamagedChannelRecordCostsOnlyItsMessages) {
  testing::TempDir dir;
  const std::string path = (dir / "good.mcap").string();
  const auto written = write_file(path, 200, 100.0, McapCompression::zstd, 12);
  std::vector<uint8_t> bytes = slurp(path);
  const std::vector<Record> records = records_of(bytes);
  const auto data_end =
      std::find_if(records.begin(), records.end(), [](const Record& r) { return r.op == 0x0F; });
  ASSERT_NE(data_end, records.end());
  bytes.resize(data_end->offset);  // cut where Data End would start: every chunk complete
  std::vector<const Record*> channels;
  for (const Record& r : records) {
    if (r.op == 0x04 && r.offset < data_end->offset) channels.push_back(&r);
  }
  ASSERT_EQ(channels.size(), 2u);
  // The second Channel record (/imu/a/raw, id 1): its topic length no longer fits.
  const Record& second = *channels[1];
  bytes[second.offset + 9 + 4 + 3] = 0x7F;
  McapReadSummary s;
  const auto got = recover_in_memory(bytes, &s);
  std::vector<Msg> expected;
  for (const Msg& m : written) {
    if (m.channel == 0) expected.push_back(m);
  }
  EXPECT_EQ(got, expected);
  EXPECT_EQ(s.orphan_messages, 200u);
  EXPECT_EQ(s.chunks, 8u);
  EXPECT_FALSE(s.complete);
  ASSERT_EQ(s.channels.size(), 1u);
  EXPECT_EQ(s.channels[0].topic, "/imu/a");
}

// Recovery never reads what is not MCAP as MCAP.
TEST(Mcap, RecoveryStillRejectsAFileThatIsNotMcap) {
  const std::string text = "#timestamp [ns],w_RS_S_x\n1,2\n3,4\n5,6\n7,8\n9,10\n11,12\n";
  McapReadSummary s;
  try {
    recover_in_memory(std::vector<uint8_t>(text.begin(), text.end()), &s);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("damaged.mcap: byte 0: not an MCAP file"),
              std::string::npos)
        << e.what();
  }
}

TEST(Mcap, Crc32MatchesTheStandardCheckValue) {
  const std::string check = "123456789";
  EXPECT_EQ(mcap_crc32(std::span(reinterpret_cast<const uint8_t*>(check.data()), check.size())),
            0xCBF43926u);
}

// A zstd frame need not state its content size, and streaming compressors (the MCAP project's
// Rust writer among them) leave it out: such a chunk was refused as corrupt until review. Here
// the first chunk of a file is compressed again without the size, the file cut after it.
TEST(Mcap, ReadsZstdChunksWhoseFrameDoesNotStateItsSize) {
  testing::TempDir dir;
  const std::string path = (dir / "s.mcap").string();
  write_file(path, 200, 100.0, McapCompression::zstd, 12);
  const std::vector<uint8_t> good = slurp(path);
  const auto rs = records_of(good);
  const auto chunk =
      std::find_if(rs.begin(), rs.end(), [](const Record& r) { return r.op == 0x06; });
  ASSERT_NE(chunk, rs.end());
  // Chunk fields: start, end, uncompressed size (8 each), CRC (4), compression (4 + 4), records
  // length (8), records.
  const std::size_t fields = chunk->offset + 9;
  uint64_t uncompressed_size = 0, records_len = 0;
  std::memcpy(&uncompressed_size, &good[fields + 16], 8);
  const std::size_t records_at = fields + 8 + 8 + 8 + 4 + 4 + 4 + 8;
  std::memcpy(&records_len, &good[records_at - 8], 8);
  ASSERT_EQ(std::string(good.begin() + static_cast<std::ptrdiff_t>(fields + 32),
                        good.begin() + static_cast<std::ptrdiff_t>(fields + 36)),
            "zstd");
  std::vector<uint8_t> plain(uncompressed_size);
  ASSERT_EQ(ZSTD_decompress(plain.data(), plain.size(), &good[records_at], records_len),
            uncompressed_size);
  std::vector<uint8_t> sizeless(ZSTD_compressBound(plain.size()));
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 0);
  const std::size_t n =
      ZSTD_compress2(cctx, sizeless.data(), sizeless.size(), plain.data(), plain.size());
  ZSTD_freeCCtx(cctx);
  ASSERT_FALSE(ZSTD_isError(n));
  sizeless.resize(n);
  ASSERT_EQ(ZSTD_getFrameContentSize(sizeless.data(), sizeless.size()), ZSTD_CONTENTSIZE_UNKNOWN);

  const auto cut_after_chunk = [&](std::span<const uint8_t> records) {
    std::vector<uint8_t> out(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(records_at));
    const uint64_t len = records_at - fields + records.size(), rl = records.size();
    std::memcpy(&out[chunk->offset + 1], &len, 8);
    std::memcpy(&out[records_at - 8], &rl, 8);
    out.insert(out.end(), records.begin(), records.end());
    return out;
  };
  const auto messages = [](const std::vector<uint8_t>& bytes, const char* name,
                           McapReadSummary& s) {
    std::vector<std::pair<uint64_t, std::vector<uint8_t>>> out;
    s = read_mcap(std::span<const uint8_t>(bytes), name, [&](const McapMessageView& m) {
      out.emplace_back(m.log_time, std::vector<uint8_t>(m.data.begin(), m.data.end()));
    });
    return out;
  };
  McapReadSummary sized_summary, sizeless_summary;
  const auto sized =
      messages(cut_after_chunk(std::span<const uint8_t>(&good[records_at], records_len)),
               "sized.mcap", sized_summary);
  const auto read = messages(cut_after_chunk(sizeless), "sizeless.mcap", sizeless_summary);
  ASSERT_GT(sized.size(), 10u);
  EXPECT_EQ(read, sized);
  EXPECT_EQ(sizeless_summary.corrupt_chunks, 0u);
  EXPECT_FALSE(sizeless_summary.complete);  // cut after the chunk

  // Without the size the header's must still come out exactly.
  std::vector<uint8_t> lying = cut_after_chunk(sizeless);
  const uint64_t one_more = uncompressed_size + 1;
  std::memcpy(&lying[fields + 16], &one_more, 8);
  try {
    read_mcap(std::span<const uint8_t>(lying), "lying.mcap", nullptr);
    ADD_FAILURE() << "accepted a chunk one byte shorter than its header says";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt chunk: decompressed size does not match"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace imukit::capture
