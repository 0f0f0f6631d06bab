// Transports: how bytes or HID reports get from a device to the host. Two small interfaces,
// ByteTransport (serial ports, pipes, files, USB bulk endpoints, mock devices) and
// ReportTransport (HID), each owning its OS resource (closed by the destructor) and reporting
// failures as TransportError with the operating system's own message kept.
//
// The end of a stream (EOF, a pulled cable, HID read -1) is not an exception from read(): it is
// ReadResult::end with a reason, so a reader ends cleanly with everything received so far.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/time.hpp"

namespace imukit::drivers {

// A transport failed (open, configure, write). what() names the device and the OS message.
class TransportError : public IoError {  // an I/O failure: the CLI's exit code 3
 public:
  using IoError::IoError;
};

// The host's clock for receive times, ns since the Unix epoch (DESIGN.md): CLOCK_REALTIME read at
// the first call plus CLOCK_BOOTTIME's time since (it never steps, and counts a suspend), so a
// step of the wall clock during a recording does not step its times.
TimeNs host_now();

struct ReadResult {
  std::size_t size = 0;  // bytes (or report bytes) placed in the buffer; 0 on timeout
  TimeNs host_time = 0;  // when they arrived (host clock, or the mock's virtual clock)
  bool end = false;      // the stream is over; end_reason says why
  std::string end_reason;
};

class Transport {
 public:
  virtual ~Transport() = default;
  Transport() = default;
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  // Human-readable name ("serial /dev/ttyUSB0 at 921600 baud").
  virtual std::string describe() const = 0;
  // The host clock this transport stamps reads with (a mock in virtual time has its own).
  virtual TimeNs now() const { return host_now(); }
  // True when now() is a simulated clock that only moves as the transport is read (a mock in
  // virtual time): a consumer may then wait instead of dropping data, since nothing is lost
  // in an OS buffer meanwhile.
  virtual bool virtual_time() const { return false; }
  // True when reads come as fast as storage gives them (a file replayed, a regular file on an
  // fd): receive times then say when the bytes were read, not when the samples were made, so
  // they give no sample rate.
  virtual bool replay() const { return false; }
  // True when the first bytes read can be the middle of what the device sends: a serial port or
  // terminal opened while the device streams (boards that do not reset on open). A line-based
  // codec cannot trust its first line then.
  virtual bool may_start_mid_stream() const { return false; }
  // What to check when nothing at all arrives, for the message that says so. Transports with
  // a setting of their own to check (a serial port's baud rate) say so.
  virtual std::string when_silent() const {
    return "check the codec in the URI and that the device is streaming";
  }
};

class ByteTransport : public Transport {
 public:
  // Waits up to timeout_ms for bytes and returns what is there (possibly less than buf.size()).
  virtual ReadResult read(std::span<uint8_t> buf, int timeout_ms) = 0;
  // Writes all bytes or throws TransportError.
  virtual void write(std::span<const uint8_t> bytes) = 0;
  // False for replays of files: commands are then not sent.
  virtual bool can_write() const { return true; }
};

class ReportTransport : public Transport {
 public:
  // One input report (report ID first, as hidapi returns it for numbered reports).
  virtual ReadResult read_report(std::span<uint8_t> buf, int timeout_ms) = 0;
  virtual void write_report(std::span<const uint8_t> report) = 0;
  // Feature report `id`: returns its bytes, report ID first; throws TransportError on failure.
  virtual std::vector<uint8_t> get_feature_report(uint8_t id, std::size_t size) = 0;
  virtual void send_feature_report(std::span<const uint8_t> report) = 0;
};

// A POSIX file descriptor: pipes, ptys, sockets, regular files (replay). Owns the descriptor
// when `owns` (closed in the destructor). Reads use poll() for the timeout; read() == 0 is the
// end of the stream.
class FdTransport : public ByteTransport {
 public:
  FdTransport(int fd, bool owns, std::string name, bool writable = true);
  ~FdTransport() override;
  // Opens a file for replay, or a FIFO or device node to read (read only), never waiting: a
  // FIFO without a writer opens at once and is read like a silent device. Throws TransportError
  // with strerror, or naming a directory as one.
  static std::unique_ptr<FdTransport> open_file(const std::string& path);

  ReadResult read(std::span<uint8_t> buf, int timeout_ms) override;
  // Throws TransportError when the other end has not taken the bytes within kWriteTimeoutMs.
  void write(std::span<const uint8_t> bytes) override;
  // False for a read-only descriptor and for a regular file (a replay) opened read-write.
  bool can_write() const override { return writable_; }
  std::string describe() const override { return name_; }
  static constexpr int kWriteTimeoutMs = 1000;
  // A regular file (open_file, or one given as an fd): a replay. Pipes and ttys are live.
  bool replay() const override { return replay_; }
  bool may_start_mid_stream() const override { return tty_; }
  std::string when_silent() const override;
  int fd() const { return fd_; }

 private:
  int fd_;
  bool owns_;
  std::string name_;
  bool writable_;
  bool replay_ = false;
  bool fifo_ = false;
  bool tty_ = false;
};

// An in-memory byte stream (tests, benchmarks, fuzzers): hands out `chunk` bytes per read (all
// at once when 0), stamping reads start_time + k * step_ns, then ends with "end of buffer".
// Writes are kept for inspection.
class MemoryTransport : public ByteTransport {
 public:
  explicit MemoryTransport(std::vector<uint8_t> data, std::size_t chunk = 0, TimeNs start_time = 0,
                           TimeNs step_ns = 1'000'000);
  ReadResult read(std::span<uint8_t> buf, int timeout_ms) override;
  void write(std::span<const uint8_t> bytes) override;
  std::string describe() const override { return "memory"; }
  TimeNs now() const override { return time_; }
  const std::vector<uint8_t>& written() const { return written_; }

 private:
  std::vector<uint8_t> data_;
  std::size_t pos_ = 0;
  std::size_t chunk_;
  TimeNs time_;
  TimeNs step_;
  std::vector<uint8_t> written_;
};

// "what: strerror(errno)" for the current errno.
std::string os_error(const std::string& what, int err);

}  // namespace imukit::drivers
