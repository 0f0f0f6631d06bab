// Enumeration of attached devices and the table of devices imukit knows by USB VID/PID, so
// `imukit devices` can say which codec would read each port or HID device.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace imukit::drivers {

struct KnownDevice {
  uint16_t vid;
  uint16_t pid;
  const char* codec;  // make_codec() name (drivers/codecs.hpp)
  const char* name;
  bool hid;  // HID device (else a serial port)
};

// Sony DualShock 4 (two revisions) and DualSense over USB, Xsens MTi USB devices and the Xsens
// USB-serial converter. WitMotion boards use generic CH340/CP210x converters, which say
// nothing about what is behind them; they are listed with codec "?" and need codec=witmotion.
const std::vector<KnownDevice>& known_devices();
std::optional<KnownDevice> find_known_device(uint16_t vid, uint16_t pid, bool hid);

struct AttachedDevice {
  std::string uri;   // what to pass to open_device (codec key added when known)
  std::string kind;  // "serial" or "hid"
  std::string path;  // /dev/ttyUSB0, /dev/hidraw3
  uint16_t vid = 0;
  uint16_t pid = 0;
  bool usb = false;         // VID/PID known (USB)
  std::string serial;       // USB serial number, if any
  std::string description;  // product string / port description
  std::string codec;        // codec that would read it, "" if unknown
  uint16_t usage_page = 0;  // HID only
};

// Serial ports via libserialport (VID/PID and serial number for USB ports).
std::vector<AttachedDevice> list_serial_ports();
// HID devices via hidapi (hidraw backend), one entry per interface.
std::vector<AttachedDevice> list_hid_devices();

}  // namespace imukit::drivers
