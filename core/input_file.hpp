// Opening input files, in one place for every imukit reader: only regular files are read (a
// device such as /dev/zero or a serial port, a FIFO such as /dev/stdout on a pipe, or a folder is
// refused before a byte is read, and opening never blocks), and readers that hold a whole file
// in memory give a size limit, so a wrong path cannot hang a command or exhaust memory. Streamed
// readers (column text, MCAP) hold only what they keep and bound their own records instead.
// Failures throw IoError naming the path.
#pragma once

#include <cstddef>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

namespace imukit {

// Size limits of whole-file readers. JSON documents (profiles, scenes, policies) are small;
// motions (BVH, joint-quaternion CSV) are parsed from memory, so their limit bounds memory too.
inline constexpr std::size_t kMaxJsonBytes = std::size_t{64} << 20;
inline constexpr std::size_t kMaxMotionBytes = std::size_t{1} << 30;
inline constexpr std::size_t kMaxNpyBytes = std::size_t{8} << 30;

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using UniqueFile = std::unique_ptr<std::FILE, FileCloser>;

// Opens `path` for reading in binary mode; `what` names the input in messages ("scene").
// Throws IoError if it cannot be opened or is not a regular file.
UniqueFile open_regular_file(const std::string& path, std::string_view what);

// The whole of a regular file; throws IoError as open_regular_file does, or if the file holds
// more than max_bytes.
std::string read_regular_file(const std::string& path, std::size_t max_bytes,
                              std::string_view what);

// Throws IoError unless `path` is absent or a regular file in a folder that exists and is
// writable: for outputs that are read back before they are replaced (a profile that is
// updated), checked before the work; named in messages as `what`.
void check_updatable_file(const std::string& path, std::string_view what);

// Writes `path` (created or replaced) through a temporary file beside it that `write` fills and
// that is renamed over `path` only when `write` returns and the data reached the file: a
// failure (bad input found while writing, a full disk) leaves an earlier file at `path` as it
// was and no temporary behind (found in review: a failed `imukit convert` truncated it).
// Throws IoError naming the path, or what `write` throws.
void write_file_atomically(const std::string& path, const std::function<void(std::FILE*)>& write);

// `text` as the whole of `path`, written atomically as above.
void write_text_file(const std::string& path, std::string_view text);

}  // namespace imukit
