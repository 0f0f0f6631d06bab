// imukit devices: lists the serial ports and HID devices attached, with the codec that would
// read each (known VID/PID table, drivers/devices.hpp), and with --read URI reads a device for a
// while and reports what arrived: samples, rate, drops, corruption, and why the stream ended.
#include <fmt/core.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "command.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/error.hpp"
#include "imukit/drivers/devices.hpp"
#include "imukit/drivers/reader.hpp"
#include "imukit/drivers/uri.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct DevicesOptions {
  bool all = false;
  std::string read_uri;
  double seconds = 2.0;
};

int list_devices(const DevicesOptions& o) {
  using drivers::AttachedDevice;
  const std::vector<AttachedDevice> serial = drivers::list_serial_ports();
  const std::vector<AttachedDevice> hid = drivers::list_hid_devices();
  int shown = 0;
  auto show = [&](const AttachedDevice& d) {
    if (!o.all && !d.usb) return;  // built-in UARTs without a device behind them
    ++shown;
    const std::string id = d.usb ? fmt::format("{:04x}:{:04x}", d.vid, d.pid) : std::string("-");
    fmt::print("{:<7} {:<20} {:<10} {:<12} {}\n", d.kind, d.path, id,
               d.codec.empty() ? "?" : d.codec, d.description);
    fmt::print("        uri: {}{}\n", d.uri,
               d.serial.empty() ? "" : fmt::format("   serial: {}", d.serial));
  };
  fmt::print("{:<7} {:<20} {:<10} {:<12} {}\n", "kind", "path", "vid:pid", "codec", "description");
  for (const auto& d : serial) show(d);
  for (const auto& d : hid) show(d);
  if (shown == 0) {
    fmt::print(
        "(no USB serial ports or HID devices found; no hardware? try: imukit devices --read "
        "\"mock:static?rate=400\")\n");
  }
  return 0;
}

int read_device(const DevicesOptions& o) {
  drivers::OpenedDevice dev = drivers::open_device(o.read_uri);
  const std::string what = dev.transport->describe();
  const std::string codec = dev.codec->name();
  const bool replay = dev.transport->replay();
  const std::string when_silent = dev.transport->when_silent();
  drivers::DeviceReader reader(std::move(dev.transport), std::move(dev.codec));
  reader.start();
  const bool ended = reader.wait(static_cast<int>(o.seconds * 1000));
  if (!ended) reader.stop();
  const std::vector<drivers::Sample> s = reader.take();
  const drivers::CodecStats st = reader.stats();
  const drivers::EndReason end = reader.end_reason();
  fmt::print("{} ({} codec): {} samples\n", what, codec, s.size());
  if (s.size() >= 2) {
    const bool dev_time = s.front().has_device_time && s.back().has_device_time;
    const TimeNs span = dev_time ? s.back().device_time - s.front().device_time
                                 : s.back().host_time - s.front().host_time;
    if (!dev_time && replay) {
      fmt::print("  rate {}\n", capture::kRateUnknownNote);
    } else if (span > 0) {
      // By the sample counter, so dropped samples do not lower the rate.
      const auto steps = static_cast<double>(s.back().sequence - s.front().sequence);
      fmt::print("  rate {:.3f} Hz by the {} clock\n", steps / to_seconds(span),
                 dev_time ? "device" : "host");
    }
    const auto& a = s.back();
    fmt::print("  last sample: accel {:.4f} {:.4f} {:.4f} m/s^2, gyro {:.5f} {:.5f} {:.5f} rad/s\n",
               a.accel[0], a.accel[1], a.accel[2], a.gyro[0], a.gyro[1], a.gyro[2]);
  }
  fmt::print("  bytes {} (accepted {}, discarded {}), frames ok {}, corrupt {}, other {}\n",
             st.bytes_received, st.bytes_accepted, st.bytes_discarded, st.frames_ok,
             st.frames_corrupt, st.frames_other);
  // Non-finite samples are also in dropped (and their frames in corrupt); samples before the
  // start belong to an earlier session's stream and are no loss (CodecStats).
  fmt::print(
      "  samples decoded {}, dropped {} (with a non-finite value {}), counter resets {}, device "
      "errors {}, before the stream's start {} (not losses)\n",
      st.samples_decoded, st.samples_dropped, st.samples_non_finite, st.counter_resets,
      st.device_errors, st.samples_before_start);
  if (st.feature_reports_failed > 0) {
    fmt::print(
        "  calibration reports unreadable {}: the nominal scale used, as the Linux driver does\n",
        st.feature_reports_failed);
  }
  if (st.samples_stale > 0) {
    fmt::print(
        "  stale samples {} (frames repeated or delivered late: not handed out again, not "
        "losses)\n",
        st.samples_stale);
  }
  const char* kinds[] = {"running", "stopped", "end of stream", "error"};
  fmt::print("  ended: {}{}\n", kinds[static_cast<int>(end.kind)],
             end.message.empty() ? "" : ": " + end.message);
  if (st.bytes_received == 0 && end.kind == drivers::EndKind::kStopped)
    fmt::print("  nothing arrived in {:g} s: {}\n", o.seconds, when_silent);
  if (s.empty()) {
    // A test read that gave no sample failed, as `record` says of such a device (found in review:
    // garbage read as 0 samples, 1 corrupt frame and exit 0).
    std::fflush(stdout);
    throw IoError(
        fmt::format("devices: no samples from {} (see the counts and the end above)", o.read_uri));
  }
  return end.kind == drivers::EndKind::kError ? kIo : kOk;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    devices,
    CommandSpec{
        "devices",
        "List attached IMUs (serial, HID) with the codec that reads them; --read tests one", 5,
        [](CLI::App& sub) -> std::function<int()> {
          auto o = std::make_shared<DevicesOptions>();
          sub.add_flag("--all", o->all, "Also list serial ports that are not USB devices");
          sub.add_option(
              "--read", o->read_uri,
              "Read this device URI for a while and report samples, rate, drops and errors");
          sub.add_option("--seconds", o->seconds, "How long --read reads (default 2)")
              ->check(real_in(0, 86400, "s", LowEnd::open));
          sub.footer(
              "Device URIs (docs/devices.md): serial:/dev/ttyUSB0?baud=921600&codec=witmotion,\n"
              "hid:054c:09cc, usb:2639:0013?codec=xsens, file:capture.bin?codec=xsens,\n"
              "fd:0?codec=text, mock:static?rate=400, mock:poses?hold_s=5&move_s=2\n\n"
              "Examples:\n"
              "  imukit devices\n"
              "  imukit devices --read \"mock:static?rate=400&drop=0.01\" --seconds 3\n");
          return [o] { return o->read_uri.empty() ? list_devices(*o) : read_device(*o); };
        }});

}  // namespace imukit::cli
