// HidTransport: a HID device through hidapi (hidraw backend on Linux), owning the handle:
// input reports with a timeout, output reports, feature reports in both directions. A read that
// fails (hid_read_timeout returns -1, e.g. the device was unplugged) ends the stream with
// hidapi's message.
#pragma once

#include <cstdint>
#include <string>

#include "imukit/drivers/transport.hpp"

struct hid_device_;

namespace imukit::drivers {

class HidTransport : public ReportTransport {
 public:
  // The first device with this VID/PID (and serial number, when not empty).
  HidTransport(uint16_t vid, uint16_t pid, const std::string& serial = "");
  // A device by its hidraw path.
  explicit HidTransport(const std::string& path);
  ~HidTransport() override;

  ReadResult read_report(std::span<uint8_t> buf, int timeout_ms) override;
  void write_report(std::span<const uint8_t> report) override;
  std::vector<uint8_t> get_feature_report(uint8_t id, std::size_t size) override;
  void send_feature_report(std::span<const uint8_t> report) override;
  std::string describe() const override { return name_; }

 private:
  std::string error(const std::string& what) const;
  std::string name_;
  hid_device_* dev_ = nullptr;
};

// hidapi's wide strings (serial number, manufacturer, error text) as ASCII, '?' for the rest;
// "" for a null pointer.
std::string hid_ascii(const wchar_t* text);

}  // namespace imukit::drivers
