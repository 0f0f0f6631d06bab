#include "imukit/core/npy.hpp"

#include <gtest/gtest.h>
#include <cstring>
#include <fstream>
#include <sstream>

#include "imukit/core/error.hpp"
#include "support/test_data.hpp"

namespace imukit {
namespace {

TEST(Npy, HeaderIsNumpyVersion1AlignedTo64Bytes) {
  testing::TempDir dir;
  const std::string path = (dir / "x.npy").string();
  const std::vector<float> data = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f};
  const std::vector<std::size_t> shape = {2, 3};
  write_npy(path, std::span<const float>(data), shape);
  const std::string file = testing::read_file(path);
  ASSERT_EQ(file.size(), 128u + 24u);  // 10 + 60 + 1 bytes of header round up to 128
  EXPECT_EQ(file.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  EXPECT_EQ(static_cast<unsigned char>(file[8]) + 256 * static_cast<unsigned char>(file[9]), 118);
  EXPECT_EQ(
      file.substr(10, 118).rfind("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }", 0),
      0u);
  EXPECT_EQ(file[127], '\n');
  float third;
  std::memcpy(&third, file.data() + 128 + 8, 4);
  EXPECT_EQ(third, 3.0f);
}

TEST(Npy, RoundTripsEachDtypeAndShape) {
  testing::TempDir dir;
  const std::vector<double> d = {0.1, -2.5, 1e300, 4.9406564584124654e-324};
  const std::vector<int64_t> i = {INT64_MIN, -1, 0, INT64_MAX, 7};
  const std::vector<std::size_t> shape_d = {4};
  const std::vector<std::size_t> shape_i = {5, 1};
  write_npy((dir / "d.npy").string(), std::span<const double>(d), shape_d);
  write_npy((dir / "i.npy").string(), std::span<const int64_t>(i), shape_i);
  const NpyArray a = read_npy((dir / "d.npy").string());
  EXPECT_EQ(a.dtype, NpyDtype::float64);
  EXPECT_EQ(a.shape, shape_d);
  EXPECT_EQ(a.to_double(), d);
  EXPECT_NE(testing::read_file((dir / "d.npy").string()).find("'shape': (4,)"), std::string::npos);
  const NpyArray b = read_npy((dir / "i.npy").string());
  EXPECT_EQ(b.dtype, NpyDtype::int64);
  EXPECT_EQ(b.shape, shape_i);
  ASSERT_EQ(b.bytes.size(), 40u);
  int64_t first;
  std::memcpy(&first, b.bytes.data(), 8);
  EXPECT_EQ(first, INT64_MIN);
  const std::vector<std::size_t> empty_shape = {0, 3};
  write_npy((dir / "e.npy").string(), std::span<const float>(), empty_shape);
  EXPECT_EQ(read_npy((dir / "e.npy").string()).size(), 0u);
}

TEST(Npy, ShapeMismatchIsAnError) {
  testing::TempDir dir;
  const std::vector<float> data(5);
  const std::vector<std::size_t> shape = {2, 3};
  EXPECT_THROW(write_npy((dir / "x.npy").string(), std::span<const float>(data), shape), Error);
}

TEST(Npy, MalformedFilesNameTheByteOffset) {
  testing::TempDir dir;
  const std::vector<double> d = {1, 2, 3};
  const std::vector<std::size_t> shape = {3};
  write_npy((dir / "ok.npy").string(), std::span<const double>(d), shape);
  const std::string good = testing::read_file((dir / "ok.npy").string());
  const auto parse = [](const std::string& bytes) {
    return parse_npy(
        std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()),
        "m.npy");
  };
  EXPECT_NO_THROW(parse(good));
  const auto expect = [&](std::string bytes, const std::string& part) {
    try {
      parse(bytes);
      ADD_FAILURE() << "accepted: " << part;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("m.npy: byte"), std::string::npos) << e.what();
    }
  };
  expect("not numpy at all", "magic");
  expect(good.substr(0, good.size() - 1), "needs 24 bytes of data but the file has 23");
  std::string fortran = good;
  fortran.replace(fortran.find("False"), 5, "True ");
  expect(fortran, "C-order");
  std::string dtype = good;
  dtype.replace(dtype.find("<f8"), 3, ">f8");
  expect(dtype, "dtype");
  std::string longer = good;
  longer[8] = '\xff';
  longer[9] = '\xff';
  expect(longer, "header longer than the file");
}

