#include "imukit/drivers/transport.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/core.h>
#include <limits.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>

namespace imukit::drivers {

namespace {
TimeNs read_clock(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}
}  // namespace

TimeNs host_now() {
  // The wall clock steps (NTP's first sync, an administrator's `date`), and a step in the middle
  // of a recording bent the whole offline clock fit: +0.5 s half way through 600 s read as a
  // skew of -1,664 ppm, 500 ms off at the ends (review, 2026-11-27). The wall clock is read
  // once, and CLOCK_BOOTTIME, which never steps and (unlike CLOCK_MONOTONIC) counts a suspend,
  // measures the time since.
  struct Base {
    TimeNs wall, boot;
  };
  static const Base base{read_clock(CLOCK_REALTIME), read_clock(CLOCK_BOOTTIME)};
  return base.wall + (read_clock(CLOCK_BOOTTIME) - base.boot);
}

std::string os_error(const std::string& what, int err) { return what + ": " + std::strerror(err); }

FdTransport::FdTransport(int fd, bool owns, std::string name, bool writable)
    : fd_(fd), owns_(owns), name_(std::move(name)), writable_(writable) {
  struct stat st {};
  const bool known = ::fstat(fd_, &st) == 0;
  replay_ = known && S_ISREG(st.st_mode);
  fifo_ = known && S_ISFIFO(st.st_mode);
  writable_ = writable_ && !replay_;
  tty_ = ::isatty(fd_) == 1;
}

std::string FdTransport::when_silent() const {
  // A FIFO opened without waiting for its writer (open_file), or a pipe.
  if (fifo_) return "nothing was written to the FIFO or pipe: has a writer opened it?";
  return ByteTransport::when_silent();
}

FdTransport::~FdTransport() {
  if (owns_ && fd_ >= 0) ::close(fd_);
}

std::unique_ptr<FdTransport> FdTransport::open_file(const std::string& path) {
  // Without O_NONBLOCK, opening a FIFO waits for a writer, forever if none comes (found in
  // review). With it the FIFO opens at once; poll() then waits for its bytes within each read's
  // timeout (Linux reports no hang-up before a writer has come), so a FIFO nobody writes to is a
  // silent device that `record --no-data-timeout` ends, and Ctrl-C works meanwhile. Reads of
  // regular files ignore the flag, and read() takes EAGAIN as "nothing yet".
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw TransportError(os_error("cannot open " + path, errno));
  struct stat st {};
  const int err = ::fstat(fd, &st) == 0 ? 0 : errno;
  // A directory opens too, and its reads fail with EISDIR: refused here, before any reading
  // (found in review: `file:.` ended as "read failed" and `devices --read` exited 0).
  if (err != 0 || S_ISDIR(st.st_mode)) {
    ::close(fd);
    throw TransportError(err != 0 ? os_error("cannot open " + path, err)
                                  : "cannot read " + path +
                                        ": it is a directory (file: names a capture file, a "
                                        "FIFO or a device node)");
  }
  const bool fifo = S_ISFIFO(st.st_mode);
  return std::make_unique<FdTransport>(fd, true, (fifo ? "FIFO " : "file ") + path, false);
}

ReadResult FdTransport::read(std::span<uint8_t> buf, int timeout_ms) {
  ReadResult r;
  pollfd p{fd_, POLLIN, 0};
  int ready;
  do {
    ready = ::poll(&p, 1, timeout_ms);
  } while (ready < 0 && errno == EINTR);
  if (ready < 0) throw TransportError(os_error(name_ + ": poll", errno));
  if (ready == 0) {
    r.host_time = host_now();
    return r;
  }
  ssize_t n;
  do {
    n = ::read(fd_, buf.data(), buf.size());
  } while (n < 0 && errno == EINTR);
  r.host_time = host_now();
  if (n > 0) {
    r.size = static_cast<std::size_t>(n);
  } else if (n == 0) {
    r.end = true;
    r.end_reason = name_ + ": end of stream";
  } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
    // spurious wake-up: nothing to read yet
  } else {
    // EIO from a tty whose device vanished: an unplug, reported as the end of the stream.
    r.end = true;
    r.end_reason = os_error(name_ + ": read failed (device gone?)", errno);
  }
  return r;
}

void FdTransport::write(std::span<const uint8_t> bytes) {
  if (!writable_) throw TransportError(name_ + ": opened read-only, cannot send commands");
  // One deadline for the whole command, as the serial transport's: a peer that stops reading
  // (a socket nobody drains, a tty held by flow control) blocked the reader thread for good,
  // and with it --duration, --no-data-timeout and Ctrl-C (review, 2026-11-27). The descriptor
  // may be blocking: each write waits for POLLOUT and is at most PIPE_BUF bytes, which a
  // writable pipe takes whole.
  const TimeNs deadline = host_now() + kWriteTimeoutMs * 1'000'000;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const TimeNs left_ns = deadline - host_now();
    pollfd p{fd_, POLLOUT, 0};
    const int ready =
        left_ns > 0 ? ::poll(&p, 1, static_cast<int>((left_ns + 999'999) / 1'000'000)) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) throw TransportError(os_error(name_ + ": poll", errno));
    if (ready == 0) {
      throw TransportError(
          fmt::format("{}: write: {} of {} command bytes taken in {} ms (does "
                      "the other end read?)",
                      name_, done, bytes.size(), kWriteTimeoutMs));
    }
    const std::size_t chunk = std::min<std::size_t>(bytes.size() - done, PIPE_BUF);
    const ssize_t n = ::write(fd_, bytes.data() + done, chunk);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) continue;
      throw TransportError(os_error(name_ + ": write", errno));
    }
    done += static_cast<std::size_t>(n);
  }
}

MemoryTransport::MemoryTransport(std::vector<uint8_t> data, std::size_t chunk, TimeNs start_time,
                                 TimeNs step_ns)
    : data_(std::move(data)), chunk_(chunk), time_(start_time), step_(step_ns) {}

ReadResult MemoryTransport::read(std::span<uint8_t> buf, int) {
  ReadResult r;
  if (pos_ >= data_.size()) {
    r.end = true;
    r.end_reason = "end of buffer";
    r.host_time = time_;
    return r;
  }
  std::size_t n = std::min(buf.size(), data_.size() - pos_);
  if (chunk_ > 0) n = std::min(n, chunk_);
  std::copy_n(data_.begin() + static_cast<std::ptrdiff_t>(pos_), n, buf.begin());
  pos_ += n;
  time_ += step_;
  r.size = n;
  r.host_time = time_;
  return r;
}

void MemoryTransport::write(std::span<const uint8_t> bytes) {
  written_.insert(written_.end(), bytes.begin(), bytes.end());
}

}  // namespace imukit::drivers
