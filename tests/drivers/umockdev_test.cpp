// The serial and HID paths through the real libserialport and hidapi (hidraw backend), against
// devices emulated by umockdev (seed-summary section 5): this binary runs under
// `umockdev-wrapper` (LD_PRELOAD of libumockdev-preload), which redirects /sys and /dev into a
// test bed built here. A pseudo-terminal backs /dev/ttyUSB0 and /dev/hidraw0; an ioctl handler
// answers what a pty cannot (modem lines for libserialport; report descriptor and feature reports
// for hidapi) and forwards the rest (termios) to the pty.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/hidraw.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <umockdev.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "imukit/core/rng.hpp"
#include "imukit/drivers/devices.hpp"
#include "imukit/drivers/hid_transport.hpp"
#include "imukit/drivers/imukit_codec.hpp"
#include "imukit/drivers/mock_device.hpp"
#include "imukit/drivers/playstation_codec.hpp"
#include "imukit/drivers/reader.hpp"
#include "imukit/drivers/serial_transport.hpp"
#include "imukit/drivers/uri.hpp"
#include "imukit/drivers/witmotion_codec.hpp"
#include "support/test_data.hpp"

namespace imukit::drivers {
namespace {

// A CH340 adapter (what WitMotion boards ship with), an Xsens MTi-300, and a DualShock 4,
// in umockdev's device description format (P: path, E: property, A: attribute, L: link,
// H: binary attribute in hex, N: device node).
constexpr const char* kDevices =
    "P: /devices/pci0000:00/usb1/1-1\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\n"
    "A: idVendor=1a86\nA: idProduct=7523\nA: serial=WT901-0042\nA: manufacturer=QinHeng "
    "Electronics\n"
    "A: product=USB Serial\nA: busnum=1\nA: devnum=5\n\n"
    "P: /devices/pci0000:00/usb1/1-1/1-1:1.0\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_interface\n\n"
    "P: /devices/pci0000:00/usb1/1-1/1-1:1.0/ttyUSB0\nN: ttyUSB0\nE: DEVNAME=/dev/ttyUSB0\n"
    "E: SUBSYSTEM=tty\nA: dev=188:0\nL: device=..\n\n"
    "P: /devices/pci0000:00/usb1/1-3\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\n"
    "A: idVendor=2639\nA: idProduct=0013\nA: serial=037003F8\nA: manufacturer=Xsens\n"
    "A: product=MTi-300 AHRS\nA: busnum=1\nA: devnum=6\n\n"
    "P: /devices/pci0000:00/usb1/1-3/1-3:1.0\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_interface\n\n"
    "P: /devices/pci0000:00/usb1/1-3/1-3:1.0/ttyUSB1\nN: ttyUSB1\nE: DEVNAME=/dev/ttyUSB1\n"
    "E: SUBSYSTEM=tty\nA: dev=188:1\nL: device=..\n\n"
    "P: /devices/pci0000:00/usb1/1-2\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\n"
    "A: idVendor=054c\nA: idProduct=09cc\nA: manufacturer=Sony Interactive Entertainment\n"
    "A: product=Wireless Controller\nA: busnum=1\nA: devnum=7\n\n"
    "P: /devices/pci0000:00/usb1/1-2/1-2:1.3\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_interface\n"
    "A: bInterfaceNumber=03\n\n"
    "P: /devices/pci0000:00/usb1/1-2/1-2:1.3/0003:054C:09CC.0001\nE: SUBSYSTEM=hid\n"
    "E: HID_ID=0003:0000054C:000009CC\nE: HID_NAME=Sony Interactive Entertainment Wireless "
    "Controller\n"
    "E: HID_UNIQ=\nE: HID_PHYS=usb-0000:00:14.0-2/input3\n\n"
    "P: /devices/pci0000:00/usb1/1-2/1-2:1.3/0003:054C:09CC.0001/hidraw/hidraw0\nN: hidraw0\n"
    "E: DEVNAME=/dev/hidraw0\nE: SUBSYSTEM=hidraw\nA: dev=241:0\n";

// Report descriptor: input report 1 (63 bytes), feature report 2 (36 bytes).
constexpr uint8_t kReportDescriptor[] = {0x05, 0x01, 0x09, 0x05, 0xA1, 0x01, 0x85, 0x01, 0x06,
                                         0x00, 0xFF, 0x09, 0x20, 0x15, 0x00, 0x26, 0xFF, 0x00,
                                         0x75, 0x08, 0x95, 0x3F, 0x81, 0x02, 0x85, 0x02, 0x09,
                                         0x24, 0x95, 0x24, 0xB1, 0x02, 0xC0};

void put16(uint8_t* p, int v) {
  p[0] = static_cast<uint8_t>(v & 0xFF);
  p[1] = static_cast<uint8_t>((v >> 8) & 0xFF);
}

// The DualShock 4's calibration feature report (USB layout of hid-playstation).
std::vector<uint8_t> ds4_calibration() {
  std::vector<uint8_t> r(37, 0);
  r[0] = 0x02;
  const int v[17] = {-7,  9,   -7,   8958,  -8972, 8891,  -8871, 8841, -8856,
                     540, 540, 8403, -8441, 8383,  -8022, 7868,  -8568};
  for (int i = 0; i < 17; ++i) put16(&r[1 + 2 * i], v[i]);
  return r;
}

struct Handlers {
  std::atomic<int> modem_ioctls{0};
  std::atomic<int> feature_requests{0};
  int modem_bits = TIOCM_DTR | TIOCM_RTS | TIOCM_CTS | TIOCM_DSR;
};
Handlers g_handlers;

// Modem-line ioctls for the serial ports; termios goes to the pty behind the node.
gboolean on_serial_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* c, gpointer) {
  const gulong req = umockdev_ioctl_client_get_request(c);
  if (req == TIOCMGET || req == TIOCMSET || req == TIOCMBIS || req == TIOCMBIC) {
    GError* e = nullptr;
    UMockdevIoctlData* d =
        umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(c), 0, sizeof(int), &e);
    if (!d) {
      umockdev_ioctl_client_complete(c, -1, EFAULT);
      return TRUE;
    }
    guint8* bytes = nullptr;
    int n = 0;
    umockdev_ioctl_data_retrieve(d, &bytes, &n);
    int v = 0;
    if (bytes && n >= static_cast<int>(sizeof v)) std::memcpy(&v, bytes, sizeof v);
    if (req == TIOCMGET) {
      umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&g_handlers.modem_bits),
                                 sizeof(int));
    } else if (req == TIOCMSET) {
      g_handlers.modem_bits = v;
    } else if (req == TIOCMBIS) {
      g_handlers.modem_bits |= v;
    } else {
      g_handlers.modem_bits &= ~v;
    }
    ++g_handlers.modem_ioctls;
    umockdev_ioctl_client_complete(c, 0, 0);
    return TRUE;
  }
  int err = 0;
  GError* e = nullptr;
  const int r = umockdev_ioctl_client_execute(c, &err, &e);
  if (e) g_error_free(e);
  umockdev_ioctl_client_complete(c, r, err);
  return TRUE;
}

