#include "imukit/drivers/codecs.hpp"

#include <cmath>

#include "imukit/core/error.hpp"
#include "imukit/drivers/imukit_codec.hpp"
#include "imukit/drivers/playstation_codec.hpp"
#include "imukit/drivers/text_codec.hpp"
#include "imukit/drivers/witmotion_codec.hpp"
#include "imukit/drivers/xsens_codec.hpp"

namespace imukit::drivers {

std::vector<std::string> codec_names() {
  return {"imukit", "xsens", "witmotion", "dualshock4", "dualsense", "text"};
}

std::vector<std::string> codec_keys(const std::string& name, bool decode_only) {
  // Decoding only, imukit's and WitMotion's rate= is the rate the stream was made at, which
  // times its samples; an Xsens stream is timed by its own SampleTimeFine, so its rate= and
  // mag_rate= only ever configure a device.
  if (name == "imukit")
    return decode_only ? std::vector<std::string>{"rate", "commands"}
                       : std::vector<std::string>{"rate", "commands", "block", "ping_s"};
  if (name == "xsens")
    return decode_only ? std::vector<std::string>{} : std::vector<std::string>{"rate", "mag_rate"};
  if (name == "witmotion") return {"rate", "commands", "accel_range_g", "gyro_range_dps"};
  if (name == "text") return {"time_unit", "time_bits", "accel_unit", "gyro_unit"};
  return {};  // dualshock4, dualsense: nothing to configure
}

std::unique_ptr<Codec> make_codec(const std::string& name, const CodecOptions& options) {
  const double rate = option_double(options, "rate", 0.0);
  if (rate < 0) throw Error("rate=" + options.at("rate") + ": must be positive");
  if (name == "imukit") {
    ImukitCodecOptions o;
    o.send_commands = option_bool(options, "commands", true);
    o.rate_hz = rate;
    o.samples_per_block = static_cast<int>(option_int(options, "block", 8));
    if (o.samples_per_block < 1 || o.samples_per_block > 32) {
      throw Error("block=" + options.at("block") + ": samples per block must be 1..32");
    }
    const double ping_s = option_double(options, "ping_s", 1.0);
    if (ping_s < 0) throw Error("ping_s: must not be negative");
    o.ping_interval_ns = static_cast<TimeNs>(std::llround(ping_s * 1e9));
    return std::make_unique<ImukitCodec>(o);
  }
  if (name == "xsens") {
    XsensCodecOptions o;
    if (rate > 0xFFFE) throw Error("rate: Xsens rates are below 65535 Hz");
    o.rate_hz = static_cast<uint16_t>(std::lround(rate));
    const int64_t mag = option_int(options, "mag_rate", 100);
    if (mag < 1 || mag > 0xFFFE) throw Error("mag_rate: expected 1..65534 Hz");
    o.mag_rate_hz = static_cast<uint16_t>(mag);
    return std::make_unique<XsensCodec>(o);
  }
  if (name == "witmotion") {
    WitmotionCodecOptions o;
    o.rate_hz = rate;
    o.send_commands = option_bool(options, "commands", true);
    if (rate > 0) witmotion_rate_commands(rate);  // validate now, not at start
    o.accel_range_g = option_double(options, "accel_range_g", 16.0);
    o.gyro_range_dps = option_double(options, "gyro_range_dps", 2000.0);
    if (o.accel_range_g <= 0 || o.gyro_range_dps <= 0)
      throw Error("witmotion: ranges must be positive");
    return std::make_unique<WitmotionCodec>(o);
  }
  if (name == "dualshock4")
    return std::make_unique<PlaystationCodec>(PlaystationModel::kDualShock4);
  if (name == "dualsense") return std::make_unique<PlaystationCodec>(PlaystationModel::kDualSense);
  if (name == "text") return std::make_unique<TextCodec>(text_codec_options(options));
  std::string known;
  for (const auto& n : codec_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error("unknown codec '" + name + "' (known: " + known + ")");
}

}  // namespace imukit::drivers
