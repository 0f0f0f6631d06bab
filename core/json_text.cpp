// JSON text with located errors (core/json_text.hpp).
#include "imukit/core/json_text.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace imukit {

InputLocation locate_in_text(std::string_view text, std::size_t offset, const std::string& source) {
  offset = std::min(offset, text.size());
  int64_t line = 1;
  std::size_t line_start = 0;
  for (std::size_t i = 0; i < offset; ++i) {
    if (text[i] == '\n') {
      ++line;
      line_start = i + 1;
    }
  }
  int64_t column = 1;
  for (std::size_t i = line_start; i < offset; ++i) {
    if ((static_cast<unsigned char>(text[i]) & 0xC0) != 0x80) ++column;
  }
  return InputLocation{source, line, column, {}};
}

void check_json_depth(std::string_view text, const std::string& source, int max_depth) {
  int depth = 0;
  bool in_string = false;
  bool escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) {
        throw Error(locate_in_text(text, i, source),
                    fmt::format("nesting deeper than {} levels", max_depth));
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

std::size_t json_key_offset(std::string_view text, std::size_t n) {
  std::size_t keys = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '"') continue;
    const std::size_t open = i;
    for (++i; i < text.size() && text[i] != '"'; ++i) {
      if (text[i] == '\\') ++i;
    }
    // A string is a key when a colon follows it.
    std::size_t j = i + 1;
    while (j < text.size() &&
           (text[j] == ' ' || text[j] == '\t' || text[j] == '\n' || text[j] == '\r'))
      ++j;
    if (j < text.size() && text[j] == ':' && ++keys == n) return open;
  }
  return text.size();
}

// nlohmann's messages start with "[json.exception.parse_error.101] parse error at line 1,
// column 2: "; the location is printed our way, so keep only what went wrong.
std::string json_error_reason(std::string message) {
  if (!message.empty() && message[0] == '[') {
    const auto end = message.find("] ");
    if (end != std::string::npos) message.erase(0, end + 2);
  }
  if (message.rfind("parse error", 0) == 0) {
    const auto colon = message.find(": ");
    if (colon != std::string::npos) message.erase(0, colon + 2);
  }
  // "...; last read: '<the bytes of the token>'": quoted as an excerpt, never raw.
  const std::string_view tag = "; last read: '";
  const auto last = message.find(tag);
  if (last != std::string::npos && message.back() == '\'') {
    const std::size_t start = last + tag.size();
    const std::string token = message.substr(start, message.size() - 1 - start);
    message = message.substr(0, last) + "; last read: " + quote_excerpt(token);
  }
  return message;
}

}  // namespace imukit
