#include "imukit/core/text_parse.hpp"

#include <fmt/core.h>

#include <cerrno>
#include <charconv>
#include <cstring>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"

namespace imukit {
namespace {

constexpr std::size_t kBlockSize = 1 << 20;
// No numeric text has lines this long; a file that does is not text (or not one of ours), and
// reading on would hold it all in memory.
constexpr std::size_t kMaxLineBytes = std::size_t{16} << 20;

// 128-bit integers hold 36 decimal digits exactly; __extension__ keeps -Wpedantic quiet.
__extension__ typedef __int128 Int128;

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

}  // namespace

LineReader::LineReader(const std::string& path) : source_name_(path) {
  file_ = open_regular_file(path, "text input").release();
  buffer_.resize(kBlockSize);
}

LineReader::LineReader(std::string_view text, std::string source_name)
    : source_name_(std::move(source_name)), memory_(text) {}

LineReader::~LineReader() {
  if (file_) std::fclose(file_);
}

bool LineReader::refill() {
  if (eof_ || !file_) return false;
  // Move the unfinished line to the front, grow if one line is longer than the buffer.
  const std::size_t pending = end_ - begin_;
  if (begin_ > 0) std::memmove(buffer_.data(), buffer_.data() + begin_, pending);
  begin_ = 0;
  end_ = pending;
  if (end_ == buffer_.size()) {
    if (buffer_.size() >= kMaxLineBytes) {
      check_text(std::string_view(buffer_.data(), end_), line_number_ + 1);  // why, if it can
      throw Error(InputLocation{source_name_, line_number_ + 1, {}, {}},
                  fmt::format("line longer than {} MiB: not a text file?", kMaxLineBytes >> 20));
    }
    buffer_.resize(buffer_.size() * 2);
  }
  const std::size_t got = std::fread(buffer_.data() + end_, 1, buffer_.size() - end_, file_);
  if (got == 0) {
    if (std::ferror(file_)) {
      throw Error(InputLocation{source_name_, line_number_ + 1, {}, {}},
                  std::string("read error: ") + std::strerror(errno));
    }
    eof_ = true;
    return false;
  }
  end_ += got;
  return true;
}

std::optional<std::string_view> LineReader::next() {
  std::string_view line;
  if (!file_) {
    if (memory_.empty()) return std::nullopt;
    const std::size_t nl = memory_.find('\n');
    line = memory_.substr(0, nl);
    memory_.remove_prefix(nl == std::string_view::npos ? memory_.size() : nl + 1);
  } else {
    for (;;) {
      const char* start = buffer_.data() + begin_;
      const void* nl = std::memchr(start, '\n', end_ - begin_);
      if (nl) {
        const auto len = static_cast<std::size_t>(static_cast<const char*>(nl) - start);
        line = std::string_view(start, len);
        begin_ += len + 1;
        break;
      }
      if (!refill()) {
        if (begin_ == end_) return std::nullopt;
        line = std::string_view(buffer_.data() + begin_, end_ - begin_);
        begin_ = end_;
        break;
      }
    }
  }
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  ++line_number_;
  check_text(line, line_number_);
  return line;
}

// A file that is not line-oriented text would otherwise be read as one huge line (bare CR line
// ends: "expected 7 columns, found 1201") or as rows of binary noise quoted in the messages
// (found in review); say what it is instead.
void LineReader::check_text(std::string_view line, int64_t number) const {
  if (number == 1 && line.starts_with("\x89MCAP")) {
    throw Error(InputLocation{source_name_, 1, 1, {}}, "an MCAP recording (binary), not text");
  }
  // Before the run of blanks at the end, CRs among them, which trim() removes ("0.03\r \n" was
  // read before the check and must stay so; found in review).
  std::size_t text_end = line.size();
  while (text_end > 0 && is_blank(line[text_end - 1])) --text_end;
  // First one pass without an early exit, which the compiler vectorises: the byte-by-byte loop
  // below took a fifth of parse_euroc_csv's time (perf, 2026-11-27); it now runs only to name
  // the byte of a line that has one.
  unsigned char control = 0;
  for (std::size_t i = 0; i < text_end; ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    control |= static_cast<unsigned char>((c < 0x20) & (c != '\t'));
  }
  if (control == 0) return;
  for (std::size_t i = 0; i < text_end; ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    if (c >= 0x20 || c == '\t') continue;
    const InputLocation where{source_name_, number, static_cast<int64_t>(i + 1), {}};
    if (c == '\r') {
      throw Error(where,
                  "a carriage return (\\r) inside a line: the file's lines end with a bare CR "
                  "(classic Mac OS); save it with \\n or \\r\\n line ends");
    }
    throw Error(where, fmt::format("control byte 0x{:02X}: a binary file, not text", c));
  }
}

void split_fields(std::string_view line, std::vector<Field>& out) {
  out.clear();
  const bool commas = line.find(',') != std::string_view::npos;
  std::size_t pos = 0;
  if (commas) {
    for (;;) {
      const std::size_t comma = line.find(',', pos);
      const std::size_t stop = comma == std::string_view::npos ? line.size() : comma;
      std::string_view raw = line.substr(pos, stop - pos);
      std::size_t lead = 0;
      while (lead < raw.size() && is_blank(raw[lead])) ++lead;
      out.push_back({trim(raw), static_cast<int64_t>(pos + lead + 1)});
      if (comma == std::string_view::npos) break;
      pos = comma + 1;
    }
    return;
  }
  while (pos < line.size()) {
    while (pos < line.size() && is_blank(line[pos])) ++pos;
    if (pos == line.size()) break;
    std::size_t stop = pos;
    while (stop < line.size() && !is_blank(line[stop])) ++stop;
    out.push_back({line.substr(pos, stop - pos), static_cast<int64_t>(pos + 1)});
    pos = stop;
  }
}

std::optional<double> parse_double(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, value);
  if (result.ec == std::errc::result_out_of_range) {
    // Denormal underflow is a legitimate tiny number; overflow is not a measurement.
    return std::nullopt;
  }
  if (result.ec != std::errc() || result.ptr != end) return std::nullopt;
  return value;
}