// hidraw ioctls: report descriptor and the calibration feature report.
gboolean on_hid_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* c, gpointer) {
  const gulong req = umockdev_ioctl_client_get_request(c);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(c);
  GError* e = nullptr;
  if (req == HIDIOCGRDESCSIZE) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(int), &e);
    int n = sizeof kReportDescriptor;
    umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&n), sizeof n);
    umockdev_ioctl_client_complete(c, 0, 0);
    return TRUE;
  }
  if (req == HIDIOCGRDESC) {
    UMockdevIoctlData* d =
        umockdev_ioctl_data_resolve(arg, 0, sizeof(hidraw_report_descriptor), &e);
    hidraw_report_descriptor rd{};
    rd.size = sizeof kReportDescriptor;
    std::memcpy(rd.value, kReportDescriptor, sizeof kReportDescriptor);
    umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&rd), sizeof rd);
    umockdev_ioctl_client_complete(c, 0, 0);
    return TRUE;
  }
  if (_IOC_TYPE(req) == 'H' && _IOC_NR(req) == 0x07) {  // HIDIOCGFEATURE(len)
    const std::size_t len = _IOC_SIZE(req);
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, len, &e);
    const auto cal = ds4_calibration();
    umockdev_ioctl_data_update(d, 0, const_cast<guint8*>(cal.data()),
                               static_cast<int>(std::min(len, cal.size())));
    ++g_handlers.feature_requests;
    umockdev_ioctl_client_complete(c, static_cast<glong>(std::min(len, cal.size())), 0);
    return TRUE;
  }
  umockdev_ioctl_client_complete(c, -1, ENOTTY);
  return TRUE;
}

