#include "imukit/core/npy.hpp"

#include <fmt/format.h>
#include <bit>
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

  std::FILE* out = std::fopen(path.c_str(), "wb");
  if (!out)
    throw IoError(fmt::format("{}: cannot open for writing: {}", path, std::strerror(errno)));
  const std::size_t bytes = count * item_size(dtype);
  const bool ok = std::fwrite(head.data(), 1, head.size(), out) == head.size() &&
                  (bytes == 0 || std::fwrite(data, 1, bytes, out) == bytes);
  const int saved = errno;
  const bool closed = std::fclose(out) == 0;
  if (!ok || !closed) {
    throw IoError(fmt::format("{}: write failed: {}", path, std::strerror(ok ? errno : saved)));
  }
}

[[noreturn]] void fail(const std::string& source, std::size_t offset, const std::string& what) {
  throw Error(InputLocation{source, {}, {}, static_cast<int64_t>(offset)},
              "not a valid .npy: " + what);
}

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
  if (file.size() < 10 || std::memcmp(file.data(), kMagic, kMagicSize) != 0) {
    fail(source, 0, "missing the \\x93NUMPY magic");
  }
  const auto major = static_cast<uint8_t>(file[6]);
  std::size_t header_len = 0;
  std::size_t header_start = 0;
  if (major == 1) {
    header_len = static_cast<std::size_t>(file[8]) | (static_cast<std::size_t>(file[9]) << 8);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (file.size() < 12) fail(source, file.size(), "truncated header length");
    header_len = 0;
    for (int k = 3; k >= 0; --k)
      header_len = (header_len << 8) | static_cast<std::size_t>(file[8 + k]);
    header_start = 12;
  } else {
    fail(source, 6, fmt::format("unsupported format version {}", major));
  }
  if (header_len > file.size() - header_start) fail(source, 8, "header longer than the file");
  const std::string_view header(reinterpret_cast<const char*>(file.data()) + header_start,
                                header_len);

  NpyArray array;
  const auto value_of = [&](std::string_view key) -> std::string_view {
    const std::size_t k = header.find(key);
    if (k == std::string_view::npos)
      fail(source, header_start, fmt::format("header has no {}", key));
    std::size_t v = header.find(':', k + key.size());
    if (v == std::string_view::npos)
      fail(source, header_start + k, fmt::format("{} has no value", key));
    ++v;
    while (v < header.size() && header[v] == ' ') ++v;
    return header.substr(v);
  };
  const std::string_view d = value_of("'descr'");
  if (d.rfind("'<f4'", 0) == 0)
    array.dtype = NpyDtype::float32;
  else if (d.rfind("'<f8'", 0) == 0)
    array.dtype = NpyDtype::float64;
  else if (d.rfind("'<i8'", 0) == 0)
    array.dtype = NpyDtype::int64;
  else
    fail(source, header_start + static_cast<std::size_t>(d.data() - header.data()),
         "dtype must be '<f4', '<f8' or '<i8'");
  if (value_of("'fortran_order'").rfind("False", 0) != 0) {
    fail(source, header_start, "only C-order arrays are supported");
  }
  std::string_view s = value_of("'shape'");
  const std::size_t s_offset = header_start + static_cast<std::size_t>(s.data() - header.data());
  if (s.empty() || s.front() != '(') fail(source, s_offset, "shape must be a tuple");
  const std::size_t close = s.find(')');
  if (close == std::string_view::npos) fail(source, s_offset, "shape tuple is not closed");
  std::string_view dims = s.substr(1, close - 1);
  std::size_t elements = 1;
  while (!dims.empty()) {
    while (!dims.empty() && (dims.front() == ' ' || dims.front() == ',')) dims.remove_prefix(1);
    if (dims.empty()) break;
    std::size_t n = 0;
    std::size_t used = 0;
    while (used < dims.size() && dims[used] >= '0' && dims[used] <= '9') {
      if (n > (SIZE_MAX - 9) / 10) fail(source, s_offset, "dimension too large");
      n = n * 10 + static_cast<std::size_t>(dims[used] - '0');
      ++used;
    }
    if (used == 0) fail(source, s_offset, "shape holds something other than integers");
    if (n != 0 && elements > SIZE_MAX / n) fail(source, s_offset, "shape too large");
    elements *= n;
    array.shape.push_back(n);
    dims.remove_prefix(used);
  }
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
