// Device URIs: `scheme:address?key=value&key=value` names a transport, its address and the codec
// with its options (docs/devices.md lists every scheme and key):
//   serial:/dev/ttyUSB0?baud=921600&codec=witmotion     hid:054c:09cc     hid:/dev/hidraw3
//   usb:2639:0300?codec=xsens&ep_in=0x81&ep_out=0x01     file:capture.bin?codec=xsens
//   fd:0?codec=text&time_unit=ms                         mock:static?rate=400&clock=virtual
// The address and the values are percent-decoded (%26 is '&', %25 is '%'), so a path with any
// byte can be given; percent_encode() writes one.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/drivers/codec.hpp"
#include "imukit/drivers/transport.hpp"

namespace imukit::drivers {

struct DeviceUri {
  std::string text;  // as given
  std::string scheme;
  std::string address;
  std::map<std::string, std::string> keys;
};

// Parses and checks a URI: known scheme, non-empty address, key=value pairs without repeats,
// every key known for the scheme. Throws imukit::Error whose location is "device URI" with the
// byte offset of the problem.
DeviceUri parse_device_uri(const std::string& text);

// The codec a URI names without opening anything: imukit for a mock, its codec= otherwise;
// empty where only the device would tell (a known USB id, docs/devices.md).
std::string codec_named_by(const DeviceUri& uri);

// Whether the device of `uri` is sent commands: not for file:, an fd: open read-only or
// commands=false, where the codec only decodes and only codec_keys(codec, true) do something.
bool sends_commands(const DeviceUri& uri);

// A transport and the codec that reads it, ready for a DeviceReader.
struct OpenedDevice {
  std::unique_ptr<Transport> transport;
  std::unique_ptr<Codec> codec;
};

// Opens what the URI names. The codec comes from `codec=`, else from the known VID/PID table
// (devices.hpp), else it is an error that says to name one. A key that neither the transport,
// the mock nor the codec reads (codec_keys(), codecs.hpp) is an error naming the key, its byte
// and the keys accepted, checked before anything is opened. Throws imukit::Error (bad URI or
// option) or TransportError (the OS refused, with its message).
OpenedDevice open_device(const std::string& uri);

// `text` with every byte but letters, digits and - . _ ~ / written as %XX: safe as a URI's
// address or value.
std::string percent_encode(std::string_view text);

// "a, b, c" of the keys a scheme accepts (for messages and docs).
std::vector<std::string> uri_keys(const std::string& scheme);

}  // namespace imukit::drivers
