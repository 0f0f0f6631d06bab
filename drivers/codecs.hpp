// The codecs imukit knows, by name: the factory the device URIs (drivers/uri.hpp) and tools use.
// A new codec is registered here (docs/adding_a_codec.md); codec.hpp keeps only the interface.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

// The codec called `name` (imukit, xsens, witmotion, dualshock4, dualsense, text) configured
// from options. Throws imukit::Error for an unknown name or a bad option value, naming both.
std::unique_ptr<Codec> make_codec(const std::string& name, const CodecOptions& options);

// Names make_codec() knows, for help texts.
std::vector<std::string> codec_names();

// The URI keys codec `name` reads (besides `codec` itself), so that a key it would not read is
// refused instead of silently doing nothing (docs/devices.md). Empty for an unknown name.
// `decode_only` (a replay, a read-only fd, commands=false: nothing is sent to the device) leaves
// only the keys that change the decoding: one that would configure the device does nothing then
// (found in review: rate= on an Xsens replay was accepted and ignored, and `record --rate` added
// it).
std::vector<std::string> codec_keys(const std::string& name, bool decode_only = false);

}  // namespace imukit::drivers
