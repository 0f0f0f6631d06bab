#include "imukit/drivers/usb_transport.hpp"

#include <libusb-1.0/libusb.h>

#include <cstdio>

namespace imukit::drivers {
namespace {
std::string usb_error(const std::string& what, int code) {
  return what + ": " + libusb_strerror(static_cast<libusb_error>(code));
}
}  // namespace

UsbBulkTransport::UsbBulkTransport(uint16_t vid, uint16_t pid, int interface, uint8_t endpoint_in,
                                   uint8_t endpoint_out)
    : interface_(interface), ep_in_(endpoint_in), ep_out_(endpoint_out) {
  char id[16];
  std::snprintf(id, sizeof id, "%04x:%04x", vid, pid);
  name_ = std::string("usb ") + id + " interface " + std::to_string(interface);
  if (const int rc = libusb_init(&ctx_); rc != 0)
    throw TransportError(usb_error("libusb_init", rc));
  handle_ = libusb_open_device_with_vid_pid(ctx_, vid, pid);
  if (!handle_) {
    libusb_exit(ctx_);
    throw TransportError("cannot open " + name_ +
                         ": not attached, or no permission (see packaging/udev)");
  }
  libusb_set_auto_detach_kernel_driver(handle_, 1);
  if (const int rc = libusb_claim_interface(handle_, interface_); rc != 0) {
    libusb_close(handle_);
    libusb_exit(ctx_);
    throw TransportError(usb_error("cannot claim " + name_, rc));
  }
}

UsbBulkTransport::~UsbBulkTransport() {
  libusb_release_interface(handle_, interface_);
  libusb_close(handle_);
  libusb_exit(ctx_);
}

ReadResult UsbBulkTransport::read(std::span<uint8_t> buf, int timeout_ms) {
  ReadResult r;
  int got = 0;
  const int rc = libusb_bulk_transfer(handle_, ep_in_, buf.data(), static_cast<int>(buf.size()),
                                      &got, static_cast<unsigned>(timeout_ms));
  r.host_time = host_now();
  r.size = got > 0 ? static_cast<std::size_t>(got) : 0;
  if (rc == 0 || rc == LIBUSB_ERROR_TIMEOUT) return r;
  // Any other failure (NO_DEVICE when unplugged, IO, PIPE) ends the stream with its reason.
  r.end = true;
  r.end_reason = usb_error(name_ + ": read", rc);
  return r;
}

void UsbBulkTransport::write(std::span<const uint8_t> bytes) {
  int done = 0;
  const int rc = libusb_bulk_transfer(handle_, ep_out_, const_cast<uint8_t*>(bytes.data()),
                                      static_cast<int>(bytes.size()), &done, 1000);
  if (rc != 0) throw TransportError(usb_error(name_ + ": write", rc));
  if (static_cast<std::size_t>(done) != bytes.size()) throw TransportError(name_ + ": short write");
}

}  // namespace imukit::drivers
