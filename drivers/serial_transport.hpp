// SerialTransport: a serial port through libserialport (8 data bits, no parity, 1 stop bit, no
// flow control unless asked), owning the port handle. Errors keep libserialport's message,
// which carries the OS error text.
#pragma once

#include "imukit/drivers/transport.hpp"

struct sp_port;

namespace imukit::drivers {

class SerialTransport : public ByteTransport {
 public:
  // Opens `port` (e.g. /dev/ttyUSB0) at `baud`. Throws TransportError.
  SerialTransport(const std::string& port, int baud, bool rtscts = false);
  ~SerialTransport() override;

  ReadResult read(std::span<uint8_t> buf, int timeout_ms) override;
  void write(std::span<const uint8_t> bytes) override;
  std::string describe() const override;
  std::string when_silent() const override { return "check the baud rate and codec in the URI"; }
  bool may_start_mid_stream() const override { return true; }
  int baud() const;

 private:
  std::string name_;
  int baud_;
  sp_port* port_ = nullptr;
};

}  // namespace imukit::drivers
