#include "imukit/core/input_file.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "imukit/core/error.hpp"

namespace imukit {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw IoError(InputLocation{path, {}, {}, {}}, what);
}

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a pipe (FIFO)";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

void check_regular(const std::string& path, mode_t mode, std::string_view what) {
  if (S_ISREG(mode)) return;
  fail(path, fmt::format("is {}, not a file; give the {} as a regular file", kind_of(mode), what));
}

std::string size_text(std::size_t bytes) {
  if (bytes < (std::size_t{1} << 20)) return fmt::format("{} bytes", bytes);
  return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / double(1 << 20));
}

}  // namespace

UniqueFile open_regular_file(const std::string& path, std::string_view what) {
  // O_NONBLOCK: opening a FIFO or a terminal must not wait for a writer before we can refuse it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) fail(path, std::string("cannot open for reading: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int saved = errno;
    ::close(fd);
    fail(path, std::string("cannot read: ") + std::strerror(saved));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    check_regular(path, st.st_mode, what);
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  std::FILE* f = ::fdopen(fd, "rb");
  if (f == nullptr) {
    ::close(fd);
    fail(path, std::string("cannot open for reading: ") + std::strerror(errno));
  }
  return UniqueFile(f);
}

std::string read_regular_file(const std::string& path, std::size_t max_bytes,
                              std::string_view what) {
  const UniqueFile f = open_regular_file(path, what);
  struct stat st {};
  if (::fstat(::fileno(f.get()), &st) == 0 && static_cast<uint64_t>(st.st_size) > max_bytes) {
    fail(path,
         fmt::format("{} is more than a {} may hold ({})",
                     size_text(static_cast<std::size_t>(st.st_size)), what, size_text(max_bytes)));
  }
  std::string text;
  text.resize(static_cast<std::size_t>(st.st_size));
  std::size_t got = 0;
  for (;;) {
    if (got == text.size()) {
      // The file grew since fstat (or reports no size): read on, within the limit.
      if (text.size() > max_bytes)
        fail(path, fmt::format("more than a {} may hold ({})", what, size_text(max_bytes)));
      text.resize(std::max<std::size_t>(4096, text.size() * 2));
    }
    const std::size_t n = std::fread(text.data() + got, 1, text.size() - got, f.get());
    got += n;
    if (n == 0) {
      if (std::ferror(f.get())) fail(path, std::string("read failed: ") + std::strerror(errno));
      break;
    }
  }
  if (got > max_bytes)
    fail(path, fmt::format("more than a {} may hold ({})", what, size_text(max_bytes)));
  text.resize(got);
  return text;
}

void check_updatable_file(const std::string& path, std::string_view what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) check_regular(path, st.st_mode, what);
  // Written through a temporary beside it: the folder must exist and take new files.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::string folder = parent.empty() ? std::string(".") : parent.string();
  if (::stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    fail(path, fmt::format("the folder of the {} does not exist", what));
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    fail(path, fmt::format("the folder of the {} is not writable: {}", what, std::strerror(errno)));
}

void write_file_atomically(const std::string& path, const std::function<void(std::FILE*)>& write) {
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && !S_ISREG(st.st_mode)) {
    // A device, FIFO or terminal (/dev/stdout): written in place, since renaming a file over
    // it would replace the device node itself.
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr) fail(path, fmt::format("cannot open for writing: {}", std::strerror(errno)));
    try {
      write(f);
    } catch (...) {
      std::fclose(f);
      throw;
    }
    if (std::fclose(f) != 0) fail(path, fmt::format("write failed: {}", std::strerror(errno)));
    return;
  }
  // Through a symbolic link the file it names is replaced, and the link stays.
  std::error_code ec;
  const std::filesystem::path resolved =
      exists ? std::filesystem::canonical(path, ec) : std::filesystem::path(path);
  const std::string target = ec ? path : resolved.string();
  // Beside the target, so the rename stays within one file system; the process id keeps two
  // writers of one path apart.
  const std::string temporary = fmt::format("{}.{}.tmp", target, static_cast<long>(::getpid()));
  std::FILE* f = std::fopen(temporary.c_str(), "wb");
  if (f == nullptr) fail(path, fmt::format("cannot open for writing: {}", std::strerror(errno)));
  const auto discard = [&] { std::remove(temporary.c_str()); };
  try {
    write(f);
  } catch (...) {
    std::fclose(f);
    discard();
    throw;
  }
  const bool flushed = std::fflush(f) == 0;
  const int saved = errno;
  const bool closed = std::fclose(f) == 0;
  if (!flushed || !closed) {
    const int e = flushed ? errno : saved;
    discard();
    fail(path, fmt::format("write failed: {}", std::strerror(e)));
  }
  if (std::rename(temporary.c_str(), target.c_str()) != 0) {
    const int e = errno;
    discard();
    fail(path, fmt::format("cannot replace the file: {}", std::strerror(e)));
  }
}

void write_text_file(const std::string& path, std::string_view text) {
  write_file_atomically(path, [&](std::FILE* f) {
    if (std::fwrite(text.data(), 1, text.size(), f) != text.size())
      fail(path, fmt::format("write failed: {}", std::strerror(errno)));
  });
}

}  // namespace imukit
