#include "imukit/drivers/codec.hpp"

#include <charconv>
#include <cmath>

#include "imukit/core/error.hpp"

namespace imukit::drivers {

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
