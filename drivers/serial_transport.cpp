#include "imukit/drivers/serial_transport.hpp"

#include <libserialport.h>
#include <poll.h>
#include <sys/stat.h>

#include <cerrno>

namespace imukit::drivers {
namespace {

std::string sp_message(const std::string& what, sp_return code) {
  if (code == SP_ERR_FAIL) {
    char* msg = sp_last_error_message();
    std::string s = what + ": " + (msg ? msg : "failed");
    sp_free_error_message(msg);
    return s;
  }
  if (code == SP_ERR_ARG) return what + ": invalid argument";
  if (code == SP_ERR_MEM) return what + ": out of memory";
  if (code == SP_ERR_SUPP) return what + ": not supported by this port";
  return what + ": error " + std::to_string(static_cast<int>(code));
}

void check(sp_return code, const std::string& what) {
  if (code < 0) throw TransportError(sp_message(what, code));
}

}  // namespace

SerialTransport::SerialTransport(const std::string& port, int baud, bool rtscts)
    : name_(port), baud_(baud) {
  if (const sp_return rc = sp_get_port_by_name(port.c_str(), &port_); rc < 0) {
    // libserialport says only "invalid argument" for a missing port: ask the OS why.
    struct stat st {};
    if (::stat(port.c_str(), &st) != 0) {
      throw TransportError(
          os_error("cannot open serial " + port + " (`imukit devices` lists ports)", errno));
    }
    throw TransportError(sp_message("serial " + port + " is not a serial port", rc));
  }
  const sp_return open = sp_open(port_, SP_MODE_READ_WRITE);
  if (open < 0) {
    const std::string msg = sp_message("cannot open serial " + port, open);
    sp_free_port(port_);
    port_ = nullptr;
    throw TransportError(msg);
  }
  try {
    check(sp_set_baudrate(port_, baud), "serial " + port + ": set baud " + std::to_string(baud));
    check(sp_set_bits(port_, 8), "serial " + port + ": set 8 data bits");
    check(sp_set_parity(port_, SP_PARITY_NONE), "serial " + port + ": set no parity");
    check(sp_set_stopbits(port_, 1), "serial " + port + ": set 1 stop bit");
    check(sp_set_flowcontrol(port_, rtscts ? SP_FLOWCONTROL_RTSCTS : SP_FLOWCONTROL_NONE),
          "serial " + port + ": set flow control");
  } catch (...) {
    sp_close(port_);
    sp_free_port(port_);
    port_ = nullptr;
    throw;
  }
}

SerialTransport::~SerialTransport() {
  if (port_) {
    sp_close(port_);
    sp_free_port(port_);
  }
}

int SerialTransport::baud() const {
  int baud = 0;
  sp_port_config* cfg = nullptr;
  if (sp_new_config(&cfg) == SP_OK) {
    if (sp_get_config(port_, cfg) == SP_OK) sp_get_config_baudrate(cfg, &baud);
    sp_free_config(cfg);
  }
  return baud;
}

std::string SerialTransport::describe() const {
  return "serial " + name_ + " at " + std::to_string(baud_) + " baud";
}

ReadResult SerialTransport::read(std::span<uint8_t> buf, int timeout_ms) {
  ReadResult r;
  // Returns as soon as at least one byte is there, or after the timeout.
  const int n = sp_blocking_read_next(port_, buf.data(), buf.size(),
                                      static_cast<unsigned>(timeout_ms > 0 ? timeout_ms : 1));
  r.host_time = host_now();
  if (n > 0) {
    r.size = static_cast<std::size_t>(n);
  } else if (n == 0) {
    // A tty whose device went away reads as empty forever (libserialport turns EOF into "no
    // data yet"); the hang-up shows in poll(). That is an unplug: end the stream.
    int fd = -1;
    if (sp_get_port_handle(port_, &fd) == SP_OK && fd >= 0) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL))) {
        r.end = true;
        r.end_reason = "serial " + name_ + ": hang-up (device unplugged)";
      }
    }
  } else {
    // A USB-serial adapter pulled out: the read fails (EIO). End of stream, with the reason.
    r.end = true;
    r.end_reason = sp_message("serial " + name_ + ": read failed (device unplugged?)",
                              static_cast<sp_return>(n));
  }
  return r;
}

void SerialTransport::write(std::span<const uint8_t> bytes) {
  const int n = sp_blocking_write(port_, bytes.data(), bytes.size(), 1000);
  if (n < 0)
    throw TransportError(sp_message("serial " + name_ + ": write", static_cast<sp_return>(n)));
  if (static_cast<std::size_t>(n) != bytes.size()) {
    throw TransportError("serial " + name_ + ": write timed out after " + std::to_string(n) +
                         " of " + std::to_string(bytes.size()) + " bytes");
  }
}

}  // namespace imukit::drivers
