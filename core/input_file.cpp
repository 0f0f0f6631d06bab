#include "imukit/core/input_file.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
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

namespace {

// The file `path` names once its symbolic links are followed, dangling ones included (a link to
// a file not yet written names where it will be): outputs are checked and replaced there.
std::filesystem::path link_target(const std::string& path) {
  std::filesystem::path p(path);
  for (int hops = 0; hops < 40; ++hops) {
    std::error_code ec;
    if (!std::filesystem::is_symlink(std::filesystem::symlink_status(p, ec)) || ec) break;
    const std::filesystem::path to = std::filesystem::read_symlink(p, ec);
    if (ec) break;
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  return p;
}

// Writes through `write` into f, then closes it; throws as the writer does.
void write_and_close(const std::string& path, std::FILE* f,
                     const std::function<void(std::FILE*)>& write,
                     const std::function<void()>& discard) {
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
}

}  // namespace

void check_updatable_file(const std::string& path, std::string_view what) {
  const std::filesystem::path target = link_target(path);
  struct stat st {};
  if (::stat(target.c_str(), &st) == 0) {
    check_regular(path, st.st_mode, what);
    if (::access(target.c_str(), W_OK) != 0)
      fail(path, fmt::format("the {} is not writable: {}", what, std::strerror(errno)));
  }
  // Written through a temporary beside it: the folder must exist and take new files.
  const std::filesystem::path parent = target.parent_path();
  const std::string folder = parent.empty() ? std::string(".") : parent.string();
  if (::stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    fail(path, fmt::format("the folder of the {} does not exist", what));
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    fail(path, fmt::format("the folder of the {} is not writable: {}", what, std::strerror(errno)));
}

void write_file_atomically(const std::string& path, const std::function<void(std::FILE*)>& write) {
  const std::filesystem::path target = link_target(path);
  struct stat st {};
  const bool exists = ::stat(target.c_str(), &st) == 0;
  // A device, FIFO or terminal (/dev/stdout) is written in place: renaming a file over it would
  // replace the device node itself. So is a file with other hard links, which would otherwise
  // keep the old content under their names.
  if (exists && (!S_ISREG(st.st_mode) || st.st_nlink > 1)) {
    std::FILE* f = std::fopen(target.c_str(), "wb");
    if (f == nullptr) fail(path, fmt::format("cannot open for writing: {}", std::strerror(errno)));
    write_and_close(path, f, write, [] {});
    return;
  }
  // A read-only file stays read-only, as opening it for writing would have said.
  if (exists && ::access(target.c_str(), W_OK) != 0)
    fail(path, fmt::format("cannot open for writing: {}", std::strerror(errno)));
  // A temporary of a unique short name in the target's folder (one file system for the rename;
  // O_EXCL and a per-process counter keep concurrent writers of one path, threads included,
  // apart), created 0666 less the umask as any new file, given an existing file's mode, then
  // renamed over the file.
  static std::atomic<uint64_t> counter{0};
  const std::filesystem::path folder = target.parent_path().empty() ? "." : target.parent_path();
  std::string temporary;
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    temporary = (folder / fmt::format(".imukit-{}-{}.tmp", static_cast<long>(::getpid()),
                                      counter.fetch_add(1)))
                    .string();
    fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) fail(path, fmt::format("cannot open for writing: {}", std::strerror(errno)));
  if (exists) {
    // The owner's too where allowed (root); otherwise the file becomes the writer's.
    if (::fchown(fd, st.st_uid, st.st_gid) != 0) errno = 0;
    ::fchmod(fd, st.st_mode & 07777);
  }
  std::FILE* f = ::fdopen(fd, "wb");
  if (f == nullptr) {
    const int e = errno;
    ::close(fd);
    std::remove(temporary.c_str());
    fail(path, fmt::format("cannot open for writing: {}", std::strerror(e)));
  }
  const auto discard = [&] { std::remove(temporary.c_str()); };
  write_and_close(path, f, write, discard);
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
