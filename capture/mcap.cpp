#include "imukit/capture/mcap.hpp"

#include <fmt/core.h>
#include <sys/stat.h>
#include <zlib.h>
#include <zstd.h>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <optional>

#include "imukit/capture/bytes.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"

namespace imukit::capture {
namespace {

constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum Opcode : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// A single record may not claim more than this: a length field from a corrupt file must not
// make the reader allocate gigabytes.
constexpr uint64_t kMaxRecordBytes = uint64_t{1} << 31;
// A chunk may not decompress to more than this (imukit writes 1 MiB chunks; other writers use a
// few MiB): a corrupt or hostile size field must not become a huge allocation.
constexpr uint64_t kMaxChunkBytes = uint64_t{1} << 28;

void put_map(ByteWriter& w, const McapMetadataMap& map) {
  uint32_t bytes = 0;
  for (const auto& [k, v] : map) bytes += static_cast<uint32_t>(8 + k.size() + v.size());
  w.u32(bytes);
  for (const auto& [k, v] : map) {
    w.string(k);
    w.string(v);
  }
}

McapMetadataMap get_map(ByteReader& r) {
  const uint32_t bytes = r.u32();
  ByteReader entries(r.bytes(bytes, "map entries"), r.source(), r.file_offset() - bytes);
  McapMetadataMap map;
  while (!entries.done()) {
    std::string key = entries.string("map key");
    map[key] = entries.string("map value");
  }
  return map;
}

std::vector<uint8_t> schema_body(const McapSchema& s) {
  std::vector<uint8_t> b;
  ByteWriter w(b);
  w.u16(s.id);
  w.string(s.name);
  w.string(s.encoding);
  w.u32(static_cast<uint32_t>(s.data.size()));
  w.bytes(s.data);
  return b;
}

std::vector<uint8_t> channel_body(const McapChannel& c) {
  std::vector<uint8_t> b;
  ByteWriter w(b);
  w.u16(c.id);
  w.u16(c.schema_id);
  w.string(c.topic);
  w.string(c.message_encoding);
  put_map(w, c.metadata);
  return b;
}

void append_record(std::vector<uint8_t>& out, uint8_t opcode, std::span<const uint8_t> body) {
  ByteWriter w(out);
  w.u8(opcode);
  w.u64(body.size());
  w.bytes(body);
}

}  // namespace

uint32_t mcap_crc32(std::span<const uint8_t> data, uint32_t crc) {
  // zlib's crc32 takes a uInt length; feed large spans in pieces.
  while (!data.empty()) {
    const std::size_t n = std::min<std::size_t>(data.size(), 1u << 30);
    crc = static_cast<uint32_t>(::crc32(crc, data.data(), static_cast<uInt>(n)));
    data = data.subspan(n);
  }
  return crc;
}

// ---------------------------------------------------------------------------------------------
// Writer

McapWriter::McapWriter(const std::string& path, McapWriterOptions options)
    : path_(path), options_(std::move(options)) {
  file_ = std::fopen(path.c_str(), options_.create_new ? "wbx" : "wb");
  if (!file_) {
    throw IoError(InputLocation{path, {}, {}, {}},
                  std::string("cannot open for writing: ") + std::strerror(errno));
  }
  write_start();
}

McapWriter::McapWriter(std::FILE* file, const std::string& path, McapWriterOptions options)
    : path_(path), options_(std::move(options)), file_(file), owns_file_(false) {
  write_start();
}

void McapWriter::write_start() {
  write_raw(kMagic);
  std::vector<uint8_t> body;
  ByteWriter w(body);
  w.string(options_.profile);
  w.string(options_.library);
  write_record(kHeader, body);
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (...) {
    // Everything flushed before the failure stays readable; close() reports errors to callers
    // that want them.
    if (file_ && owns_file_) std::fclose(file_);
    file_ = nullptr;
  }
}

void McapWriter::write_raw(std::span<const uint8_t> bytes) {
  if (!file_) throw Error(fmt::format("{}: write after close", path_));
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    throw IoError(InputLocation{path_, {}, {}, static_cast<int64_t>(offset_)},
                  std::string("write failed: ") + std::strerror(errno));
  }
  data_crc_ = mcap_crc32(bytes, data_crc_);
  offset_ += bytes.size();
}

void McapWriter::write_record(uint8_t opcode, std::span<const uint8_t> body) {
  std::vector<uint8_t> head;
  ByteWriter w(head);
  w.u8(opcode);
  w.u64(body.size());
  write_raw(head);
  write_raw(body);
}

