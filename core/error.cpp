#include "imukit/core/error.hpp"

#include <fmt/core.h>

namespace imukit {
namespace {

// Length of the valid UTF-8 sequence (of a printable character) starting at text[i], or 0.
std::size_t utf8_length(std::string_view text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  std::size_t n = 0;
  uint32_t code = 0;
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2, code = c & 0x1Fu;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3, code = c & 0x0Fu;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4, code = c & 0x07u;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3Fu);
  }
  // Overlong forms, surrogates, beyond U+10FFFF, and the C1 controls are not printable text.
  const uint32_t min_code[5] = {0, 0, 0x80, 0x800, 0x10000};
  if (code < min_code[n] || (code >= 0xD800 && code <= 0xDFFF) || code > 0x10FFFF ||
      (code >= 0x80 && code < 0xA0))
    return 0;
  return n;
}

// Appends the character at text[i] (escaped if need be) to out; returns the bytes consumed.
std::size_t append_escaped(std::string_view text, std::size_t i, bool quote, std::string& out) {
  const char c = text[i];
  const auto u = static_cast<unsigned char>(c);
  if (c == '\n') {
    out += "\\n";
  } else if (c == '\t') {
    out += "\\t";
  } else if (c == '\r') {
    out += "\\r";
  } else if (quote && (c == '\'' || c == '\\')) {
    out += '\\';
    out += c;
  } else if (u >= 0x20 && u < 0x7F) {
    out += c;
  } else if (const std::size_t n = u >= 0x80 ? utf8_length(text, i) : 0; n > 0) {
    out.append(text.substr(i, n));
    return n;
  } else {
    out += fmt::format("\\x{:02X}", u);
  }
  return 1;
}

}  // namespace

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

std::string quote_excerpt(std::string_view text, std::size_t max_chars) {
  std::string out = "'";
  std::size_t i = 0;
  for (std::size_t chars = 0; i < text.size() && chars < max_chars; ++chars)
    i += append_escaped(text, i, true, out);
  out += "'";
  if (i < text.size()) {
    out.insert(out.size() - 1, "...");
    out += fmt::format(" ({} bytes)", text.size());
  }
  return out;
}

std::string escape_unprintable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) i += append_escaped(text, i, false, out);
  return out;
}

}  // namespace imukit
