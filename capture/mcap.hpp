// MCAP recording files (https://mcap.dev/spec, major version 0), written and read by imukit's own
// code. The writer is built for recordings that must survive a crash or a pulled cable:
// - messages go into zstd-compressed Chunks, each with the CRC-32 of its uncompressed records,
//   followed by one Message Index per channel;
// - a chunk is closed and handed to the OS when it holds 250 ms of log time or its size limit,
//   so a killed recorder loses at most the chunk being filled;
// - Schema, Channel and Metadata records are written outside chunks, as soon as they are added,
//   so every complete chunk is readable on its own terms;
// - close() writes Data End (with the CRC of the data section), the summary (schemas, channels,
//   statistics, chunk and metadata indexes), summary offsets and the footer.
// The reader scans the data section from the start (it does not trust the summary), verifies
// every CRC, and on a file cut short returns everything up to the last complete record with a
// note saying where the file ends; only real corruption is an error. In recovery it does not
// stop at corruption either: a damaged record is skipped and the next one found (McapReadOptions::
// recover), so every intact chunk is kept.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace imukit::capture {

using McapMetadataMap = std::map<std::string, std::string>;

struct McapSchema {
  uint16_t id = 0;
  std::string name;
  std::string encoding;
  std::vector<uint8_t> data;
};

struct McapChannel {
  uint16_t id = 0;
  uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;
  McapMetadataMap metadata;
};

struct McapMessageView {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0;      // ns
  uint64_t publish_time = 0;  // ns
  std::span<const uint8_t> data;
};

struct McapMetadata {
  std::string name;
  McapMetadataMap entries;
};

enum class McapCompression { none, zstd };

struct McapWriterOptions {
  std::string profile = "ros2";
  std::string library = "imukit";
  McapCompression compression = McapCompression::zstd;
  int zstd_level = 3;
  std::size_t chunk_bytes = 1 << 20;         // uncompressed size that closes a chunk
  uint64_t chunk_duration_ns = 250'000'000;  // log-time span that closes a chunk
  // Create the file only if nothing is at the path yet (O_EXCL): a live recording must never
  // truncate a file another recording left behind.
  bool create_new = false;
};

class McapWriter {
 public:
  // Creates (truncates) the file and writes magic and header. Throws imukit::Error on failure.
  explicit McapWriter(const std::string& path, McapWriterOptions options = {});
  // Writes into `file`, already open for writing and owned by the caller, who closes it (e.g.
  // the temporary of write_file_atomically); `path` names it in messages. close() flushes it.
  McapWriter(std::FILE* file, const std::string& path, McapWriterOptions options = {});
  // Closes the file if close() was not called; errors are swallowed there (what was flushed
  // stays readable), so call close() to see them.
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  uint16_t add_channel(uint16_t schema_id, std::string_view topic,
                       std::string_view message_encoding, const McapMetadataMap& metadata = {});
  // Appends a message; the sequence number counts per channel from 0 unless given.
  void write_message(uint16_t channel_id, uint64_t log_time, uint64_t publish_time,
                     std::span<const uint8_t> data);
  void write_message(uint16_t channel_id, uint32_t sequence, uint64_t log_time,
                     uint64_t publish_time, std::span<const uint8_t> data);
  void write_metadata(std::string_view name, const McapMetadataMap& entries);
  // Closes the chunk being filled and hands everything written to the OS.
  void flush();
  // Writes the summary and footer and closes the file. Idempotent.
  void close();

  const std::string& path() const { return path_; }
  uint64_t messages_written() const { return message_count_; }

 private:
  struct ChunkIndexEntry {
    uint64_t start_time, end_time, offset, length;
    std::map<uint16_t, uint64_t> message_index_offsets;
    uint64_t message_index_length, compressed_size, uncompressed_size;
  };
  void write_raw(std::span<const uint8_t> bytes);
  void write_record(uint8_t opcode, std::span<const uint8_t> body);
  void close_chunk();
  void write_start();

  std::string path_;
  McapWriterOptions options_;
  std::FILE* file_ = nullptr;
  bool owns_file_ = true;
  uint64_t offset_ = 0;
  uint32_t data_crc_ = 0;  // running CRC-32 of everything written before Data End
  bool closed_ = false;

  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::vector<uint32_t> next_sequence_;
  std::vector<std::pair<std::string, std::pair<uint64_t, uint64_t>>> metadata_index_;