uint16_t McapWriter::add_schema(std::string_view name, std::string_view encoding,
                                std::string_view data) {
  McapSchema s;
  s.id = static_cast<uint16_t>(schemas_.size() + 1);  // 0 means "no schema"
  s.name = name;
  s.encoding = encoding;
  s.data.assign(data.begin(), data.end());
  write_record(kSchema, schema_body(s));
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

uint16_t McapWriter::add_channel(uint16_t schema_id, std::string_view topic,
                                 std::string_view message_encoding,
                                 const McapMetadataMap& metadata) {
  if (schema_id > schemas_.size()) {
    throw Error(fmt::format("{}: channel '{}' names unknown schema {}", path_, topic, schema_id));
  }
  McapChannel c;
  c.id = static_cast<uint16_t>(channels_.size());
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  write_record(kChannel, channel_body(c));
  channels_.push_back(std::move(c));
  next_sequence_.push_back(0);
  return channels_.back().id;
}

void McapWriter::write_message(uint16_t channel_id, uint64_t log_time, uint64_t publish_time,
                               std::span<const uint8_t> data) {
  if (channel_id >= channels_.size()) {
    throw Error(fmt::format("{}: message for unknown channel {}", path_, channel_id));
  }
  write_message(channel_id, next_sequence_[channel_id], log_time, publish_time, data);
}

void McapWriter::write_message(uint16_t channel_id, uint32_t sequence, uint64_t log_time,
                               uint64_t publish_time, std::span<const uint8_t> data) {
  if (closed_) throw Error(fmt::format("{}: write after close", path_));
  if (channel_id >= channels_.size()) {
    throw Error(fmt::format("{}: message for unknown channel {}", path_, channel_id));
  }
  next_sequence_[channel_id] = sequence + 1;
  if (chunk_has_messages_ && (log_time < chunk_start_time_ ||
                              log_time - chunk_start_time_ >= options_.chunk_duration_ns)) {
    close_chunk();
  }
  chunk_message_index_[channel_id].emplace_back(log_time, chunk_.size());
  ByteWriter w(chunk_);
  w.u8(kMessage);
  w.u64(2 + 4 + 8 + 8 + data.size());
  w.u16(channel_id);
  w.u32(sequence);
  w.u64(log_time);
  w.u64(publish_time);
  w.bytes(data);
  if (!chunk_has_messages_) {
    chunk_start_time_ = chunk_end_time_ = log_time;
    chunk_has_messages_ = true;
  }
  chunk_start_time_ = std::min(chunk_start_time_, log_time);
  chunk_end_time_ = std::max(chunk_end_time_, log_time);
  ++message_count_;
  ++channel_message_counts_[channel_id];
  message_start_time_ = std::min(message_start_time_, log_time);
  message_end_time_ = std::max(message_end_time_, log_time);
  if (chunk_.size() >= options_.chunk_bytes) close_chunk();
}

void McapWriter::write_metadata(std::string_view name, const McapMetadataMap& entries) {
  std::vector<uint8_t> body;
  ByteWriter w(body);
  w.string(name);
  put_map(w, entries);
  metadata_index_.push_back({std::string(name), {offset_, 1 + 8 + body.size()}});
  write_record(kMetadata, body);
}

void McapWriter::close_chunk() {
  if (!chunk_has_messages_) return;
  std::vector<uint8_t> compressed;
  std::string_view compression;
  std::span<const uint8_t> records = chunk_;
  if (options_.compression == McapCompression::zstd) {
    compressed.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compress(compressed.data(), compressed.size(), chunk_.data(),
                                        chunk_.size(), options_.zstd_level);
    if (ZSTD_isError(n)) throw Error(fmt::format("{}: zstd: {}", path_, ZSTD_getErrorName(n)));
    compressed.resize(n);
    compression = "zstd";
    records = compressed;
  }
  std::vector<uint8_t> body;
  ByteWriter w(body);
  w.u64(chunk_start_time_);
  w.u64(chunk_end_time_);
  w.u64(chunk_.size());
  w.u32(mcap_crc32(chunk_));
  w.string(compression);
  w.u64(records.size());
  w.bytes(records);

  ChunkIndexEntry entry{};
  entry.start_time = chunk_start_time_;
  entry.end_time = chunk_end_time_;
  entry.offset = offset_;
  entry.length = 1 + 8 + body.size();
  entry.compressed_size = records.size();
  entry.uncompressed_size = chunk_.size();
  // Chunk and its message indexes go out in one write, then to the OS.
  std::vector<uint8_t> out;
  append_record(out, kChunk, body);
  const uint64_t index_start = offset_ + out.size();
  for (const auto& [channel, entries] : chunk_message_index_) {
    entry.message_index_offsets[channel] = offset_ + out.size();
    std::vector<uint8_t> index;
    ByteWriter iw(index);
    iw.u16(channel);
    iw.u32(static_cast<uint32_t>(entries.size() * 16));
    for (const auto& [time, at] : entries) {
      iw.u64(time);
      iw.u64(at);
    }
    append_record(out, kMessageIndex, index);
  }
  entry.message_index_length = offset_ + out.size() - index_start;
  write_raw(out);
  if (std::fflush(file_) != 0) {
    throw IoError(InputLocation{path_, {}, {}, static_cast<int64_t>(offset_)},
                  std::string("write failed: ") + std::strerror(errno));
  }
  chunk_index_.push_back(std::move(entry));
  chunk_.clear();
  chunk_message_index_.clear();
  chunk_has_messages_ = false;
}

void McapWriter::flush() {
  close_chunk();
  if (file_ && std::fflush(file_) != 0) {
    throw IoError(InputLocation{path_, {}, {}, static_cast<int64_t>(offset_)},
                  std::string("write failed: ") + std::strerror(errno));
  }
}

void McapWriter::close() {
  if (closed_) return;
  closed_ = true;
  close_chunk();
  {
    std::vector<uint8_t> body;
    ByteWriter(body).u32(data_crc_);
    write_record(kDataEnd, body);
  }
  // Summary: each group of records, remembered for the Summary Offset section.
  const uint64_t summary_start = offset_;
  data_crc_ = 0;  // from here on the running CRC covers the summary, as the footer needs
  std::vector<std::tuple<uint8_t, uint64_t, uint64_t>> groups;
  const auto group = [&](uint8_t opcode, const std::vector<std::vector<uint8_t>>& bodies) {
    if (bodies.empty()) return;
    const uint64_t start = offset_;
    for (const auto& b : bodies) write_record(opcode, b);
    groups.emplace_back(opcode, start, offset_ - start);
  };
  std::vector<std::vector<uint8_t>> bodies;
  for (const auto& s : schemas_) bodies.push_back(schema_body(s));
  group(kSchema, bodies);
  bodies.clear();
  for (const auto& c : channels_) bodies.push_back(channel_body(c));
  group(kChannel, bodies);
  bodies.clear();
  {
    std::vector<uint8_t> b;
    ByteWriter w(b);
    w.u64(message_count_);
    w.u16(static_cast<uint16_t>(schemas_.size()));
    w.u32(static_cast<uint32_t>(channels_.size()));
    w.u32(0);  // attachments
    w.u32(static_cast<uint32_t>(metadata_index_.size()));
    w.u32(static_cast<uint32_t>(chunk_index_.size()));
    w.u64(message_count_ ? message_start_time_ : 0);
    w.u64(message_count_ ? message_end_time_ : 0);
    w.u32(static_cast<uint32_t>(channel_message_counts_.size() * 10));
    for (const auto& [channel, count] : channel_message_counts_) {
      w.u16(channel);
      w.u64(count);
    }
    bodies.push_back(std::move(b));
  }
  group(kStatistics, bodies);
  bodies.clear();
  for (const auto& e : chunk_index_) {
    std::vector<uint8_t> b;
    ByteWriter w(b);
    w.u64(e.start_time);
    w.u64(e.end_time);
    w.u64(e.offset);
    w.u64(e.length);
    w.u32(static_cast<uint32_t>(e.message_index_offsets.size() * 10));
    for (const auto& [channel, at] : e.message_index_offsets) {
      w.u16(channel);
      w.u64(at);
    }
    w.u64(e.message_index_length);
    w.string(options_.compression == McapCompression::zstd ? "zstd" : "");
    w.u64(e.compressed_size);
    w.u64(e.uncompressed_size);
    bodies.push_back(std::move(b));
  }
  group(kChunkIndex, bodies);
  bodies.clear();
  for (const auto& [name, where] : metadata_index_) {
    std::vector<uint8_t> b;
    ByteWriter w(b);
    w.u64(where.first);
    w.u64(where.second);
    w.string(name);
    bodies.push_back(std::move(b));
  }
  group(kMetadataIndex, bodies);
  const uint64_t summary_offset_start = offset_;
  for (const auto& [opcode, start, length] : groups) {
    std::vector<uint8_t> b;
    ByteWriter w(b);
    w.u8(opcode);
    w.u64(start);
    w.u64(length);
    write_record(kSummaryOffset, b);
  }
  // Footer: the summary CRC covers the summary, the summary offsets and the footer's own
  // opcode, length and first two fields.
  std::vector<uint8_t> footer;
  ByteWriter fw(footer);
  fw.u8(kFooter);
  fw.u64(20);
  fw.u64(summary_start);
  fw.u64(summary_offset_start);
  const uint32_t summary_crc = mcap_crc32(footer, data_crc_);
  fw.u32(summary_crc);
  write_raw(footer);
  write_raw(kMagic);
  const bool flushed = std::fflush(file_) == 0;
  const int saved = errno;
  const bool closed = !owns_file_ || std::fclose(file_) == 0;
  file_ = nullptr;
  if (!flushed || !closed) {
    throw IoError(InputLocation{path_, {}, {}, {}},
                  std::string("close failed: ") + std::strerror(flushed ? errno : saved));
  }
}

// ---------------------------------------------------------------------------------------------
// Reader

namespace {

// Where the reader gets its bytes: a file, or memory (tests, fuzzing). Read sequentially; recovery
// also seeks (to the footer, and to look for the next record after a damaged one).
class Source {
 public:
  virtual ~Source() = default;
  uint64_t size() const { return size_; }
  uint64_t position() const { return pos_; }
  uint64_t remaining() const { return size_ - pos_; }
  // Reads exactly n <= remaining() bytes into out (resized).
  virtual void read(uint64_t n, std::vector<uint8_t>& out) = 0;
  // Moves to pos <= size().
  virtual void seek(uint64_t pos) = 0;

 protected:
  uint64_t size_ = 0;
  uint64_t pos_ = 0;
};

class FileSource : public Source {
 public:
  explicit FileSource(const std::string& path) : path_(path) {
    file_ = open_regular_file(path, "MCAP recording").release();
    struct stat st {};
    if (::fstat(fileno(file_), &st) != 0) {
      std::fclose(file_);
      throw IoError(InputLocation{path, {}, {}, {}},
                    std::string("cannot stat: ") + std::strerror(errno));
    }
    size_ = static_cast<uint64_t>(st.st_size);
  }
  ~FileSource() override { std::fclose(file_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;

  void read(uint64_t n, std::vector<uint8_t>& out) override {
    out.resize(static_cast<std::size_t>(n));
    if (n > 0 && std::fread(out.data(), 1, out.size(), file_) != out.size()) {
      throw Error(InputLocation{path_, {}, {}, static_cast<int64_t>(pos_)},
                  std::string("read failed: ") + std::strerror(errno));
    }
    pos_ += n;
  }
  void seek(uint64_t pos) override {
    if (pos == pos_) return;
    if (::fseeko(file_, static_cast<off_t>(pos), SEEK_SET) != 0) {
      throw Error(InputLocation{path_, {}, {}, static_cast<int64_t>(pos)},
                  std::string("seek failed: ") + std::strerror(errno));
    }
    pos_ = pos;
  }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

class MemorySource : public Source {
 public:
  explicit MemorySource(std::span<const uint8_t> bytes) : bytes_(bytes) { size_ = bytes.size(); }
  void read(uint64_t n, std::vector<uint8_t>& out) override {
    const auto part = bytes_.subspan(static_cast<std::size_t>(pos_), static_cast<std::size_t>(n));
    out.assign(part.begin(), part.end());
    pos_ += n;
  }
  void seek(uint64_t pos) override { pos_ = pos; }

 private:
  std::span<const uint8_t> bytes_;
};

McapSchema parse_schema(ByteReader& r) {
  McapSchema s;
  s.id = r.u16();
  s.name = r.string("schema name");
  s.encoding = r.string("schema encoding");
  const uint32_t n = r.u32();
  const auto data = r.bytes(n, "schema data");
  s.data.assign(data.begin(), data.end());
  return s;
}

McapChannel parse_channel(ByteReader& r) {
  McapChannel c;
  c.id = r.u16();
  c.schema_id = r.u16();
  c.topic = r.string("channel topic");
  c.message_encoding = r.string("channel message encoding");
  c.metadata = get_map(r);
  return c;
}

McapMessageView parse_message(ByteReader& r) {
  McapMessageView m;
  m.channel_id = r.u16();
  m.sequence = r.u32();
  m.log_time = r.u64();
  m.publish_time = r.u64();
  m.data = r.bytes(r.remaining(), "message data");
  return m;
}

const char* record_name(uint8_t op) {
  switch (op) {
    case kHeader:
      return "Header";
    case kFooter:
      return "Footer";
    case kSchema:
      return "Schema";
    case kChannel:
      return "Channel";
    case kMessage:
      return "Message";
    case kChunk:
      return "Chunk";
    case kMessageIndex:
      return "Message Index";
    case kMetadata:
      return "Metadata";
    case kDataEnd:
      return "Data End";
    default:
      return "summary";
  }
}

// Opcodes of the MCAP spec (0x01 Header .. 0x0F Data End); recovery takes nothing else for the
// start of a record.
bool known_opcode(uint8_t op) { return op >= kHeader && op <= kDataEnd; }

struct RecordHead {
  uint8_t op = 0;
  uint64_t len = 0;
};

RecordHead decode_head(const uint8_t* p) {
  RecordHead h;
  h.op = p[0];
  for (int i = 0; i < 8; ++i) h.len |= static_cast<uint64_t>(p[1 + i]) << (8 * i);
  return h;
}

// One record of the data section, parsed but not yet handed on.
struct Parsed {
  uint64_t consumed = 0;    // bytes of the body its fields took (a longer body may be damage)
  uint32_t crc_before = 0;  // the data section CRC of the bytes before the record
  std::optional<McapSchema> schema;
  std::optional<McapChannel> channel;
  std::optional<McapMessageView> message;
  std::optional<McapMetadata> metadata;
  std::optional<std::pair<std::string, std::string>> header;  // profile, library
  std::optional<uint32_t> data_end_crc;
  bool chunk = false;  // its records are in `plain`
  std::span<const uint8_t> plain;
};

// One pass over a source: magic, then one record at a time (its head, or a resync in recovery;
// its verification; handing it on), until the footer or the end of the bytes.
struct Scan {
  // What a step of the record loop came to.
  enum class Step { record, skipped, ended };

  Scan(Source& file, const std::string& path, const McapHandlers& handlers,
       const McapReadOptions& options)
      : options(options), handlers(handlers), file(file), path(path) {}

  McapReadSummary summary;
  const McapReadOptions& options;
  const McapHandlers& handlers;
  std::map<uint16_t, std::size_t> channel_slot;
  Source& file;
  const std::string& path;
  std::vector<uint8_t> buf;
  std::vector<uint8_t> head;
  std::vector<uint8_t> peek;
  std::vector<uint8_t> uncompressed;
  uint32_t data_crc = 0;
  bool crc_meaningful = true;  // nothing skipped yet, so the data section CRC can be checked
  bool data_ended = false;
  // In recovery, where to search from when the header at the current position is unreadable:
  // the end of the last record's fields, which is before the current position when that
  // record's length claimed more than its fields hold (a damaged length).
  uint64_t resume = 8;
  // In recovery, whether the record at the current position must prove itself by being followed
  // by another record header: after damage, and after a record whose fields did not account
  // for its whole length or cannot be checked (a message outside a chunk, summary records).
  bool suspect = false;
  bool after_damage = false;  // the last record was skipped as damaged (already noted)

  void add_schema(McapSchema s) {
    for (const auto& have : summary.schemas) {
      if (have.id == s.id) return;
    }
    if (handlers.on_schema) handlers.on_schema(s);
    summary.schemas.push_back(std::move(s));
  }
  void add_channel(McapChannel c) {
    if (channel_slot.count(c.id)) return;
    channel_slot[c.id] = summary.channels.size();
    if (handlers.on_channel) handlers.on_channel(c);
    summary.channels.push_back(std::move(c));
  }
  void message(const McapMessageView& m, const std::string& source, uint64_t offset) {
    if (!channel_slot.count(m.channel_id)) {
      // In recovery, the Channel record may be what was damaged: its messages cannot be told
      // apart from noise, so they are counted and left out.
      if (options.recover) {
        ++summary.orphan_messages;
        return;
      }
      throw Error(InputLocation{source, {}, {}, static_cast<int64_t>(offset)},
                  fmt::format("message for channel {} before its Channel record", m.channel_id));
    }
    ++summary.messages;
    if (handlers.on_message) handlers.on_message(m);
  }
  void note_damage(std::string what) {
    ++summary.damaged_records;
    if (summary.damage.size() < McapReadSummary::kMaxDamageNotes)
      summary.damage.push_back(std::move(what));
  }
  // Records inside a chunk (uncompressed). Each is parsed before it is handed on, so an error
  // from a handler is the handler's, never mistaken for damage. In recovery, returns why the
  // records stopped early (the ones before stay delivered).
  std::optional<std::string> chunk_records(std::span<const uint8_t> records,
                                           const std::string& source, uint64_t base) {
    ByteReader r(records, source, base);
    while (!r.done()) {
      uint8_t op = 0;
      uint64_t at = 0;
      std::optional<McapSchema> schema;
      std::optional<McapChannel> channel;
      std::optional<McapMessageView> message_view;
      try {
        op = r.u8();
        const uint64_t len = r.u64();
        at = r.file_offset();
        ByteReader body(r.bytes(len, "record in chunk"), source, at);
        if (op == kSchema)
          schema = parse_schema(body);
        else if (op == kChannel)
          channel = parse_channel(body);
        else if (op == kMessage)
          message_view = parse_message(body);
        // Other records inside chunks are not defined by the spec; skip them.
      } catch (const Error& e) {
        if (!options.recover) throw;
        return std::string(e.what());
      }
      if (schema) add_schema(std::move(*schema));
      if (channel) add_channel(std::move(*channel));
      if (message_view) message(*message_view, source, at);
    }
    return std::nullopt;
  }

  InputLocation at(uint64_t offset) const {
    return InputLocation{path, {}, {}, static_cast<int64_t>(offset)};
  }
  // Ends the scan short of the footer; `what` says where the bytes ran out.
  void end_truncated(const std::string& what) {
    summary.complete = false;
    summary.truncation_note = fmt::format(
        "{}: the file ends at byte {} {}; kept the {} messages of the {} complete chunks before it",
        path, file.size(), what, summary.messages, summary.chunks);
  }

  // Recovery's view of record boundaries: a header is a known opcode with a length that fits in
  // the file; a candidate found by searching must also be followed by a header (or the end of
  // the file, or a record the end cuts short).
  std::optional<RecordHead> head_at(uint64_t p) {
    if (p > file.size() || file.size() - p < 9) return std::nullopt;
    file.seek(p);
    file.read(9, peek);
    return decode_head(peek.data());
  }
  bool fits(const RecordHead& h, uint64_t p) const {
    return known_opcode(h.op) && h.len <= kMaxRecordBytes && h.len <= file.size() - p - 9;
  }
  bool followed(uint64_t p, const RecordHead& h) {
    const uint64_t next = p + 9 + h.len;
    if (next == file.size() || h.op == kFooter) return true;
    const auto n = head_at(next);
    return !n || (known_opcode(n->op) && n->len <= kMaxRecordBytes);
  }
  std::optional<uint64_t> resync(uint64_t from);
  void use_summary();

  // The phases of the scan, in order.
  bool check_magic();
  Step next_head(uint64_t record_start, RecordHead& head_out);
  bool verify(uint64_t record_start, const RecordHead& h, Parsed& p);
  std::string read_chunk(ByteReader& r, uint64_t record_start, Parsed& p);
  Step hand_on(uint64_t record_start, uint8_t op, Parsed& p);
};

// The first record start at or after `from`, searched a window at a time.
std::optional<uint64_t> Scan::resync(uint64_t from) {
  constexpr uint64_t kWindow = uint64_t{1} << 16;
  std::vector<uint8_t> window;
  for (uint64_t base = from; base < file.size() && file.size() - base >= 9; base += kWindow) {
    const uint64_t n = std::min(kWindow + 8, file.size() - base);
    file.seek(base);
    file.read(n, window);
    for (uint64_t i = 0; i < kWindow && i + 9 <= n; ++i) {
      const RecordHead h = decode_head(&window[static_cast<std::size_t>(i)]);
      if (fits(h, base + i) && followed(base + i, h)) return base + i;
    }
  }
  return std::nullopt;
}

// Recovery trusts the summary's schemas and channels when the summary CRC checks out: a
// damaged Channel record in the data section then costs no messages.
void Scan::use_summary() {
  constexpr uint64_t kFooterBytes = 9 + 20;
  if (file.size() < 8 + kFooterBytes + 8) return;
  const uint64_t footer_at = file.size() - 8 - kFooterBytes;
  file.seek(footer_at);
  file.read(kFooterBytes + 8, buf);
  ByteReader f(buf, path, footer_at);
  const RecordHead h{f.u8(), f.u64()};
  const uint64_t summary_start = f.u64();
  (void)f.u64();  // summary offset start
  const uint32_t summary_crc = f.u32();
  if (h.op != kFooter || h.len != 20 || std::memcmp(&buf[kFooterBytes], kMagic, 8) != 0 ||
      summary_start < 8 || summary_start >= footer_at || summary_crc == 0 ||
      footer_at - summary_start > kMaxRecordBytes) {
    return;
  }
  // The CRC covers the summary, the summary offsets and the footer up to the CRC itself.
  const uint64_t covered = footer_at + 1 + 8 + 16 - summary_start;
  file.seek(summary_start);
  file.read(covered, buf);
  if (mcap_crc32(buf) != summary_crc) {
    note_damage(
        fmt::format("byte {}: the summary's CRC-32 does not match; not used", summary_start));
    return;
  }
  ByteReader r(std::span<const uint8_t>(buf).first(footer_at - summary_start), path, summary_start);
  try {
    while (!r.done()) {
      const uint8_t op = r.u8();
      const uint64_t len = r.u64();
      ByteReader body(r.bytes(len, "summary record"), path, r.file_offset() - len);
      if (op == kSchema) add_schema(parse_schema(body));
      if (op == kChannel) add_channel(parse_channel(body));
    }
  } catch (const Error&) {
    // The CRC matched, so the writer made it so; what was read before stays.
  }
  summary.summary_used = true;
}

// Reads the magic; false when the file ends inside it (the scan has ended).
bool Scan::check_magic() {
  if (file.size() < 8) {
    if (file.size() == 0) {
      end_truncated("before the magic (empty file)");
      return false;
    }
    file.read(file.size(), buf);
    if (std::memcmp(buf.data(), kMagic, buf.size()) != 0) {
      throw Error(at(0), "not an MCAP file (bad magic)");
    }
    end_truncated("inside the magic");
    return false;
  }
  file.read(8, buf);
  data_crc = mcap_crc32(buf);
  if (std::memcmp(buf.data(), kMagic, 8) != 0) {
    // Recovery reads on when a Header record follows: only the magic was hit.
    const auto h = options.recover ? head_at(8) : std::nullopt;
    if (!h || h->op != kHeader || !fits(*h, 8)) throw Error(at(0), "not an MCAP file (bad magic)");
    note_damage("byte 0: bad magic; read on from the Header record at byte 8");
    crc_meaningful = false;
  }
  return true;
}

// The head of the record at `record_start` (the current position), left in `head_out` with the
// position just after it; in recovery, an unreadable head is skipped to the next record found.
Scan::Step Scan::next_head(uint64_t record_start, RecordHead& head_out) {
  const bool recover = options.recover;
  if (file.remaining() == 0) {
    end_truncated(data_ended ? "before the footer" : "after a complete record, before Data End");
    return Step::ended;
  }
  std::optional<RecordHead> h;
  if (file.remaining() >= 9) {
    file.read(9, head);
    h = decode_head(head.data());
  }
  bool unreadable = false;
  if (!h) {
    if (!recover) {
      end_truncated(fmt::format("inside a record header at byte {}", record_start));
      return Step::ended;
    }
    unreadable = true;
  } else if (h->len > kMaxRecordBytes) {
    if (!recover) {
      throw Error(at(record_start),
                  fmt::format("record of {} bytes is larger than any imukit writes", h->len));
    }
    unreadable = true;
  } else if (h->len > file.remaining()) {
    if (!recover) {
      end_truncated(fmt::format("inside a record (opcode 0x{:02x}) that started at byte {}", h->op,
                                record_start));
      return Step::ended;
    }
    unreadable = true;
  } else if (recover && !known_opcode(h->op)) {
    unreadable = true;
  } else if (recover && suspect) {
    unreadable = !followed(record_start, *h);
    file.seek(record_start + 9);
  }
  if (!unreadable) {
    head_out = *h;
    return Step::record;
  }
  const auto next = resync(resume < record_start ? resume : record_start + 1);
  if (!next) {
    // Nothing readable follows: the end of a file cut short (or damaged to its end).
    if (h && known_opcode(h->op) && h->len <= kMaxRecordBytes &&
        h->len > file.size() - record_start - 9) {
      end_truncated(fmt::format("inside a record (opcode 0x{:02x}) that started at byte {}", h->op,
                                record_start));
    } else {
      end_truncated(fmt::format("after byte {}, with no complete record from there", record_start));
    }
    return Step::ended;
  }
  if (!after_damage) {
    note_damage(*next > record_start
                    ? fmt::format("byte {}: no readable record; {} bytes skipped to the record at "
                                  "byte {}",
                                  record_start, *next - record_start, *next)
                    : fmt::format("byte {}: no readable record; read on from the record found at "
                                  "byte {}, inside the one before",
                                  record_start, *next));
  }
  crc_meaningful = false;
  file.seek(*next);
  resume = *next;
  suspect = false;  // a record found by resync() is followed by another
  after_damage = false;
  return Step::skipped;
}

// Reads and parses the body of the record whose head `h` was just read, checking what can be
// checked (lengths, a chunk's sizes and CRC). False when the record was skipped as damaged
// (recovery only: without it, damage throws).
bool Scan::verify(uint64_t record_start, const RecordHead& h, Parsed& p) {
  const bool recover = options.recover;
  const uint8_t op = h.op;
  file.read(h.len, buf);
  // The data section CRC covers every byte before the Data End record.
  p.crc_before = data_crc;
  if (!data_ended && op != kDataEnd) data_crc = mcap_crc32(buf, mcap_crc32(head, data_crc));

  std::string problem;
  try {
    ByteReader r(buf, path, record_start + 9);
    switch (op) {
      case kHeader: {
        std::string profile = r.string("header profile");
        p.header.emplace(std::move(profile), r.string("header library"));
        break;
      }
      case kSchema:
        p.schema = parse_schema(r);
        break;
      case kChannel:
        p.channel = parse_channel(r);
        break;
      case kMessage:
        p.message = parse_message(r);
        break;
      case kMetadata: {
        McapMetadata m;
        m.name = r.string("metadata name");
        m.entries = get_map(r);
        p.metadata = std::move(m);
        break;
      }
      case kMessageIndex: {  // not used, but its fields delimit it for recovery
        (void)r.u16();
        r.skip(r.u32(), "message index entries");
        break;
      }
      case kChunk:
        problem = read_chunk(r, record_start, p);
        break;
      case kDataEnd:
        p.data_end_crc = r.u32();
        break;
      case kFooter:
        (void)r.u64();
        (void)r.u64();
        (void)r.u32();
        break;
      default:
        r.skip(r.remaining(), "record");  // summary records and unknown opcodes
        break;
    }
    p.consumed = r.position();
  } catch (const Error& e) {
    if (!recover) throw;
    problem = e.what();
  }
  if (!problem.empty()) {
    note_damage(fmt::format("{} record skipped ({})", record_name(op), problem));
    crc_meaningful = false;
    // Go on right after it if a record that is followed by another starts there (its length
    // was sound), else search from just after its start (its length was what the damage hit).
    resume = record_start + 1;
    suspect = true;
    after_damage = true;
    return false;
  }
  after_damage = false;
  resume = record_start + 9 + p.consumed;
  // Verified: a chunk that passed its CRC, or a record whose self-delimiting fields used
  // exactly its length.
  const bool self_delimited = op == kHeader || op == kSchema || op == kChannel || op == kMetadata ||
                              op == kMessageIndex || op == kDataEnd || op == kFooter ||
                              op == kChunk;
  suspect = !(self_delimited && p.consumed == h.len);
  return true;
}

// The fields of a Chunk record after its opcode and length: its records, uncompressed, go to
// `p.plain`. Returns what is wrong with the chunk (empty when nothing is); without recovery,
// throws instead.
std::string Scan::read_chunk(ByteReader& r, uint64_t record_start, Parsed& p) {
  std::string problem;
  (void)r.u64();  // start time
  (void)r.u64();  // end time
  const uint64_t uncompressed_size = r.u64();
  const uint32_t uncompressed_crc = r.u32();
  const std::string compression = r.string("chunk compression");
  const uint64_t records_len = r.u64();
  const auto records = r.bytes(records_len, "chunk records");
  const unsigned long long frame_size =
      compression == "zstd" ? ZSTD_getFrameContentSize(records.data(), records.size()) : 0;
  if (uncompressed_size > kMaxChunkBytes) {
    problem = fmt::format("declares {} uncompressed bytes (more than {})", uncompressed_size,
                          kMaxChunkBytes);
  } else if (compression.empty()) {
    if (records.size() != uncompressed_size)
      problem = "uncompressed size does not match its records";
    p.plain = records;
  } else if (compression == "zstd" && frame_size != uncompressed_size &&
             frame_size != ZSTD_CONTENTSIZE_UNKNOWN) {
    // A zstd frame that states its own size must agree with the chunk header; checking first
    // means a lying header never decides how much memory is allocated. The size is optional in
    // a frame (streaming compressors, the MCAP project's Rust writer among them, leave it out:
    // such chunks were refused as corrupt until review, 2026-11-27); without it the header's
    // size, already bounded by kMaxChunkBytes, is the buffer and must come out exactly.
    problem = frame_size == ZSTD_CONTENTSIZE_ERROR
                  ? std::string("its records are not a zstd frame")
                  : std::string("uncompressed size does not match its zstd frame");
  } else if (compression == "zstd") {
    uncompressed.resize(static_cast<std::size_t>(uncompressed_size));
    const std::size_t n =
        ZSTD_decompress(uncompressed.data(), uncompressed.size(), records.data(), records.size());
    if (ZSTD_isError(n))
      problem = fmt::format("zstd: {}", ZSTD_getErrorName(n));
    else if (n != uncompressed_size)
      problem = "decompressed size does not match the chunk header";
    p.plain = std::span<const uint8_t>(uncompressed.data(),
                                       std::min<std::size_t>(n, uncompressed.size()));
  } else {
    problem = fmt::format("unsupported compression '{}'", compression);
  }
  if (problem.empty() && options.verify_crcs && uncompressed_crc != 0 &&
      mcap_crc32(p.plain) != uncompressed_crc) {
    problem = "CRC-32 of its records does not match";
  }
  if (!problem.empty()) {
    if (!options.recover) throw Error(at(record_start), "corrupt chunk: " + problem);
    ++summary.corrupt_chunks;
    problem = fmt::format("{}: corrupt chunk: {}", at(record_start).to_string(), problem);
  }
  p.chunk = true;
  return problem;
}

// Hands a verified record on: to the summary, to the handlers, or (Data End, Footer) to the
// checks that end the data section and the file.
Scan::Step Scan::hand_on(uint64_t record_start, uint8_t op, Parsed& p) {
  if (p.header) {
    summary.profile = std::move(p.header->first);
    summary.library = std::move(p.header->second);
  } else if (p.schema) {
    // A summary whose CRC matches lists every schema and channel; the data section's copies
    // have no CRC of their own (a damaged id would parse as another schema).
    if (!data_ended && !summary.summary_used) add_schema(std::move(*p.schema));
  } else if (p.channel) {
    if (!data_ended && !summary.summary_used) add_channel(std::move(*p.channel));
  } else if (p.message) {
    message(*p.message, path, record_start);
  } else if (p.metadata) {
    if (!data_ended) summary.metadata.push_back(std::move(*p.metadata));
  } else if (p.chunk) {
    const auto damaged =
        chunk_records(p.plain, path + " (chunk at byte " + std::to_string(record_start) + ")", 0);
    if (damaged) {
      note_damage(fmt::format("Chunk records cut short ({})", *damaged));
    } else {
      ++summary.chunks;
    }
  } else if (p.data_end_crc) {
    const uint32_t stored = *p.data_end_crc;
    if (options.verify_crcs && stored != 0 && stored != p.crc_before && crc_meaningful) {
      const std::string what = fmt::format(
          "data section CRC-32 0x{:08x} does not match the stored 0x{:08x}", p.crc_before, stored);
      if (!options.recover) throw Error(at(record_start), what);
      // Every chunk passed its own CRC: the damage is in a record outside the chunks.
      note_damage(fmt::format("{}: {} (a record outside the chunks is damaged{})",
                              at(record_start).to_string(), what,
                              summary.summary_used ? "; schemas and channels came from the "
                                                     "summary, whose CRC matches"
                                                   : ""));
    }
    data_ended = true;
  } else if (op == kFooter) {
    if (file.remaining() < 8) {
      end_truncated("inside the closing magic");
      return Step::ended;
    }
    file.read(8, buf);
    if (std::memcmp(buf.data(), kMagic, 8) != 0) {
      if (!options.recover)
        throw Error(at(file.position() - 8), "bad closing magic after the footer");
      note_damage(fmt::format("byte {}: bad closing magic", file.position() - 8));
      end_truncated("after a footer without its closing magic");
      return Step::ended;
    }
    summary.complete = true;
    return Step::ended;
  }
  return Step::record;
}

McapReadSummary read_source(Source& file, const std::string& path, const McapHandlers& handlers,
                            const McapReadOptions& options) {
  Scan scan(file, path, handlers, options);
  if (!scan.check_magic()) return scan.summary;
  if (options.recover) scan.use_summary();
  file.seek(8);
  while (true) {
    const uint64_t record_start = file.position();
    RecordHead h;
    const Scan::Step step = scan.next_head(record_start, h);
    if (step == Scan::Step::ended) return scan.summary;
    if (step == Scan::Step::skipped) continue;
    Parsed p;
    if (!scan.verify(record_start, h, p)) continue;
    if (scan.hand_on(record_start, h.op, p) == Scan::Step::ended) return scan.summary;
  }
}

}  // namespace

McapReadSummary read_mcap(const std::string& path, const McapHandlers& handlers,
                          const McapReadOptions& options) {
  FileSource file(path);
  return read_source(file, path, handlers, options);
}

McapReadSummary read_mcap(const std::string& path,
                          const std::function<void(const McapMessageView&)>& on_message,
                          const McapReadOptions& options) {
  return read_mcap(path, McapHandlers{nullptr, nullptr, on_message}, options);
}

McapReadSummary read_mcap(std::span<const uint8_t> bytes, const std::string& source_name,
                          const McapHandlers& handlers, const McapReadOptions& options) {
  MemorySource memory(bytes);
  return read_source(memory, source_name, handlers, options);
}

McapReadSummary read_mcap(std::span<const uint8_t> bytes, const std::string& source_name,
                          const std::function<void(const McapMessageView&)>& on_message,
                          const McapReadOptions& options) {
  return read_mcap(bytes, source_name, McapHandlers{nullptr, nullptr, on_message}, options);
}

namespace {

// The schemas, channels, metadata (extra_metadata replacing records of the same name) and
// messages (through edit) of `in` into writer, which it closes.
void copy_into(McapWriter& writer, const std::string& in, const McapReadSummary& summary,
               const McapMessageEdit& edit, const McapReadOptions& options,
               const std::vector<McapMetadata>& extra_metadata) {
  std::map<uint16_t, uint16_t> schema_map;
  std::map<uint16_t, uint16_t> channel_map;
  std::map<uint16_t, const McapChannel*> channels;
  for (const auto& s : summary.schemas) {
    schema_map[s.id] = writer.add_schema(
        s.name, s.encoding,
        std::string_view(reinterpret_cast<const char*>(s.data.data()), s.data.size()));
  }
  for (const auto& c : summary.channels) {
    const auto schema = schema_map.count(c.schema_id) ? schema_map[c.schema_id] : uint16_t{0};
    channel_map[c.id] = writer.add_channel(schema, c.topic, c.message_encoding, c.metadata);
    channels[c.id] = &c;
  }
  for (const auto& m : summary.metadata) {
    const bool replaced = std::any_of(extra_metadata.begin(), extra_metadata.end(),
                                      [&](const McapMetadata& e) { return e.name == m.name; });
    if (!replaced) writer.write_metadata(m.name, m.entries);
  }
  for (const auto& m : extra_metadata) writer.write_metadata(m.name, m.entries);
  read_mcap(
      in,
      [&](const McapMessageView& m) {
        McapMessageView copy = m;
        if (edit && !edit(*channels.at(m.channel_id), copy)) return;
        writer.write_message(channel_map.at(m.channel_id), copy.sequence, copy.log_time,
                             copy.publish_time, copy.data);
      },
      options);
  writer.close();
}

}  // namespace

McapReadSummary rewrite_mcap(const std::string& in, const std::string& out_path,
                             const McapMessageEdit& edit, const McapReadOptions& options,
                             const std::vector<McapMetadata>& extra_metadata) {
  // First pass: what the file declares (schemas, channels, metadata); second: the messages.
  McapReadSummary summary = read_mcap(in, nullptr, options);
  McapWriterOptions wo;
  wo.profile = summary.profile;
  wo.library = summary.library.empty() ? "imukit" : summary.library;
  // Through a temporary renamed over out_path when complete: a full disk or a bad message
  // leaves no truncated file under the final name, and an earlier file there as it was.
  write_file_atomically(out_path, [&](std::FILE* file) {
    McapWriter writer(file, out_path, wo);
    copy_into(writer, in, summary, edit, options, extra_metadata);
  });
  return summary;
}

McapReadSummary recover_mcap(const std::string& in, const std::string& out_path) {
  McapReadOptions options;
  options.recover = true;
  return rewrite_mcap(in, out_path, nullptr, options);
}

}  // namespace imukit::capture