class Umockdev : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* preload = std::getenv("LD_PRELOAD");
    if (!preload || !std::strstr(preload, "libumockdev-preload")) {
      if (imukit::testing::running_in_ci()) FAIL() << "not running under umockdev-wrapper under CI";
      GTEST_SKIP() << "not running under umockdev-wrapper (LD_PRELOAD=libumockdev-preload.so.0): "
                      "umockdev cannot emulate devices here";
    }
    testbed_ = umockdev_testbed_new();
    ASSERT_TRUE(umockdev_in_mock_environment());
    GError* err = nullptr;
    ASSERT_TRUE(umockdev_testbed_add_from_string(testbed_, kDevices, &err))
        << (err ? err->message : "");
    serial_handler_ = umockdev_ioctl_base_new();
    g_signal_connect(serial_handler_, "handle-ioctl", G_CALLBACK(on_serial_ioctl), nullptr);
    ASSERT_TRUE(umockdev_testbed_attach_ioctl(testbed_, "/dev/ttyUSB0", serial_handler_, &err));
    ASSERT_TRUE(umockdev_testbed_attach_ioctl(testbed_, "/dev/ttyUSB1", serial_handler_, &err));
    hid_handler_ = umockdev_ioctl_base_new();
    g_signal_connect(hid_handler_, "handle-ioctl", G_CALLBACK(on_hid_ioctl), nullptr);
    ASSERT_TRUE(umockdev_testbed_attach_ioctl(testbed_, "/dev/hidraw0", hid_handler_, &err));
  }
  void TearDown() override {
    if (testbed_) g_object_unref(testbed_);
    if (serial_handler_) g_object_unref(serial_handler_);
    if (hid_handler_) g_object_unref(hid_handler_);
  }
  // The device's end of the emulated node (the pty master).
  int device_end(const char* node) { return umockdev_testbed_get_dev_fd(testbed_, node); }

  UMockdevTestbed* testbed_ = nullptr;
  UMockdevIoctlBase* serial_handler_ = nullptr;
  UMockdevIoctlBase* hid_handler_ = nullptr;
};

void write_all(int fd, const std::vector<uint8_t>& b) {
  std::size_t done = 0;
  while (done < b.size()) {
    const ssize_t n = ::write(fd, b.data() + done, b.size() - done);
    ASSERT_GT(n, 0) << std::strerror(errno);
    done += static_cast<std::size_t>(n);
  }
}

// Reads what the host wrote to the device within timeout_ms.
std::vector<uint8_t> read_available(int fd, int timeout_ms) {
  std::vector<uint8_t> out;
  uint8_t buf[512];
  pollfd p{fd, POLLIN, 0};
  while (::poll(&p, 1, timeout_ms) > 0) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    out.insert(out.end(), buf, buf + n);
    timeout_ms = 50;
  }
  return out;
}

