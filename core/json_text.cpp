// JSON text with located errors (core/json_text.hpp).
#include "imukit/core/json_text.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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

namespace {

std::size_t skip_blanks(std::string_view text, std::size_t i) {
  while (i < text.size() &&
         (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == '\r'))
    ++i;
  return i;
}

// One past the string whose opening quote is at i.
std::size_t skip_string(std::string_view text, std::size_t i) {
  for (++i; i < text.size() && text[i] != '"'; ++i) {
    if (text[i] == '\\') ++i;
  }
  return std::min(i + 1, text.size());
}

// One past the value that starts at i (well-formed text: brackets only need counting).
std::size_t skip_value(std::string_view text, std::size_t i) {
  int depth = 0;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      i = skip_string(text, i) - 1;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      if (depth == 0) return i;  // a scalar ends at its container's end
      --depth;
    } else if (c == ',' && depth == 0) {
      return i;
    }
    if (depth == 0 && (c == '"' || c == '}' || c == ']')) return i + 1;
  }
  return i;
}

}  // namespace

std::size_t json_path_offset(std::string_view text, std::string_view path) {
  std::size_t at = skip_blanks(text, 0);
  while (!path.empty()) {
    if (path.front() == '.') {
      path.remove_prefix(1);
      continue;
    }
    if (path.front() == '[') {
      const std::size_t close = path.find(']');
      std::size_t n = 0;
      for (std::size_t k = 1; k < close && k < path.size(); ++k)
        n = n * 10 + static_cast<std::size_t>(path[k] - '0');
      if (close == std::string_view::npos || at >= text.size() || text[at] != '[') return at;
      std::size_t i = skip_blanks(text, at + 1);
      for (std::size_t k = 0; k < n; ++k) {
        i = skip_blanks(text, skip_value(text, i));
        if (i >= text.size() || text[i] != ',') return at;
        i = skip_blanks(text, i + 1);
      }
      if (i >= text.size() || text[i] == ']') return at;
      at = i;
      path.remove_prefix(close + 1);
      continue;
    }
    const std::size_t end = std::min(path.find('.'), path.find('['));
    const std::string_view key = path.substr(0, end);
    if (at >= text.size() || text[at] != '{') return at;
    std::size_t i = skip_blanks(text, at + 1);
    bool found = false;
    while (i < text.size() && text[i] == '"') {
      const std::size_t key_end = skip_string(text, i);
      const bool match = text.substr(i + 1, key_end - i - 2) == key;
      i = skip_blanks(text, key_end);                       // at the colon
      i = skip_blanks(text, std::min(i + 1, text.size()));  // at the value
      if (match) {
        found = true;
        break;
      }
      i = skip_blanks(text, skip_value(text, i));
      if (i < text.size() && text[i] == ',') i = skip_blanks(text, i + 1);
    }
    if (!found) return at;
    at = i;
    path.remove_prefix(std::min(end, path.size()));
  }
  return at;
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

void json_fail(const std::string& source, const std::string& path, const std::string& what) {
  throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt}, path + ": " + what);
}

double json_number(const nlohmann::json& j, const std::string& source, const std::string& path) {
  if (!j.is_number())
    json_fail(source, path, std::string("expected a number, got ") + j.type_name());
  const double v = j.get<double>();
  if (!std::isfinite(v)) json_fail(source, path, "expected a finite number");
  return v;
}

std::string json_string(const nlohmann::json& j, const std::string& source,
                        const std::string& path) {
  if (!j.is_string())
    json_fail(source, path, std::string("expected a string, got ") + j.type_name());
  return j.get<std::string>();
}

bool json_boolean(const nlohmann::json& j, const std::string& source, const std::string& path) {
  if (!j.is_boolean())
    json_fail(source, path, std::string("expected true or false, got ") + j.type_name());
  return j.get<bool>();
}

Eigen::Vector3d json_vec3(const nlohmann::json& j, const std::string& source,
                          const std::string& path) {
  if (!j.is_array() || j.size() != 3) json_fail(source, path, "expected an array of 3 numbers");
  return {json_number(j[0], source, path + "[0]"), json_number(j[1], source, path + "[1]"),
          json_number(j[2], source, path + "[2]")};
}

void json_only_keys(const nlohmann::json& j, std::initializer_list<std::string_view> keys,
                    const std::string& source, const std::string& path) {
  if (!j.is_object())
    json_fail(source, path, std::string("expected an object, got ") + j.type_name());
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(keys.begin(), keys.end(), it.key()) != keys.end()) continue;
    std::string known;
    for (std::string_view k : keys) known.append(known.empty() ? "" : ", ").append(k);
    json_fail(source, path, "unknown key '" + it.key() + "' (known: " + known + ")");
  }
}

}  // namespace imukit