std::optional<int64_t> parse_scaled_integer(std::string_view text, int scale_digits) {
  std::size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative = text[i++] == '-';
  // value = digits * 10^exponent. Digits beyond the 36th significant one are dropped: they
  // are far below a nanosecond for any time that fits int64.
  Int128 digits = 0;
  int significant = 0;
  int exponent = 0;
  bool any_digit = false;
  auto take_digit = [&](char c, bool fractional) {
    any_digit = true;
    if (significant < 36) {
      digits = digits * 10 + (c - '0');
      if (digits != 0) ++significant;
      if (fractional) --exponent;
    } else if (!fractional) {
      ++exponent;
    }
  };
  while (i < text.size() && text[i] >= '0' && text[i] <= '9') take_digit(text[i++], false);
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') take_digit(text[i++], true);
  }
  if (!any_digit) return std::nullopt;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    bool exp_negative = false;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) exp_negative = text[i++] == '-';
    if (i == text.size()) return std::nullopt;
    int e = 0;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
      e = e * 10 + (text[i++] - '0');
      if (e > 100000) return std::nullopt;
    }
    exponent += exp_negative ? -e : e;
  }
  if (i != text.size()) return std::nullopt;

  exponent += scale_digits;
  constexpr Int128 kMax = static_cast<Int128>(INT64_MAX);
  if (digits == 0) return 0;
  if (exponent >= 0) {
    for (int k = 0; k < exponent; ++k) {
      digits *= 10;
      if (digits > kMax) return std::nullopt;
    }
  } else {
    // Divide by 10^-exponent, rounding half away from zero.
    const int shift = -exponent;
    if (shift > 36) {  // digits < 10^36, so the quotient is below 1/10
      digits = 0;
    } else {
      Int128 divisor = 1;
      for (int k = 0; k < shift; ++k) divisor *= 10;
      const Int128 quotient = digits / divisor;
      const Int128 remainder = digits % divisor;
      const Int128 twice = remainder * 2;
      digits = quotient + (twice >= divisor ? 1 : 0);
    }
  }
  if (digits > kMax) return std::nullopt;
  const auto value = static_cast<int64_t>(digits);
  return negative ? -value : value;
}

}  // namespace imukit
