// Low-level pieces shared by every text reader in imukit: a buffered line reader that knows its
// line numbers, field splitting (commas or whitespace), strict number parsing, and exact
// decimal-to-nanosecond time parsing (no detour through double, so 1.7e9 s since the epoch keeps
// its nanoseconds).
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imukit {

// Reads a file (or an in-memory buffer) line by line in large blocks. Lines are returned
// without their terminator ("\n" or "\r\n"); a final line without a newline is returned too.
class LineReader {
 public:
  // Throws imukit::Error naming the path if it cannot be opened.
  explicit LineReader(const std::string& path);
  // Reads from memory; `source_name` is used in error messages.
  LineReader(std::string_view text, std::string source_name);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  // The next line, valid until the next call; nullopt at the end of the input. Throws
  // imukit::Error, at the line, when the input is not line-oriented text (check_text).
  std::optional<std::string_view> next();
  // 1-based number of the line last returned.
  int64_t line_number() const { return line_number_; }
  const std::string& source_name() const { return source_name_; }

 private:
  bool refill();
  // Throws imukit::Error at a line that shows the input is not line-oriented text: an MCAP
  // recording, a bare CR inside it (CR-only line ends), or another control byte (binary data).
  void check_text(std::string_view line, int64_t number) const;

  std::string source_name_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
  std::string_view memory_;
  std::size_t begin_ = 0;  // start of unread data in buffer_
  std::size_t end_ = 0;    // end of valid data in buffer_
  bool eof_ = false;
  int64_t line_number_ = 0;
};

// One field of a line and the 1-based column (character position) where it starts.
struct Field {
  std::string_view text;
  int64_t column = 0;
};

// Splits a line on commas if it has any, else on runs of blanks (spaces, tabs). Fields are
// trimmed of surrounding blanks; with commas an empty field stays (and is an error for the
// caller to report). Reuses `out`'s storage.
void split_fields(std::string_view line, std::vector<Field>& out);

// Parses a whole field as a double with std::from_chars semantics (no locale, no leading '+'
// surprises: a leading '+' is accepted). Returns nullopt unless the entire field is a number.
// "nan"/"inf" parse as NaN/Inf: callers decide whether those are allowed.
std::optional<double> parse_double(std::string_view text);

// Parses a decimal number exactly into an integer count of 10^-scale_digits units, rounded to
// the nearest (halves away from zero). E.g. parse_scaled_integer("1459.63", 9) == 1459630000000.
// Accepts sign, fraction and exponent ("2.984e-02"). Returns nullopt for anything else,
// including NaN, Inf and values outside int64.
std::optional<int64_t> parse_scaled_integer(std::string_view text, int scale_digits);

}  // namespace imukit
