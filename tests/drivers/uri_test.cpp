#include "drivers/uri.hpp"

#include <gtest/gtest.h>

#include "core/error.hpp"

#include "drivers/devices.hpp"
#include "tests/support/test_data.hpp"

namespace imukit::drivers {
namespace {

int64_t error_offset(const std::string& uri) {
  try {
    parse_device_uri(uri);
  } catch (const Error& e) {
    EXPECT_TRUE(e.where().has_value()) << e.what();
    return e.where() ? e.where()->byte_offset.value_or(-1) : -1;
  }
  ADD_FAILURE() << "no error for " << uri;
  return -1;
}

TEST(DeviceUri, ParsesSchemeAddressAndKeys) {
  const DeviceUri u = parse_device_uri("serial:/dev/ttyUSB0?baud=921600&codec=witmotion");
  EXPECT_EQ(u.scheme, "serial");
  EXPECT_EQ(u.address, "/dev/ttyUSB0");
  EXPECT_EQ(u.keys.at("baud"), "921600");
  EXPECT_EQ(u.keys.at("codec"), "witmotion");
  EXPECT_EQ(parse_device_uri("hid:054c:09cc").address, "054c:09cc");
  EXPECT_EQ(parse_device_uri("file:capture.bin?codec=xsens").keys.at("codec"), "xsens");
  EXPECT_EQ(parse_device_uri("mock:static?rate=400").keys.at("rate"), "400");
}

TEST(DeviceUri, ErrorsPointAtTheOffendingByte) {
  EXPECT_EQ(error_offset("ttyUSB0"), 0);
  EXPECT_EQ(error_offset("bluetooth:aa"), 0);
  EXPECT_EQ(error_offset("serial:?baud=9600"), 7);
  EXPECT_EQ(error_offset("serial:/dev/x?baud=1&speed=2"), 21);
  EXPECT_EQ(error_offset("serial:/dev/x?baud"), 14);
  EXPECT_EQ(error_offset("mock:static?rate=1&rate=2"), 19);
  EXPECT_EQ(error_offset("hid:54c-9cc"), 4);
  EXPECT_EQ(error_offset("usb:12345:1"), 4);
}

TEST(DeviceUri, FileReplayDecodesWithTheNamedCodec) {
  testing::TempDir dir;
  const std::string path = (dir / "cap.txt").string();
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("1,0,0,9.8,0,0,0\n2,0,0,9.8,0,0,0\n", f);
    std::fclose(f);
  }
  OpenedDevice d = open_device("file:" + path + "?codec=text&time_unit=s");
  EXPECT_EQ(d.codec->name(), "text");
  auto* bytes = dynamic_cast<ByteTransport*>(d.transport.get());
  ASSERT_NE(bytes, nullptr);
  EXPECT_FALSE(bytes->can_write());
  EXPECT_THROW(open_device("file:" + path), Error);  // which codec?
  try {
    open_device("file:/nonexistent/x.bin?codec=xsens");
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

TEST(KnownDevices, TableNamesTheCodecs) {
  EXPECT_EQ(std::string(find_known_device(0x054c, 0x09cc, true)->codec), "dualshock4");
  EXPECT_EQ(std::string(find_known_device(0x054c, 0x0ce6, true)->codec), "dualsense");
  EXPECT_EQ(std::string(find_known_device(0x2639, 0x0013, false)->codec), "xsens");
  EXPECT_FALSE(find_known_device(0x054c, 0x09cc, false).has_value());
}

}  // namespace
}  // namespace imukit::drivers
