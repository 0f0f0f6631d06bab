// UsbBulkTransport: a pair of USB bulk endpoints through libusb (for devices that stream over a
// vendor interface, e.g. Xsens MTi over native USB), owning the context, handle and claimed
// interface. A transfer that fails with LIBUSB_ERROR_NO_DEVICE (unplugged) ends the stream.
#pragma once

#include <cstdint>

#include "imukit/drivers/transport.hpp"

struct libusb_context;
struct libusb_device_handle;

namespace imukit::drivers {

class UsbBulkTransport : public ByteTransport {
 public:
  // Opens the first device with vid:pid, detaches a kernel driver if one is bound, claims the
  // interface. Throws TransportError with libusb's message.
  UsbBulkTransport(uint16_t vid, uint16_t pid, int interface, uint8_t endpoint_in,
                   uint8_t endpoint_out);
  ~UsbBulkTransport() override;

  ReadResult read(std::span<uint8_t> buf, int timeout_ms) override;
  void write(std::span<const uint8_t> bytes) override;
  std::string describe() const override { return name_; }

 private:
  std::string name_;
  libusb_context* ctx_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  int interface_;
  uint8_t ep_in_;
  uint8_t ep_out_;
};

}  // namespace imukit::drivers