TEST_F(Umockdev, SerialPortsAreListedWithVidPidSerialAndCodec) {
  const auto ports = list_serial_ports();
  const AttachedDevice* wit = nullptr;
  const AttachedDevice* xsens = nullptr;
  for (const auto& p : ports) {
    if (p.path == "/dev/ttyUSB0") wit = &p;
    if (p.path == "/dev/ttyUSB1") xsens = &p;
  }
  ASSERT_NE(wit, nullptr);
  ASSERT_NE(xsens, nullptr);
  EXPECT_TRUE(wit->usb);
  EXPECT_EQ(wit->vid, 0x1a86);
  EXPECT_EQ(wit->pid, 0x7523);
  EXPECT_EQ(wit->serial, "WT901-0042");
  EXPECT_EQ(wit->codec, "");  // a CH340 says nothing about the board behind it
  EXPECT_EQ(wit->uri, "serial:/dev/ttyUSB0");
  EXPECT_EQ(xsens->vid, 0x2639);
  EXPECT_EQ(xsens->pid, 0x0013);
  EXPECT_EQ(xsens->codec, "xsens");
  EXPECT_EQ(xsens->uri, "serial:/dev/ttyUSB1?codec=xsens");
  // The table picks the codec when the URI names none.
  EXPECT_EQ(open_device("serial:/dev/ttyUSB1").codec->name(), "xsens");
  EXPECT_THROW(open_device("serial:/dev/ttyUSB0"), Error);  // CH340: which codec?
}

TEST_F(Umockdev, SerialOpenSetsTheBaudRate) {
  const int before = g_handlers.modem_ioctls.load();
  SerialTransport port("/dev/ttyUSB0", 921600);
  EXPECT_EQ(port.baud(), 921600);
  EXPECT_GT(g_handlers.modem_ioctls.load(), before);  // libserialport read the modem lines
  EXPECT_EQ(port.describe(), "serial /dev/ttyUSB0 at 921600 baud");
}

