#include "imukit/drivers/uri.hpp"

#include <fcntl.h>
#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>

#include "imukit/core/error.hpp"
#include "imukit/drivers/codecs.hpp"
#include "imukit/drivers/devices.hpp"
#include "imukit/drivers/hid_transport.hpp"
#include "imukit/drivers/mock_device.hpp"
#include "imukit/drivers/serial_transport.hpp"
#include "imukit/drivers/usb_transport.hpp"

namespace imukit::drivers {
namespace {

const std::vector<std::string> kCodecKeys = {
    "codec",         "rate",           "commands",  "block",     "ping_s",     "mag_rate",
    "accel_range_g", "gyro_range_dps", "time_unit", "time_bits", "accel_unit", "gyro_unit"};

// The keys each mock reads (make_mock_device); its codec, imukit, reads its own besides.
const std::vector<std::string> kMockKeys = {
    "rate",     "seed",       "profile",          "drop",
    "flip",     "drift_ppm",  "latency_us",       "jitter_us",
    "stall_ms", "stall_at_s", "disconnect_after", "clock",
    "gravity"};
const std::vector<std::string> kMockStaticKeys = {"quat"};
const std::vector<std::string> kMockPosesKeys = {"hold_s", "move_s", "init_s", "poses"};

std::vector<std::string> transport_keys(const std::string& scheme) {
  if (scheme == "serial") return {"baud", "flow"};
  if (scheme == "hid") return {"serial"};
  if (scheme == "usb") return {"interface", "ep_in", "ep_out"};
  return {};
}

const std::vector<std::string> kSchemes = {"serial", "hid", "usb", "file", "fd", "mock"};

[[noreturn]] void fail(const std::string& uri, std::size_t offset, const std::string& what) {
  InputLocation where;
  where.file = "device URI '" + uri + "'";
  where.byte_offset = static_cast<int64_t>(offset);
  throw Error(where, what);
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// The address or a value with its %XX escapes decoded; `offset` is where `s` starts in `uri`.
std::string percent_decode(const std::string& uri, std::size_t offset, const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '%') {
      out += s[i];
      continue;
    }
    const bool room = i + 2 < s.size();
    const int hi = room ? hex_digit(s[i + 1]) : -1;
    const int lo = room ? hex_digit(s[i + 2]) : -1;
    if (hi < 0 || lo < 0)
      fail(uri, offset + i, "'%' must be followed by two hex digits (%25 is '%' itself)");
    // A NUL would end the path the OS sees early (found in review: it opened a shorter path).
    if (hi == 0 && lo == 0) fail(uri, offset + i, "%00 (a NUL byte) cannot be part of a URI");
    out += static_cast<char>(hi * 16 + lo);
    i += 2;
  }
  return out;
}

// "054c:09cc" -> vid, pid; false if not two 1..4-digit hex numbers.
bool parse_vid_pid(const std::string& s, uint16_t& vid, uint16_t& pid) {
  const std::size_t colon = s.find(':');
  if (colon == std::string::npos || colon == 0 || colon > 4 || s.size() - colon - 1 == 0 ||
      s.size() - colon - 1 > 4) {
    return false;
  }
  unsigned v = 0, p = 0;
  auto a = std::from_chars(s.data(), s.data() + colon, v, 16);
  auto b = std::from_chars(s.data() + colon + 1, s.data() + s.size(), p, 16);
  if (a.ec != std::errc() || a.ptr != s.data() + colon || b.ec != std::errc() ||
      b.ptr != s.data() + s.size()) {
    return false;
  }
  vid = static_cast<uint16_t>(v);
  pid = static_cast<uint16_t>(p);
  return true;
}

// An endpoint address of the direction `key` names: libusb takes a transfer's direction from
// bit 7, so ep_in=0x02 sent the read buffer to the device (review, 2026-11-27).
uint8_t parse_endpoint(const std::map<std::string, std::string>& keys, const std::string& key,
                       uint8_t fallback) {
  const auto it = keys.find(key);
  if (it == keys.end()) return fallback;
  const std::string& t = it->second;
  unsigned v = 0;
  const bool hex = t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X');
  const char* b = t.data() + (hex ? 2 : 0);
  const auto r = std::from_chars(b, t.data() + t.size(), v, hex ? 16 : 10);
  if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size() || v > 0xFF) {
    throw Error(key + "=" + t + ": expected an endpoint address such as 0x81");
  }
  const bool in = key == "ep_in";
  if (((v & 0x80) != 0) != in) {
    throw Error(fmt::format("{}={}: an {} endpoint's address has bit 7 {} (such as {})", key, t,
                            in ? "IN" : "OUT", in ? "set" : "clear", in ? "0x81" : "0x01"));
  }
  return static_cast<uint8_t>(v);
}

