#include "imukit/drivers/codec.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "imukit/core/error.hpp"

namespace imukit::drivers {

namespace {

bool all_finite(const std::array<double, 3>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// Every value field, whether its channel bit is set or not: the recorder writes accel and gyro
// of every sample.
bool sample_is_finite(const Sample& s) {
  return all_finite(s.accel) && all_finite(s.gyro) && all_finite(s.mag) &&
         all_finite(s.angles_rad) && std::isfinite(s.temperature_c) && std::isfinite(s.tick_hz);
}

}  // namespace

void Codec::feed(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) {
  const std::size_t first = out.size();
  decode(data, host_time, out);
  drop_non_finite(out, first);
}

void Codec::finish(TimeNs host_time, std::vector<Sample>& out) {
  const std::size_t first = out.size();
  decode_end(host_time, out);
  drop_non_finite(out, first);
}

void Codec::drop_non_finite(std::vector<Sample>& out, std::size_t first) {
  const auto bad = std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                                  [](const Sample& s) { return !sample_is_finite(s); });
  const auto n = static_cast<uint64_t>(out.end() - bad);
  if (n == 0) return;
  out.erase(bad, out.end());
  // The frame passed its checksum but its value is unusable: corrupt, and the sample is lost.
  stats_.samples_non_finite += n;
  stats_.frames_corrupt += n;
  stats_.samples_dropped += n;
  stats_.samples_decoded -= n;
}

double option_double(const CodecOptions& options, const std::string& key, double fallback) {
  const auto it = options.find(key);
  if (it == options.end()) return fallback;
  const std::string& text = it->second;
  double v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size() ||
      !std::isfinite(v)) {
    throw Error(key + "=" + text + ": expected a number");
  }
  return v;
}

int64_t option_int(const CodecOptions& options, const std::string& key, int64_t fallback) {
  const auto it = options.find(key);
  if (it == options.end()) return fallback;
  const std::string& text = it->second;
  int64_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) {
    throw Error(key + "=" + text + ": expected an integer");
  }
  return v;
}

bool option_bool(const CodecOptions& options, const std::string& key, bool fallback) {
  const auto it = options.find(key);
  if (it == options.end()) return fallback;
  const std::string& t = it->second;
  if (t == "1" || t == "true" || t == "yes" || t == "on") return true;
  if (t == "0" || t == "false" || t == "no" || t == "off") return false;
  throw Error(key + "=" + t + ": expected true or false");
}

std::string option_string(const CodecOptions& options, const std::string& key,
                          const std::string& fallback) {
  const auto it = options.find(key);
  return it == options.end() ? fallback : it->second;
}

}  // namespace imukit::drivers