  std::vector<uint8_t> chunk_;  // uncompressed records of the open chunk
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_message_index_;
  uint64_t chunk_start_time_ = 0, chunk_end_time_ = 0;
  bool chunk_has_messages_ = false;
  std::vector<ChunkIndexEntry> chunk_index_;

  uint64_t message_count_ = 0;
  uint64_t message_start_time_ = UINT64_MAX, message_end_time_ = 0;
  std::map<uint16_t, uint64_t> channel_message_counts_;
};

struct McapReadOptions {
  bool verify_crcs = true;
  // Recovery: instead of throwing, skip every damaged record (a chunk whose CRC, sizes or
  // compression fail, a record whose fields do not parse, a length that does not fit, a bad
  // magic) and search on for the next record: a known opcode whose length fits and is followed
  // by another record header. Schemas and channels come from the summary alone when its own CRC
  // matches (so a damaged Channel record costs nothing in a file that was closed), messages
  // whose channel is unknown are left out and counted. Only a file that does not start as MCAP
  // (magic and Header record both wrong) is still an error.
  bool recover = false;
};

struct McapReadSummary {
  std::string profile;
  std::string library;
  std::vector<McapSchema> schemas;
  std::vector<McapChannel> channels;
  std::vector<McapMetadata> metadata;
  uint64_t messages = 0;
  uint64_t chunks = 0;
  uint64_t corrupt_chunks = 0;
  bool complete = false;        // Data End, footer and closing magic were all found
  std::string truncation_note;  // where and how a file that is not complete ends
  // Recovery only: records skipped as damaged (corrupt chunks included), messages left out
  // because their channel is unknown, whether the summary's schemas and channels were used, and
  // one line per damaged record or region (the first kMaxDamageNotes).
  static constexpr std::size_t kMaxDamageNotes = 100;
  uint64_t damaged_records = 0;
  uint64_t orphan_messages = 0;
  bool summary_used = false;
  std::vector<std::string> damage;
};

// Callbacks for a reader that wants records as they come: a channel is always announced before
// its first message.
struct McapHandlers {
  std::function<void(const McapSchema&)> on_schema;
  std::function<void(const McapChannel&)> on_channel;
  std::function<void(const McapMessageView&)> on_message;
};

McapReadSummary read_mcap(const std::string& path, const McapHandlers& handlers,
                          const McapReadOptions& options = {});

// Reads a file, calling on_message for every message in file order (the view is valid during the
// call). Throws imukit::Error (with the byte offset) on anything but a file cut short.
McapReadSummary read_mcap(const std::string& path,
                          const std::function<void(const McapMessageView&)>& on_message,
                          const McapReadOptions& options = {});

// The same for a file already in memory; `source_name` is used in messages.
McapReadSummary read_mcap(std::span<const uint8_t> bytes, const std::string& source_name,
                          const McapHandlers& handlers, const McapReadOptions& options = {});
McapReadSummary read_mcap(std::span<const uint8_t> bytes, const std::string& source_name,
                          const std::function<void(const McapMessageView&)>& on_message,
                          const McapReadOptions& options = {});

// Copies `in` to `out` message by message, letting `edit` change a message's times and data
// (it may point m.data at its own storage, which must outlive the call) or leave it out (by
// returning false). Schemas, channels and metadata are copied as they are (plus
// `extra_metadata`, which replaces records of the same name). Reads as `options` say (e.g.
// recovering). `out` is written through a temporary beside it and renamed over it only when
// complete (write_file_atomically): a failure leaves an earlier file at `out` as it was.
using McapMessageEdit = std::function<bool(const McapChannel& channel, McapMessageView& m)>;
McapReadSummary rewrite_mcap(const std::string& in, const std::string& out,
                             const McapMessageEdit& edit, const McapReadOptions& options = {},
                             const std::vector<McapMetadata>& extra_metadata = {});

// Rewrites whatever `in` holds (up to where it was cut, skipping damaged records) as a complete
// file at `out`. Returns the summary of what was read. (A recording of `imukit record` also
// needs its clocks refitted over what was kept: capture::recover_recording, session.hpp.)
McapReadSummary recover_mcap(const std::string& in, const std::string& out);

// CRC-32 (IEEE 802.3, zlib's), as MCAP uses.
uint32_t mcap_crc32(std::span<const uint8_t> data, uint32_t crc = 0);

}  // namespace imukit::capture