std::string codec_for(const DeviceUri& u, std::optional<KnownDevice> known) {
  if (std::string named = codec_named_by(u); !named.empty()) return named;
  if (known && *known->codec) return known->codec;
  std::string names;
  for (const auto& n : codec_names()) names += (names.empty() ? "" : ", ") + n;
  throw Error("device URI '" + u.text + "': no codec known for this device; add codec=NAME (" +
              names + ")");
}

std::string joined(const std::vector<std::string>& items) {
  std::string list;
  for (const auto& k : items) list += (list.empty() ? "" : ", ") + k;
  return list;
}

// Every key of the URI must be read by its transport, its mock or its codec: a key that would
// do nothing (a mock:poses key on mock:static, a text codec's key on an Xsens replay) is refused,
// never silently ignored (found in review: `mock:static?poses=3` recorded a static device).
void check_keys_are_used(const DeviceUri& u, const std::string& codec) {
  const std::vector<std::string> names = codec_names();
  if (std::find(names.begin(), names.end(), codec) == names.end()) return;  // make_codec says so
  const bool decode_only = !sends_commands(u);
  std::vector<std::string> accepted{"codec"};
  std::string what;
  if (u.scheme == "mock") {
    const auto& own = u.address == "poses" ? kMockPosesKeys : kMockStaticKeys;
    accepted.insert(accepted.end(), kMockKeys.begin(), kMockKeys.end());
    accepted.insert(accepted.end(), own.begin(), own.end());
    what =
        "mock:" + u.address + (decode_only ? " (imukit codec, decoding only)" : " (imukit codec)");
  } else {
    const std::vector<std::string> t = transport_keys(u.scheme);
    accepted.insert(accepted.end(), t.begin(), t.end());
    what = u.scheme + ": with codec " + codec + (decode_only ? ", decoding only" : "");
  }
  for (const auto& k : codec_keys(codec, decode_only)) {
    if (std::find(accepted.begin(), accepted.end(), k) == accepted.end()) accepted.push_back(k);
  }
  for (const auto& [key, value] : u.keys) {
    if (std::find(accepted.begin(), accepted.end(), key) != accepted.end()) continue;
    // Searched in the query only: an address may hold "&key=" too (found in review, 2026-11-27).
    const std::size_t query = u.text.find('?');
    std::size_t at =
        u.text.find("?" + key + "=", query == std::string::npos ? u.text.size() : query);
    if (at == std::string::npos && query != std::string::npos)
      at = u.text.find("&" + key + "=", query);
    fail(u.text, at == std::string::npos ? 0 : at + 1,
         "key '" + key + "' does nothing for " + what + " (keys it accepts: " + joined(accepted) +
             ")");
  }
}

}  // namespace

bool sends_commands(const DeviceUri& uri) {
  if (uri.scheme == "file") return false;
  if (uri.scheme == "fd") {
    // A descriptor that is not open sends nothing either; open_device says it is not open.
    int fd = -1;
    const auto r = std::from_chars(uri.address.data(), uri.address.data() + uri.address.size(), fd);
    const int flags = r.ec == std::errc() ? fcntl(fd, F_GETFL) : -1;
    if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY) return false;
  }
  try {
    return option_bool(uri.keys, "commands", true);
  } catch (const Error&) {
    return true;  // not a boolean: make_codec refuses it, naming the key
  }
}

std::string codec_named_by(const DeviceUri& uri) {
  if (uri.scheme == "mock") return "imukit";
  const auto it = uri.keys.find("codec");
  return it != uri.keys.end() ? it->second : std::string();
}

std::string percent_encode(std::string_view text) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : text) {
    const auto b = static_cast<unsigned char>(c);
    const bool plain =
        std::isalnum(b) != 0 || c == '-' || c == '.' || c == '_' || c == '~' || c == '/';
    if (plain) {
      out += c;
    } else {
      out += '%';
      out += kHex[b >> 4];
      out += kHex[b & 15];
    }
  }
  return out;
}

