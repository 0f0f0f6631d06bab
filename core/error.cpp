#include "core/error.hpp"

#include <fmt/core.h>

namespace imukit {

std::string InputLocation::to_string() const {
  // fmt rather than string concatenation: gcc 12 reports a false -Wrestrict on the latter.
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line) {
    out += fmt::format(":{}", *line);
    if (column) out += fmt::format(":{}", *column);
  }
  if (byte_offset) out += fmt::format(": byte {}", *byte_offset);
  return out;
}

Error::Error(const std::string& what) : std::runtime_error(what), reason_(what) {}

Error::Error(const InputLocation& where, const std::string& what)
    : std::runtime_error(where.to_string() + ": " + what), where_(where), reason_(what) {}

}  // namespace imukit