TEST_F(Umockdev, WitmotionStreamArrivesAndTheRateCommandIsWrittenBack) {
  const int dev = device_end("/dev/ttyUSB0");
  ASSERT_GE(dev, 0);
  OpenedDevice d = open_device("serial:/dev/ttyUSB0?baud=115200&codec=witmotion&rate=100");
  DeviceReader reader(std::move(d.transport), std::move(d.codec), ReaderOptions{20, 4096, 300});
  reader.start();
  // What the host sent at start: unlock, RRATE = 100 Hz, save.
  const auto cmd = read_available(dev, 2000);
  EXPECT_EQ(cmd, witmotion_rate_commands(100));
  // 301 sample groups written in random chunks (the 301st accel frame closes group 300).
  std::vector<uint8_t> stream;
  for (int i = 0; i <= 300; ++i) {
    const int16_t a[4] = {static_cast<int16_t>(i), 0, 2048, 2400},
                  g[4] = {0, 0, static_cast<int16_t>(-i), 0};
    for (const auto& f : {witmotion_frame(0x51, a), witmotion_frame(0x52, g)})
      stream.insert(stream.end(), f.begin(), f.end());
  }
  Rng rng(1);
  for (std::size_t pos = 0; pos < stream.size();) {
    const std::size_t n = std::min<std::size_t>(1 + rng.uniform_index(64), stream.size() - pos);
    write_all(dev, std::vector<uint8_t>(stream.begin() + static_cast<std::ptrdiff_t>(pos),
                                        stream.begin() + static_cast<std::ptrdiff_t>(pos + n)));
    pos += n;
  }
  ASSERT_TRUE(reader.wait(10'000));
  EXPECT_EQ(reader.end_reason().kind, EndKind::kStopped);  // max_samples reached
  const auto s = reader.take();
  ASSERT_GE(s.size(), 300u);
  for (int i = 0; i < 300; ++i) {
    EXPECT_DOUBLE_EQ(s[i].accel[0], i * 16 * 9.80665 / 32768);
    EXPECT_DOUBLE_EQ(s[i].temperature_c, 24.0);
  }
  EXPECT_EQ(reader.stats().frames_corrupt, 0u);
}

TEST_F(Umockdev, ImukitMockBehindTheSerialPortStreamsThroughLibserialport) {
  const int dev = device_end("/dev/ttyUSB0");
  ASSERT_GE(dev, 0);
  ::fcntl(dev, F_SETFL, ::fcntl(dev, F_GETFL) | O_NONBLOCK);
  // The device side: a mock imukit device in virtual time, bridged to the pty master.
  auto mock = make_mock_device(
      "static", {{"rate", "200"}, {"clock", "virtual"}, {"disconnect_after", "400"}});
  std::atomic<bool> done{false};
  std::thread device([&] {
    std::vector<uint8_t> buf(4096);
    while (!done) {
      const ssize_t n = ::read(dev, buf.data(), buf.size());
      if (n > 0) mock->write(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)));
      const ReadResult r = mock->read(buf, 5);
      if (r.size > 0) {
        std::size_t off = 0;
        while (off < r.size) {
          const ssize_t w = ::write(dev, buf.data() + off, r.size - off);
          if (w > 0)
            off += static_cast<std::size_t>(w);
          else
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
      }
      if (r.end) break;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  });
  OpenedDevice d = open_device("serial:/dev/ttyUSB0?baud=921600&codec=imukit&rate=200");
  DeviceReader reader(std::move(d.transport), std::move(d.codec), ReaderOptions{20, 4096, 400});
  reader.start();
  const bool ended = reader.wait(20'000);
  done = true;
  device.join();
  ASSERT_TRUE(ended);
  const auto s = reader.take();
  ASSERT_EQ(s.size(), 400u);
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_EQ(s[i].sequence, i);
    EXPECT_NEAR(s[i].accel[2], 9.80665, 16 * 9.80665 / 32768);
  }
  EXPECT_EQ(reader.stats().samples_dropped, 0u);
}

TEST_F(Umockdev, DualShock4IsEnumeratedCalibratedAndRead) {
  const auto hid = list_hid_devices();
  const AttachedDevice* pad = nullptr;
  for (const auto& h : hid) {
    if (h.path == "/dev/hidraw0") pad = &h;
  }
  ASSERT_NE(pad, nullptr);
  EXPECT_EQ(pad->vid, 0x054c);
  EXPECT_EQ(pad->pid, 0x09cc);
  EXPECT_EQ(pad->codec, "dualshock4");
  EXPECT_EQ(pad->uri, "hid:054c:09cc");

  OpenedDevice d = open_device("hid:054c:09cc");  // codec from the VID/PID table
  ASSERT_EQ(d.codec->name(), "dualshock4");
  auto* transport = dynamic_cast<ReportTransport*>(d.transport.get());
  ASSERT_NE(transport, nullptr);
  // The calibration feature report through hidapi's HIDIOCGFEATURE.
  const int before = g_handlers.feature_requests.load();
  const auto cal = transport->get_feature_report(0x02, 37);
  EXPECT_EQ(g_handlers.feature_requests.load(), before + 1);
  EXPECT_EQ(cal, ds4_calibration());
  d.codec->on_feature_report(0x02, cal);

  const int dev = device_end("/dev/hidraw0");
  ASSERT_GE(dev, 0);
  std::vector<Sample> out;
  std::vector<uint8_t> buf(128);
  for (int k = 0; k < 20; ++k) {
    std::vector<uint8_t> r(64, 0);
    r[0] = 0x01;
    r[7] = static_cast<uint8_t>(((k + (k >= 10)) & 0x3F) << 2);  // report 10 is lost
    put16(&r[10], (1000 + 750 * k) & 0xFFFF);
    put16(&r[13], 1000);  // gyro x
    put16(&r[19], 8192);  // accel x
    write_all(dev, r);
    const ReadResult rr = transport->read_report(buf, 2000);  // one report per read, as hidraw
    ASSERT_EQ(rr.size, 64u);
    d.codec->feed(std::span<const uint8_t>(buf.data(), rr.size), rr.host_time, out);
  }
  ASSERT_EQ(out.size(), 20u);
  EXPECT_EQ(d.codec->stats().samples_dropped, 1u);
  // Calibrated as hid-playstation does: 1000 * 1080 / 17930 deg/s; (8192 + 19) * 2 / 16844 g.
  EXPECT_NEAR(out[0].gyro[0], 1000.0 * 1080 / 17930 * 3.14159265358979323846 / 180, 1e-12);
  EXPECT_NEAR(out[0].accel[0], 8211.0 * 2 / 16844 * 9.80665, 1e-12);
}

// Pulls the cable: closes the device's end of the pty (and parks /dev/null on the descriptor
// number, which the test bed closes later).
void unplug(int dev) {
  const int null_fd = ::open("/dev/null", O_RDWR);
  ASSERT_GE(null_fd, 0);
  ASSERT_EQ(::dup2(null_fd, dev), dev);  // atomically replaces (and so closes) the pty master
  ::close(null_fd);
}

TEST_F(Umockdev, SerialUnplugEndsTheStreamWithTheReasonAndKeepsTheSamples) {
  const int dev = device_end("/dev/ttyUSB0");
  ASSERT_GE(dev, 0);
  OpenedDevice d = open_device("serial:/dev/ttyUSB0?baud=115200&codec=witmotion");
  DeviceReader reader(std::move(d.transport), std::move(d.codec), ReaderOptions{20, 4096, 0});
  reader.start();
  std::vector<uint8_t> stream;
  for (int i = 0; i < 50; ++i) {
    const int16_t a[4] = {static_cast<int16_t>(i), 0, 0, 0}, g[4] = {0, 0, 0, 0};
    for (const auto& f : {witmotion_frame(0x51, a), witmotion_frame(0x52, g)})
      stream.insert(stream.end(), f.begin(), f.end());
  }
  write_all(dev, stream);
  for (int k = 0; k < 200 && reader.samples_total() < 49; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(reader.samples_total(), 49u);  // the 50th group is still open
  unplug(dev);
  ASSERT_TRUE(reader.wait(10'000));
  const EndReason end = reader.end_reason();
  EXPECT_EQ(end.kind, EndKind::kEndOfStream) << end.message;
  EXPECT_NE(end.message.find("/dev/ttyUSB0"), std::string::npos) << end.message;
  // finish() handed out the last, complete-looking group too: nothing received is lost.
  EXPECT_EQ(reader.take().size(), 50u);
}

TEST_F(Umockdev, DualShock4ThroughTheReaderAndUnplug) {
  OpenedDevice d = open_device("hid:054c:09cc");
  DeviceReader reader(std::move(d.transport), std::move(d.codec), ReaderOptions{20, 4096, 0});
  const int before = g_handlers.feature_requests.load();
  reader.start();  // reads the calibration feature report first
  const int dev = device_end("/dev/hidraw0");
  ASSERT_GE(dev, 0);
  for (int k = 0; k < 10; ++k) {
    std::vector<uint8_t> r(64, 0);
    r[0] = 0x01;
    r[7] = static_cast<uint8_t>(k << 2);
    put16(&r[19], 8192);
    write_all(dev, r);
    // hidraw hands out one report per read; a pty would merge two, so wait for each.
    for (int w = 0; w < 500 && reader.samples_total() < static_cast<uint64_t>(k + 1); ++w) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ASSERT_EQ(reader.samples_total(), static_cast<uint64_t>(k + 1));
  }
  EXPECT_EQ(g_handlers.feature_requests.load(), before + 1);
  unplug(dev);
  ASSERT_TRUE(reader.wait(10'000));
  EXPECT_EQ(reader.end_reason().kind, EndKind::kEndOfStream) << reader.end_reason().message;
  const auto s = reader.take();
  ASSERT_EQ(s.size(), 10u);
  EXPECT_NEAR(s[9].accel[0], 8211.0 * 2 / 16844 * 9.80665, 1e-12);  // calibrated
}

}  // namespace
}  // namespace imukit::drivers
