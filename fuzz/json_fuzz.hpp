// Shared by the JSON fuzzers: inputs that name an absolute path are skipped, because a fuzzer
// that follows a file name from its input could read /dev/zero or a FIFO and hang.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace imukit::fuzz {

inline bool names_absolute_path(const nlohmann::json& j) {
  if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    return !s.empty() && s.front() == '/';
  }
  if (j.is_structured()) {
    for (const auto& e : j) {
      if (names_absolute_path(e)) return true;
    }
  }
  return false;
}

// True when the text is JSON that names an absolute path anywhere (keys are not checked).
inline bool json_names_absolute_path(std::string_view text) {
  const nlohmann::json probe = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  return !probe.is_discarded() && names_absolute_path(probe);
}

}  // namespace imukit::fuzz