std::vector<std::string> uri_keys(const std::string& scheme) {
  std::vector<std::string> keys = kCodecKeys;
  const std::vector<std::string> t = transport_keys(scheme);
  keys.insert(keys.end(), t.begin(), t.end());
  if (scheme == "mock") {
    for (const auto* list : {&kMockKeys, &kMockStaticKeys, &kMockPosesKeys}) {
      for (const auto& k : *list) {
        if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
      }
    }
  }
  return keys;
}

DeviceUri parse_device_uri(const std::string& text) {
  DeviceUri u;
  u.text = text;
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || colon == 0) {
    fail(text, 0, "expected SCHEME:ADDRESS, e.g. serial:/dev/ttyUSB0 or mock:static");
  }
  u.scheme = text.substr(0, colon);
  if (std::find(kSchemes.begin(), kSchemes.end(), u.scheme) == kSchemes.end()) {
    fail(text, 0, "unknown scheme '" + u.scheme + "' (known: serial, hid, usb, file, fd, mock)");
  }
  const std::size_t q = text.find('?', colon + 1);
  u.address = percent_decode(
      text, colon + 1,
      text.substr(colon + 1, (q == std::string::npos ? text.size() : q) - colon - 1));
  if (u.address.empty()) fail(text, colon + 1, "missing address after '" + u.scheme + ":'");
  if (q != std::string::npos) {
    const std::vector<std::string> known = uri_keys(u.scheme);
    std::size_t pos = q + 1;
    while (pos <= text.size()) {
      std::size_t amp = text.find('&', pos);
      if (amp == std::string::npos) amp = text.size();
      const std::string pair = text.substr(pos, amp - pos);
      const std::size_t eq = pair.find('=');
      if (pair.empty() || eq == std::string::npos || eq == 0) {
        fail(text, pos, "expected key=value, got '" + pair + "'");
      }
      const std::string key = pair.substr(0, eq);
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        fail(text, pos, "unknown key '" + key + "' for " + u.scheme + ": (known: " + list + ")");
      }
      if (!u.keys.emplace(key, percent_decode(text, pos + eq + 1, pair.substr(eq + 1))).second)
        fail(text, pos, "key '" + key + "' given twice");
      if (amp == text.size()) break;
      pos = amp + 1;
    }
  }
  if (u.scheme == "hid" && u.address[0] != '/') {
    uint16_t v, p;
    if (!parse_vid_pid(u.address, v, p)) {
      fail(text, colon + 1, "expected VID:PID in hex (e.g. 054c:09cc) or a /dev/hidraw path");
    }
  }
  if (u.scheme == "usb") {
    uint16_t v, p;
    if (!parse_vid_pid(u.address, v, p))
      fail(text, colon + 1, "expected VID:PID in hex, e.g. 2639:0013");
  }
  return u;
}

