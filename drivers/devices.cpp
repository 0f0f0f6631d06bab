#include "imukit/drivers/devices.hpp"

#include <hidapi/hidapi.h>
#include <libserialport.h>

#include <cstdio>
#include <mutex>

#include "imukit/drivers/hid_transport.hpp"

namespace imukit::drivers {

const std::vector<KnownDevice>& known_devices() {
  // Sony IDs: Linux hid-ids.h (USB_DEVICE_ID_SONY_PS4_CONTROLLER, _2, PS5_CONTROLLER).
  // Xsens IDs: Linux drivers/usb/serial/xsens_mt.c and ftdi_sio_ids.h.
  static const std::vector<KnownDevice> table = {
      {0x054c, 0x05c4, "dualshock4", "Sony DualShock 4 (CUH-ZCT1)", true},
      {0x054c, 0x09cc, "dualshock4", "Sony DualShock 4 (CUH-ZCT2)", true},
      {0x054c, 0x0ce6, "dualsense", "Sony DualSense", true},
      {0x2639, 0x0001, "xsens", "Xsens MTi-10 IMU", false},
      {0x2639, 0x0002, "xsens", "Xsens MTi-20 VRU", false},
      {0x2639, 0x0003, "xsens", "Xsens MTi-30 AHRS", false},
      {0x2639, 0x0011, "xsens", "Xsens MTi-100 IMU", false},
      {0x2639, 0x0012, "xsens", "Xsens MTi-200 VRU", false},
      {0x2639, 0x0013, "xsens", "Xsens MTi-300 AHRS", false},
      {0x2639, 0x0017, "xsens", "Xsens MTi-G-700 GPS/INS", false},
      {0x2639, 0xd00d, "xsens", "Xsens USB-serial converter", false},
      {0x0403, 0xd388, "xsens", "Xsens USB converter (FTDI)", false},
      {0x0403, 0xd38b, "xsens", "Xsens USB-serial converter (FTDI)", false},
      // Generic converters WitMotion boards ship with: the codec cannot be known.
      {0x1a86, 0x7523, "", "CH340 USB-serial (WitMotion boards use it: codec=witmotion)", false},
      {0x10c4, 0xea60, "", "CP210x USB-serial (WitMotion boards use it: codec=witmotion)", false},
  };
  return table;
}

std::optional<KnownDevice> find_known_device(uint16_t vid, uint16_t pid, bool hid) {
  for (const KnownDevice& d : known_devices()) {
    if (d.vid == vid && d.pid == pid && d.hid == hid) return d;
  }
  return std::nullopt;
}

namespace {

std::string hex4(uint16_t v) {
  char b[8];
  std::snprintf(b, sizeof b, "%04x", v);
  return b;
}

}  // namespace

std::vector<AttachedDevice> list_serial_ports() {
  std::vector<AttachedDevice> out;
  sp_port** ports = nullptr;
  if (sp_list_ports(&ports) != SP_OK) return out;
  for (sp_port** p = ports; *p; ++p) {
    AttachedDevice d;
    d.kind = "serial";
    d.path = sp_get_port_name(*p);
    if (const char* desc = sp_get_port_description(*p)) d.description = desc;
    if (sp_get_port_transport(*p) == SP_TRANSPORT_USB) {
      int vid = 0, pid = 0;
      if (sp_get_port_usb_vid_pid(*p, &vid, &pid) == SP_OK) {
        d.usb = true;
        d.vid = static_cast<uint16_t>(vid);
        d.pid = static_cast<uint16_t>(pid);
      }
      if (const char* sn = sp_get_port_usb_serial(*p)) d.serial = sn;
    }
    d.uri = "serial:" + d.path;
    if (d.usb) {
      if (auto k = find_known_device(d.vid, d.pid, false)) {
        d.codec = k->codec;
        if (d.description.empty()) d.description = k->name;
        if (!d.codec.empty())
          d.uri += "?codec=" + d.codec;
        else
          d.description += std::string(" [") + k->name + "]";
      }
    }
    out.push_back(std::move(d));
  }
  sp_free_port_list(ports);
  return out;
}

std::vector<AttachedDevice> list_hid_devices() {
  std::vector<AttachedDevice> out;
  static std::once_flag init;
  std::call_once(init, [] { hid_init(); });
  hid_device_info* all = hid_enumerate(0, 0);
  for (hid_device_info* i = all; i; i = i->next) {
    AttachedDevice d;
    d.kind = "hid";
    d.path = i->path ? i->path : "";
    d.vid = i->vendor_id;
    d.pid = i->product_id;
    d.usb = true;
    d.serial = hid_ascii(i->serial_number);
    d.description = hid_ascii(i->manufacturer_string);
    const std::string product = hid_ascii(i->product_string);
    if (!product.empty()) d.description += (d.description.empty() ? "" : " ") + product;
    d.usage_page = i->usage_page;
    d.uri = "hid:" + hex4(d.vid) + ":" + hex4(d.pid);
    if (auto k = find_known_device(d.vid, d.pid, true)) {
      d.codec = k->codec;
      if (d.description.empty()) d.description = k->name;
    }
    out.push_back(std::move(d));
  }
  hid_free_enumeration(all);
  return out;
}

}  // namespace imukit::drivers
