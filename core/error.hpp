// imukit::Error: the exception type of the library. Its message names where bad input was
// found (file, line, column or byte offset) and what was wrong, so the CLI can print it as is.
// IoError, a kind of Error, says a file could not be opened, read or written (or is not a
// regular file, or is too large) rather than that its content was wrong; the CLI gives it its
// own exit code. Bytes of an input quoted in a message go through quote_excerpt, so a message
// never carries raw (binary, control, or long) content of a file.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

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

class IoError : public Error {
 public:
  using Error::Error;
};

// `text` as a short quoted excerpt for a message: 'abc', with control characters, quotes,
// backslashes and bytes that are not valid UTF-8 escaped (\n, \xNN), and anything beyond
// max_chars characters elided ('abcdef...' (1234 bytes)).
std::string quote_excerpt(std::string_view text, std::size_t max_chars = 32);

// The whole of `text` with the same escapes and no elision, for a message about to be printed.
std::string escape_unprintable(std::string_view text);

}  // namespace imukit
