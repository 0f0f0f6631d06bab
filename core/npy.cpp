#include "imukit/core/npy.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <iterator>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"

namespace imukit {

static_assert(std::endian::native == std::endian::little,
              "imukit's NPY I/O writes host bytes as little-endian");

namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;

std::string_view descr(NpyDtype d) {
  switch (d) {
    case NpyDtype::float32:
      return "<f4";
    case NpyDtype::float64:
      return "<f8";
    case NpyDtype::int64:
      return "<i8";
  }
  return "";
}

std::size_t item_size(NpyDtype d) { return d == NpyDtype::float32 ? 4 : 8; }

std::size_t product(std::span<const std::size_t> shape) {
  std::size_t n = 1;
  for (std::size_t s : shape) n *= s;
  return n;
}

void write_raw(const std::string& path, NpyDtype dtype, const void* data, std::size_t count,
               std::span<const std::size_t> shape) {
  if (product(shape) != count) {
    throw Error(fmt::format("{}: NPY shape holds {} values but {} were given", path, product(shape),
                            count));
  }
  std::string dict =
      fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': (", descr(dtype));
  // Python tuple syntax: (), (3,), (3, 4).
  for (std::size_t k = 0; k < shape.size(); ++k) {
    if (k > 0) dict += ", ";
    dict += std::to_string(shape[k]);
  }
  if (shape.size() == 1) dict += ',';
  dict += ')';
  dict += ", }";
  // Pad with spaces so the data starts on a 64-byte boundary; the header ends with '\n'.
  const std::size_t unpadded = kMagicSize + 2 + 2 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  std::string head(kMagic, kMagicSize);
  head += '\x01';
  head += '\x00';
  const auto len = static_cast<uint16_t>(dict.size());
  head += static_cast<char>(len & 0xFF);
  head += static_cast<char>(len >> 8);
  head += dict;

  // Through a temporary renamed over the file: a failed write (a full disk, a kill) leaves an
  // earlier file as it was, never a truncated array under its name (found in review,
  // 2026-11-27: a dataset folder held a new X.npy beside the old run's files).
  write_file_atomically(path, [&](std::FILE* out) {
    const std::size_t bytes = count * item_size(dtype);
    if (std::fwrite(head.data(), 1, head.size(), out) != head.size() ||
        (bytes != 0 && std::fwrite(data, 1, bytes, out) != bytes)) {
      throw IoError(fmt::format("{}: write failed: {}", path, std::strerror(errno)));
    }
  });
}

[[noreturn]] void fail(const std::string& source, std::size_t offset, const std::string& what) {
  throw Error(InputLocation{source, {}, {}, static_cast<int64_t>(offset)},
              "not a valid .npy: " + what);
}

// The header: a Python literal dict, as numpy writes it and reads it back with
// ast.literal_eval, {'descr': '<f8', 'fortran_order': False, 'shape': (10, 17, 3), } padded with
// blanks. Parsed strictly (found in review: a search for each key's text accepted `(10 17 3)`,
// a dict never closed, and keys inside other values): exactly the three keys, each once, the
// shape a tuple of integers; each error gives the byte offset in the file.
class HeaderParser {
 public:
  HeaderParser(std::string_view text, std::size_t offset, const std::string& source)
      : text_(text), offset_(offset), source_(source) {}

