#include "imukit/drivers/hid_transport.hpp"

#include <hidapi/hidapi.h>

#include <cstdio>
#include <filesystem>
#include <mutex>

namespace imukit::drivers {
namespace {

void init_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (hid_init() != 0) throw TransportError("hidapi: hid_init failed");
  });
}

}  // namespace

std::string hid_ascii(const wchar_t* text) {
  std::string s;
  if (!text) return s;
  for (; *text; ++text) s.push_back(*text < 128 ? static_cast<char>(*text) : '?');
  return s;
}

HidTransport::HidTransport(uint16_t vid, uint16_t pid, const std::string& serial) {
  init_once();
  char id[16];
  std::snprintf(id, sizeof id, "%04x:%04x", vid, pid);
  name_ = std::string("hid ") + id;
  // Enumerate everything and pick by VID/PID (and serial) ourselves, then open by path: the same
  // as hid_open(), and it also works where hidapi's filtered enumeration finds nothing (umockdev).
  std::string path;
  hid_device_info* all = hid_enumerate(0, 0);
  for (hid_device_info* i = all; i && path.empty(); i = i->next) {
    if (i->vendor_id == vid && i->product_id == pid && i->path &&
        (serial.empty() || hid_ascii(i->serial_number) == serial)) {
      path = i->path;
    }
  }
  hid_free_enumeration(all);
  if (path.empty()) {
    throw TransportError("cannot open " + name_ + (serial.empty() ? "" : " serial " + serial) +
                         ": no such HID device attached (`imukit devices` lists them)");
  }
  dev_ = hid_open_path(path.c_str());
  if (!dev_) {
    throw TransportError(
        error("cannot open " + name_ + " at " + path + " (permission? see packaging/udev)"));
  }
  name_ += " (" + path + ")";
}

HidTransport::HidTransport(const std::string& path) : name_("hid " + path) {
  init_once();
  // hidapi 0.13 (Debian 12) frees a wild pointer when the node has no HID uevent: a serial port,
  // /dev/null or a capture file given to hid: crashed the process (review, 2026-11-27; fixed
  // upstream in 0.14). Only hidraw nodes, known to sysfs, reach it.
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw TransportError("cannot open " + name_ +
                         ": no such device (unplugged? `imukit devices` "
                         "lists them)");
  }
  const std::filesystem::path real = std::filesystem::canonical(path, ec);
  const std::string node = (ec ? std::filesystem::path(path) : real).filename().string();
  if (node.rfind("hidraw", 0) != 0 || !std::filesystem::exists("/sys/class/hidraw/" + node, ec)) {
    throw TransportError("cannot open " + name_ +
                         ": not a hidraw device (/dev/hidrawN: `imukit devices` lists them)");
  }
  dev_ = hid_open_path(path.c_str());
  if (!dev_)
    throw TransportError(
        error("cannot open " + name_ + " (attached? permission: see packaging/udev)"));
}

HidTransport::~HidTransport() {
  if (dev_) hid_close(dev_);
}

std::string HidTransport::error(const std::string& what) const {
  const std::string msg = hid_ascii(hid_error(dev_));
  return what + (msg.empty() ? std::string() : ": " + msg);
}

ReadResult HidTransport::read_report(std::span<uint8_t> buf, int timeout_ms) {
  ReadResult r;
  const int n = hid_read_timeout(dev_, buf.data(), buf.size(), timeout_ms);
  r.host_time = host_now();
  if (n > 0) {
    r.size = static_cast<std::size_t>(n);
  } else if (n < 0) {
    r.end = true;
    r.end_reason = error(name_ + ": read failed (device unplugged?)");
  }
  return r;
}

void HidTransport::write_report(std::span<const uint8_t> report) {
  if (hid_write(dev_, report.data(), report.size()) < 0)
    throw TransportError(error(name_ + ": write"));
}

std::vector<uint8_t> HidTransport::get_feature_report(uint8_t id, std::size_t size) {
  std::vector<uint8_t> buf(size < 2 ? 2 : size);
  buf[0] = id;
  const int n = hid_get_feature_report(dev_, buf.data(), buf.size());
  if (n < 0) throw TransportError(error(name_ + ": get feature report " + std::to_string(id)));
  buf.resize(static_cast<std::size_t>(n));
  return buf;
}

void HidTransport::send_feature_report(std::span<const uint8_t> report) {
  if (hid_send_feature_report(dev_, report.data(), report.size()) < 0) {
    throw TransportError(error(name_ + ": send feature report"));
  }
}

}  // namespace imukit::drivers
