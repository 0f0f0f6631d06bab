// imukit::Error: the one exception type of the library. Its message names where bad input was
// found (file, line, column or byte offset) and what was wrong, so the CLI can print it as is.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace imukit {

// Where in an input something went wrong. Any field may be absent; line and column count from 1.
struct InputLocation {
  std::string file;
  std::optional<int64_t> line;
  std::optional<int64_t> column;
  std::optional<int64_t> byte_offset;

  // "file:line:column" (or "file: byte N"), the prefix compilers and editors understand.
  std::string to_string() const;
};

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what);
  Error(const InputLocation& where, const std::string& what);

  const std::optional<InputLocation>& where() const { return where_; }
  // The message without the location prefix.
  const std::string& reason() const { return reason_; }

 private:
  std::optional<InputLocation> where_;
  std::string reason_;
};

}  // namespace imukit