  // Fills array's dtype and shape; returns the file offset of the shape (for later errors).
  std::size_t parse(NpyArray& array) {
    expect('{', "the header to start with '{'");
    bool descr = false, fortran_order = false, shape = false;
    std::size_t shape_at = 0;
    for (bool more = !take('}'); more;) {
      const std::size_t key_at = at();
      const std::string_view key = string("a key in quotes, or '}'");
      expect(':', "':' after the key");
      bool* seen = key == "descr"           ? &descr
                   : key == "fortran_order" ? &fortran_order
                   : key == "shape"         ? &shape
                                            : nullptr;
      if (seen == nullptr) {
        fail_at(key_at, fmt::format("unknown key {} (a .npy header has descr, fortran_order and "
                                    "shape)",
                                    quote_excerpt(key)));
      }
      if (*seen) fail_at(key_at, fmt::format("key {} given twice", quote_excerpt(key)));
      *seen = true;
      if (key == "descr") {
        const std::size_t value_at = at();
        const std::string_view d = string("the dtype in quotes");
        if (d == "<f4")
          array.dtype = NpyDtype::float32;
        else if (d == "<f8")
          array.dtype = NpyDtype::float64;
        else if (d == "<i8")
          array.dtype = NpyDtype::int64;
        else
          fail_at(value_at, "dtype must be '<f4', '<f8' or '<i8'");
      } else if (key == "fortran_order") {
        const std::size_t value_at = at();
        const std::string_view word = identifier();
        if (word == "True") fail_at(value_at, "only C-order arrays are supported");
        if (word != "False") fail_at(value_at, "fortran_order must be True or False");
      } else {
        shape_at = at();
        array.shape = tuple();
      }
      // A trailing comma before '}' is Python (and what numpy writes).
      if (take(',')) {
        more = !take('}');
      } else {
        expect('}', "',' or '}' after a value");
        more = false;
      }
    }
    blanks();
    if (i_ != text_.size()) fail_at(at(), "text after the header's closing '}'");
    for (const auto& [seen, key] :
         {std::pair{descr, "descr"}, std::pair{fortran_order, "fortran_order"},
          std::pair{shape, "shape"}}) {
      if (!seen) fail(source_, offset_, fmt::format("header has no '{}'", key));
    }
    return shape_at;
  }

 private:
  std::size_t at() {
    blanks();
    return offset_ + i_;
  }
  [[noreturn]] void fail_at(std::size_t file_offset, const std::string& what) const {
    fail(source_, file_offset, what);
  }
  void blanks() {
    while (i_ < text_.size() &&
           (text_[i_] == ' ' || text_[i_] == '\t' || text_[i_] == '\n' || text_[i_] == '\r'))
      ++i_;
  }
  bool take(char c) {
    blanks();
    if (i_ >= text_.size() || text_[i_] != c) return false;
    ++i_;
    return true;
  }
  void expect(char c, std::string_view what) {
    if (!take(c)) expected(what);
  }
  [[noreturn]] void expected(std::string_view what) {
    fail_at(at(), i_ >= text_.size()
                      ? fmt::format("header dict is not closed (expected {} before its end)", what)
                      : fmt::format("expected {}", what));
  }
  // A quoted string without escapes (no key or dtype needs one).
  std::string_view string(std::string_view what) {
    blanks();
    const char quote = i_ < text_.size() ? text_[i_] : '\0';
    if (quote != '\'' && quote != '"') expected(what);
    const std::size_t close = text_.find(quote, i_ + 1);
    const std::size_t backslash = text_.find('\\', i_ + 1);
    if (close == std::string_view::npos || backslash < close)
      fail_at(offset_ + i_, "string not closed (or holding an escape)");
    const std::string_view s = text_.substr(i_ + 1, close - i_ - 1);
    i_ = close + 1;
    return s;
  }
  std::string_view identifier() {
    blanks();
    const std::size_t start = i_;
    while (i_ < text_.size() && std::isalpha(static_cast<unsigned char>(text_[i_]))) ++i_;
    return text_.substr(start, i_ - start);
  }
  // A Python tuple of non-negative integers: (), (3,), (3, 4) or (3, 4,).
  std::vector<std::size_t> tuple() {
    expect('(', "the shape as a tuple");
    std::vector<std::size_t> dims;
    std::size_t elements = 1;
    while (!take(')')) {
      const std::size_t dim_at = at();
      std::size_t n = 0;
      std::size_t digits = 0;
      for (; i_ < text_.size() && text_[i_] >= '0' && text_[i_] <= '9'; ++i_, ++digits) {
        if (n > (SIZE_MAX - 9) / 10) fail_at(dim_at, "dimension too large");
        n = n * 10 + static_cast<std::size_t>(text_[i_] - '0');
      }
      if (digits == 0) fail_at(dim_at, "shape holds something other than integers");
      if (n != 0 && elements > SIZE_MAX / n) fail_at(dim_at, "shape too large");
      elements *= n;
      dims.push_back(n);
      if (take(',')) continue;
      expect(')', "',' or ')' after a dimension of the shape");
      // (3) is the integer 3 in Python, not a tuple: numpy refuses it.
      if (dims.size() == 1) fail_at(dim_at, "a one-dimensional shape is written (N,)");
      break;
    }
    return dims;
  }

