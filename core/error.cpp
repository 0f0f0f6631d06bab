#include "core/error.hpp"

namespace imukit {

std::string InputLocation::to_string() const {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line) {
    out += ":" + std::to_string(*line);
    if (column) out += ":" + std::to_string(*column);
  }
  if (byte_offset) out += ": byte " + std::to_string(*byte_offset);
  return out;
}

Error::Error(const std::string& what) : std::runtime_error(what), reason_(what) {}

Error::Error(const InputLocation& where, const std::string& what)
    : std::runtime_error(where.to_string() + ": " + what), where_(where), reason_(what) {}

}  // namespace imukit