// Found in review: the header was searched for each key's text, so `(3 1)`, a dict never closed
// and a key inside another value were read; a 9-byte start of a valid file was "missing the
// magic". The header is a Python literal dict, parsed strictly, each error at its byte.
TEST(Npy, HeaderIsParsedAsAPythonDictWithByteOffsets) {
  const std::string data(24, '\0');  // 3 doubles
  const auto file = [&](const std::string& dict) {
    const std::string header = dict + "\n";
    std::string f("\x93NUMPY\x01\x00", 8);
    f += static_cast<char>(header.size() & 0xFF);
    f += static_cast<char>(header.size() >> 8);
    return f + header + data;
  };
  const auto error = [](const std::string& bytes) -> std::string {
    try {
      parse_npy(std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data()),
                                           bytes.size()),
                "h.npy");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string head = "{'descr': '<f8', 'fortran_order': False, 'shape': ";
  EXPECT_EQ(error(file(head + "(3 1), }")),
            "h.npy: byte 63: not a valid .npy: expected ',' or ')' after a dimension of the shape");
  EXPECT_EQ(error(file(head + "(3,), ")),
            "h.npy: byte 67: not a valid .npy: header dict is not closed (expected a key in "
            "quotes, or '}' before its end)");
  EXPECT_EQ(error(file(head + "(3,), 'x': 'fortran_order': True}")),
            "h.npy: byte 66: not a valid .npy: unknown key 'x' (a .npy header has descr, "
            "fortran_order and shape)");
  EXPECT_EQ(error(file(head + "(3), }")),
            "h.npy: byte 61: not a valid .npy: a one-dimensional shape is written (N,)");
  EXPECT_EQ(error(file(head + "(3,), 'descr': '<f8'}")),
            "h.npy: byte 66: not a valid .npy: key 'descr' given twice");
  EXPECT_EQ(error(file(head + "(3,)} x")),
            "h.npy: byte 66: not a valid .npy: text after the header's closing '}'");
  EXPECT_EQ(error(file("{'descr': '<f8', 'shape': (3,)}")),
            "h.npy: byte 10: not a valid .npy: header has no 'fortran_order'");
  // What Python writes or accepts: any key order, double quotes, no trailing comma, blanks.
  EXPECT_EQ(error(file("{'shape': (3,), \"descr\": \"<f8\", 'fortran_order': False}")), "");
  EXPECT_EQ(error(file(head + "( 3 , ) , }   ")), "");
  // () is a scalar: one value.
  EXPECT_NE(error(file(head + "(), }")).find("shape needs 8 bytes of data but the file has 24"),
            std::string::npos);
  // Truncated inside the preamble: said so, at the end of the file.
  const std::string good = file(head + "(3,), }");
  EXPECT_EQ(error(good.substr(0, 9)),
            "h.npy: byte 9: not a valid .npy: truncated: 9 bytes, but the magic, version and "
            "header length take 10");
  EXPECT_EQ(error(good.substr(0, 3)),
            "h.npy: byte 3: not a valid .npy: truncated: 3 bytes, but the magic, version and "
            "header length take 10");
  EXPECT_EQ(error("\x93NUMPX\x01"),
            "h.npy: byte 0: not a valid .npy: missing the \\x93NUMPY magic");
  EXPECT_EQ(error(""), "h.npy: byte 0: not a valid .npy: missing the \\x93NUMPY magic");
}

}  // namespace
}  // namespace imukit