  std::string_view text_;
  std::size_t offset_;
  const std::string& source_;
  std::size_t i_ = 0;
};

}  // namespace

void write_npy(const std::string& path, std::span<const float> data,
               std::span<const std::size_t> shape) {
  write_raw(path, NpyDtype::float32, data.data(), data.size(), shape);
}
void write_npy(const std::string& path, std::span<const double> data,
               std::span<const std::size_t> shape) {
  write_raw(path, NpyDtype::float64, data.data(), data.size(), shape);
}
void write_npy(const std::string& path, std::span<const int64_t> data,
               std::span<const std::size_t> shape) {
  write_raw(path, NpyDtype::int64, data.data(), data.size(), shape);
}

std::size_t NpyArray::size() const { return product(shape); }

std::vector<double> NpyArray::to_double() const {
  std::vector<double> out(size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (dtype == NpyDtype::float32) {
      float v;
      std::memcpy(&v, bytes.data() + 4 * i, 4);
      out[i] = v;
    } else if (dtype == NpyDtype::float64) {
      std::memcpy(&out[i], bytes.data() + 8 * i, 8);
    } else {
      int64_t v;
      std::memcpy(&v, bytes.data() + 8 * i, 8);
      out[i] = static_cast<double>(v);
    }
  }
  return out;
}

NpyArray parse_npy(std::span<const std::byte> file, const std::string& source) {
  const auto* bytes = reinterpret_cast<const char*>(file.data());
  const std::size_t preamble =
      file.size() >= 7 && (file[6] == std::byte{2} || file[6] == std::byte{3}) ? 12 : 10;
  if (file.size() < preamble) {
    // A file cut inside the preamble is truncated if what is there is the magic's start (found in
    // review: 9 bytes of a valid start were "missing the magic").
    if (!file.empty() && std::memcmp(bytes, kMagic, std::min(file.size(), kMagicSize)) == 0) {
      fail(source, file.size(),
           fmt::format("truncated: {} bytes, but the magic, version and header length take {}",
                       file.size(), preamble));
    }
    fail(source, 0, "missing the \\x93NUMPY magic");
  }
  if (std::memcmp(bytes, kMagic, kMagicSize) != 0) fail(source, 0, "missing the \\x93NUMPY magic");
  const auto major = static_cast<uint8_t>(file[6]);
  std::size_t header_len = 0;
  if (major == 1) {
    header_len = static_cast<std::size_t>(file[8]) | (static_cast<std::size_t>(file[9]) << 8);
  } else if (major == 2 || major == 3) {
    for (int k = 3; k >= 0; --k)
      header_len = (header_len << 8) | static_cast<std::size_t>(file[8 + k]);
  } else {
    fail(source, 6, fmt::format("unsupported format version {}", major));
  }
  const std::size_t header_start = preamble;
  if (header_len > file.size() - header_start) fail(source, 8, "header longer than the file");

  NpyArray array;
  HeaderParser header(std::string_view(bytes + header_start, header_len), header_start, source);
  const std::size_t s_offset = header.parse(array);
  const std::size_t elements = product(array.shape);
  const std::size_t data_start = header_start + header_len;
  const std::size_t available = file.size() - data_start;
  const std::size_t item = item_size(array.dtype);
  if (elements > SIZE_MAX / item) fail(source, s_offset, "shape too large");
  if (elements * item != available) {
    fail(source, data_start,
         fmt::format("shape needs {} bytes of data but the file has {}", elements * item,
                     available));
  }
  array.bytes.assign(file.begin() + static_cast<std::ptrdiff_t>(data_start), file.end());
  return array;
}

NpyArray read_npy(const std::string& path) {
  const std::string raw = read_regular_file(path, kMaxNpyBytes, "NumPy array");
  const auto* begin = reinterpret_cast<const std::byte*>(raw.data());
  return parse_npy(std::span<const std::byte>(begin, raw.size()), path);
}

}  // namespace imukit
