// NumPy .npy files (format version 1.0): what Python users load with one numpy.load. imukit
// writes C-order little-endian float32, float64 and int64 arrays (each file through a temporary
// renamed over it), and reads the same back
// (strictly: anything else is rejected with the byte offset of the problem).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace imukit {

enum class NpyDtype { float32, float64, int64 };

// Writes `data` (C order) with the given shape; the product of shape must equal data.size().
void write_npy(const std::string& path, std::span<const float> data,
               std::span<const std::size_t> shape);
void write_npy(const std::string& path, std::span<const double> data,
               std::span<const std::size_t> shape);
void write_npy(const std::string& path, std::span<const int64_t> data,
               std::span<const std::size_t> shape);

struct NpyArray {
  NpyDtype dtype = NpyDtype::float64;
  std::vector<std::size_t> shape;
  std::vector<std::byte> bytes;  // little-endian, C order

  std::size_t size() const;
  // The values converted to double (int64 values beyond 2^53 lose precision).
  std::vector<double> to_double() const;
};

NpyArray read_npy(const std::string& path);
NpyArray parse_npy(std::span<const std::byte> file, const std::string& source_name);

}  // namespace imukit