OpenedDevice open_device(const std::string& text) {
  const DeviceUri u = parse_device_uri(text);
  OpenedDevice d;
  auto with_context = [&](auto&& f) {
    try {
      return f();
    } catch (const TransportError&) {
      throw;
    } catch (const Error& e) {
      if (e.where()) throw;
      const std::string prefix = "device URI '" + text + "'";
      if (e.reason().rfind(prefix, 0) == 0) throw;  // already says which URI
      throw Error(prefix + ": " + e.reason());
    }
  };
  with_context([&] {
    if (u.scheme == "mock") {
      if (u.keys.count("codec") && u.keys.at("codec") != "imukit") {
        throw Error("mock devices speak the imukit protocol: codec must be imukit");
      }
      if (u.address == "static" || u.address == "poses") check_keys_are_used(u, "imukit");
      d.transport = make_mock_device(u.address, u.keys);
      CodecOptions o = u.keys;
      o.erase("codec");
      if (!o.count("rate")) o["rate"] = "400";
      d.codec = make_codec("imukit", o);
    } else if (u.scheme == "file") {
      const std::string codec = codec_for(u, std::nullopt);
      check_keys_are_used(u, codec);
      CodecOptions o = u.keys;
      if (option_bool(o, "commands", false))
        throw Error("file: is a replay, so commands cannot be sent: remove commands=true");
      o["commands"] = "false";
      d.codec = make_codec(codec, o);
      d.transport = FdTransport::open_file(u.address);
    } else if (u.scheme == "fd") {
      int fd = -1;
      const auto r = std::from_chars(u.address.data(), u.address.data() + u.address.size(), fd);
      if (r.ec != std::errc() || r.ptr != u.address.data() + u.address.size() || fd < 0) {
        throw Error("fd:" + u.address + ": expected a file descriptor number");
      }
      const int flags = fcntl(fd, F_GETFL);
      if (flags < 0) throw TransportError(os_error("fd " + u.address, errno));
      // FdTransport takes a regular file for a replay, never written, even when opened
      // read-write (`3<>`: commands overwrote the recorded bytes until review, 2026-11-27).
      const bool read_only = (flags & O_ACCMODE) == O_RDONLY;
      auto transport = std::make_unique<FdTransport>(fd, false, "fd " + u.address, !read_only);
      const bool writable = transport->can_write();
      const std::string codec = codec_for(u, std::nullopt);
      check_keys_are_used(u, codec);
      CodecOptions o = u.keys;
      if (!writable) {
        // Nothing can reach the device through a read-only descriptor (a pipe, a file on
        // stdin): the codec decodes what comes, as for file:, instead of waiting for answers to
        // commands it could not send.
        if (option_bool(o, "commands", false))
          throw Error("fd " + u.address +
                      (read_only ? " is open read-only," : " is a regular file, a replay,") +
                      " so commands cannot be sent: remove commands=true");
        o["commands"] = "false";
      }
      d.codec = make_codec(codec, o);
      d.transport = std::move(transport);
    } else if (u.scheme == "serial") {
      const int64_t baud = option_int(u.keys, "baud", 115200);
      if (baud <= 0 || baud > 20'000'000) throw Error("baud: expected a positive baud rate");
      const std::string flow = option_string(u.keys, "flow", "none");
      if (flow != "none" && flow != "rtscts")
        throw Error("flow=" + flow + ": expected none or rtscts");
      std::optional<KnownDevice> known;
      for (const AttachedDevice& a : list_serial_ports()) {
        if (a.path == u.address && a.usb) known = find_known_device(a.vid, a.pid, false);
      }
      const std::string codec = codec_for(u, known);
      check_keys_are_used(u, codec);
      d.codec = make_codec(codec, u.keys);
      d.transport =
          std::make_unique<SerialTransport>(u.address, static_cast<int>(baud), flow == "rtscts");
    } else if (u.scheme == "hid") {
      std::optional<KnownDevice> known;
      uint16_t vid = 0, pid = 0;
      if (u.address[0] == '/') {
        // A path names one device: a serial number would choose nothing (it was ignored).
        if (u.keys.count("serial"))
          throw Error("serial: chooses among the devices of a VID:PID; " + u.address +
                      " names one already: remove serial=");
        for (const AttachedDevice& a : list_hid_devices()) {
          if (a.path == u.address) known = find_known_device(a.vid, a.pid, true);
        }
      } else {
        parse_vid_pid(u.address, vid, pid);
        known = find_known_device(vid, pid, true);
      }
      const std::string codec = codec_for(u, known);
      check_keys_are_used(u, codec);
      d.codec = make_codec(codec, u.keys);
      if (!d.codec->report_based())
        throw Error("codec " + d.codec->name() + " reads byte streams, not HID reports");
      if (u.address[0] == '/') {
        d.transport = std::make_unique<HidTransport>(u.address);
      } else {
        d.transport = std::make_unique<HidTransport>(vid, pid, option_string(u.keys, "serial", ""));
      }
    } else {  // usb
      uint16_t vid = 0, pid = 0;
      parse_vid_pid(u.address, vid, pid);
      const std::string codec = codec_for(u, find_known_device(vid, pid, false));
      check_keys_are_used(u, codec);
      d.codec = make_codec(codec, u.keys);
      // Before the interface is claimed, which detaches a pad's kernel HID driver.
      if (d.codec->report_based())
        throw Error("codec " + d.codec->name() + " reads HID reports: use a hid: URI");
      const int64_t iface = option_int(u.keys, "interface", 0);
      if (iface < 0 || iface > 255) throw Error("interface: expected 0..255");
      d.transport = std::make_unique<UsbBulkTransport>(vid, pid, static_cast<int>(iface),
                                                       parse_endpoint(u.keys, "ep_in", 0x81),
                                                       parse_endpoint(u.keys, "ep_out", 0x01));
    }
    if (d.codec->report_based() && !dynamic_cast<ReportTransport*>(d.transport.get())) {
      throw Error("codec " + d.codec->name() + " reads HID reports: use a hid: URI");
    }
    return 0;
  });
  return d;
}

}  // namespace imukit::drivers
