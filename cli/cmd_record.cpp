// imukit record: record one or more devices into an MCAP file, with live statistics, clean
// stops (duration, sample count, Ctrl-C / SIGTERM, device loss) and the clock fit at the end.
#include <fmt/core.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <set>
#include <thread>

#include "command.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/error.hpp"
#include "imukit/drivers/codecs.hpp"
#include "imukit/drivers/transport.hpp"
#include "imukit/drivers/uri.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct RecordArgs {
  std::vector<std::string> uris;
  std::string output;
  double duration_s = 0.0;
  uint64_t samples = 0;
  double rate_hz = 0.0;
  double no_data_timeout_s = 10.0;
  bool no_refit = false;
  bool no_taps = false;
  std::string guide;
  int poses = 12;
  double init_static_s = 10.0;
  bool poses_given = false, init_static_given = false;
};

// Lines typed while recording become /events markers ("note", the text typed; an empty line is
// a "mark"). The reading thread blocks on stdin, so it is detached and shares its queue.
struct Markers {
  std::mutex mutex;
  std::vector<Event> pending;
};

void start_marker_thread(const std::shared_ptr<Markers>& markers) {
  std::thread([markers] {
    std::string line;
    while (std::getline(std::cin, line)) {
      const std::lock_guard lock(markers->mutex);
      markers->pending.push_back({drivers::host_now(), line.empty() ? "mark" : "note", line});
    }
  }).detach();
}

// A stream name from a URI: the mock kind, or the device path's last part; made unique.
std::string stream_name(const drivers::DeviceUri& uri, std::set<std::string>& used) {
  std::string base = uri.scheme == "mock" ? "mock_" + uri.address
                                          : std::filesystem::path(uri.address).filename().string();
  for (char& c : base) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (base.empty()) base = uri.scheme;
  std::string name = base;
  for (int k = 2; used.count(name); ++k) name = fmt::format("{}_{}", base, k);
  used.insert(name);
  return name;
}

std::string progress_line(const std::vector<capture::DeviceProgress>& devices) {
  std::string line;
  for (const auto& d : devices) {
    if (!line.empty()) line += " | ";
    line += fmt::format("{}: {} samples {}, dropped {}, corrupt {}, backlog max {}{}", d.name,
                        d.samples,
                        d.rate_unknown ? std::string("rate unknown (replay without sample clock)")
                                       : fmt::format("{:.1f} Hz", d.rate_hz),
                        d.dropped, d.frames_corrupt, d.queue_high_water,
                        d.backpressure ? fmt::format(", RECORDER LOST {}", d.backpressure) : "");
  }
  return line;
}

// Whether the device of `uri` takes a rate= (its codec reads it, also when it only decodes), as
// far as the URI says; a device found by its USB id (no codec named) is assumed to.
bool takes_a_rate(const drivers::DeviceUri& uri) {
  const std::string codec = drivers::codec_named_by(uri);
  if (codec.empty()) return true;
  const std::vector<std::string> keys = drivers::codec_keys(codec, !drivers::sends_commands(uri));
  return std::find(keys.begin(), keys.end(), "rate") != keys.end();
}

// The devices of the command line, each with its stream name. A --rate goes into the URIs
// without their own rate= whose device takes one; the others are named in a note (found in
// review: appended to a text replay's URI, it made the URI check refuse a key never typed).
std::vector<capture::SessionDevice> open_devices(const RecordArgs& args) {
  std::vector<capture::SessionDevice> devices;
  std::set<std::string> used;
  for (std::string text : args.uris) {
    // Parsed once: the stream name reads only scheme and address, which a rate= leaves alone.
    const drivers::DeviceUri uri = drivers::parse_device_uri(text);
    if (args.rate_hz > 0 && uri.keys.count("rate") == 0) {
      if (takes_a_rate(uri)) {
        text += (text.find('?') == std::string::npos ? "?" : "&") +
                fmt::format("rate={}", args.rate_hz);
      } else {
        fmt::print(stderr, "imukit: note: --rate {:g}: {} has no rate to configure; not used\n",
                   args.rate_hz, text);
      }
    }
    capture::SessionDevice d;
    d.name = stream_name(uri, used);
    d.uri = text;
    d.device = drivers::open_device(text);
    devices.push_back(std::move(d));
  }
  return devices;
}

// --guide multipos: the pose guide, and what it says to the person holding the device.
void add_pose_guide(const RecordArgs& args, bool tty, capture::SessionOptions& options) {
  if (args.guide != "multipos") throw UsageError("--guide: the only guide is multipos");
  capture::PoseGuideOptions guide;
  guide.poses_wanted = args.poses;
  guide.initial_still_s = args.init_static_s;
  options.guide = guide;
  options.on_pose = [&args, tty](const std::string& device, const capture::PoseEvent& e) {
    if (tty) fmt::print("\n");
    if (e.initial) {
      fmt::print("{}: held still for {:g} s (the initial static period): done\n", device,
                 args.init_static_s);
    }
    if (e.kind == capture::PoseEvent::Kind::repeated_pose) {
      fmt::print("{}: this orientation is already recorded: turn to a new one\n", device);
    } else if (e.kind == capture::PoseEvent::Kind::done) {
      fmt::print("{}: pose {} of {} held: done\n", device, e.count, args.poses);
    } else {
      fmt::print("{}: pose {} of {} held: rotate to a new orientation and hold it still for 2 s\n",
                 device, e.count, args.poses);
    }
    std::fflush(stdout);
  };
}

// Per device: samples, rate, every kind of loss, the backlog and the clock fit. Returns the
// names of the devices that sent nothing ("" if none).
std::string print_report(const capture::SessionReport& report) {
  fmt::print("stopped: {}\n", report.stop_reason);
  const std::size_t queue_capacity = capture::SessionOptions{}.queue_capacity;
  std::string silent;
  for (const auto& d : report.devices) {
    // The backlog is how far the writer fell behind the device (the queue between them): near
    // the capacity, samples were about to be lost.
    // Named when there are any, in the words of `devices --read`: samples with a non-finite value
    // (among the codec's losses and its corrupt frames), and two kinds that are no loss, samples
    // of the device's stream before this recording's began and stale ones (found in review: the
    // metadata and `info` had them, this report did not).
    fmt::print(
        "{}: {} samples {}; missing (counter gaps) {}, lost as the codec counts them "
        "{}{}, corrupt frames {}, lost by the recorder {}, largest backlog {} of {} samples; "
        "ended: {}\n",
        d.name, d.samples,
        d.rate_unknown ? fmt::format("(rate {})", capture::kRateUnknownNote)
                       : fmt::format("at {:.3f} Hz", d.rate_hz),
        d.dropped, d.codec_dropped,
        d.non_finite > 0 ? fmt::format(" (with a non-finite value {})", d.non_finite) : "",
        d.frames_corrupt, d.backpressure, d.queue_high_water, queue_capacity, d.end_reason);
    if (d.before_start > 0)
      fmt::print("  samples before the stream's start {} (not losses)\n", d.before_start);
    if (d.feature_reports_failed > 0) {
      fmt::print(
          "  calibration reports unreadable {}: the nominal scale used, as the Linux driver "
          "does\n",
          d.feature_reports_failed);
    }
    if (d.stale > 0) {
      fmt::print(
          "  stale samples {} (frames repeated or delivered late: not handed out again, not "
          "losses)\n",
          d.stale);
    }
    if (d.samples == 0) silent += (silent.empty() ? "" : ", ") + d.name;
    if (d.clock.packets > 1) {
      fmt::print(
          "  clock: device {:+.3f} ppm, receive jitter mean {:.1f} us, std {:.1f} us, max {:.1f} "
          "us{}\n",
          d.clock.skew_ppm, d.clock.jitter_mean_s * 1e6, d.clock.jitter_std_s * 1e6,
          d.clock.jitter_max_s * 1e6,
          d.clock.ping_corrected
              ? fmt::format(
                    "; latency {:.1f} us from {} time-sync pings (best round trip {:.1f} us)",
                    d.clock.latency_correction_s * 1e6, d.clock.pings,
                    d.clock.best_round_trip_s * 1e6)
              : "; no time-sync pings: times are receive times at the smallest latency seen");
      if (d.clock.segments > 1 || d.clock.outliers > 0) {
        fmt::print(
            "  clock: {} restart(s) of the device clock (each stretch fitted on its own), {} "
            "sample(s) with a tick that fitted neither side, timed from their neighbours\n",
            d.clock.segments - 1, d.clock.outliers);
      }
    }
  }
  return silent;
}

int run_record(const RecordArgs& args) {
  if (std::filesystem::path(args.output).extension() != ".mcap") {
    throw UsageError(fmt::format("record: the output must be a .mcap file, got {}",
                                 quote_excerpt(args.output, 200)));
  }
  // Before any device is opened (a device may be reset or configured by opening it) and before
  // "recording ..." is printed: a crashed recording's partial file stops this one.
  capture::check_no_partial_recording(args.output);
  std::vector<capture::SessionDevice> devices = open_devices(args);
  // A virtual-clock mock makes data as fast as the disk takes it: without a limit it would fill
  // the disk before anyone reached for Ctrl-C. A guide is a limit only if it can complete.
  const bool all_virtual = std::all_of(
      devices.begin(), devices.end(),
      [](const capture::SessionDevice& d) { return d.device.transport->virtual_time(); });
  if (all_virtual && args.duration_s == 0 && args.samples == 0) {
    throw UsageError(
        "record: a virtual-clock mock runs as fast as it can: give --duration or --samples");
  }
  // Ctrl-C, kill and a closed terminal stop the recording cleanly (flushed, refitted, closed).
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);
  // A closed pipe (stdout, or an fd: device) and a file over the size limit would kill the
  // process with the file open; ignored, they are write errors (EPIPE, EFBIG) that end the
  // device or the recording with its error and exit 3, the file closed.
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);
  const bool tty = ::isatty(STDOUT_FILENO) != 0;
  auto last_plain = std::chrono::steady_clock::now();
  capture::SessionOptions options;
  options.path = args.output;
  options.duration_s = args.duration_s;
  options.max_samples = args.samples;
  options.no_data_timeout_s = args.no_data_timeout_s;
  options.finalize = !args.no_refit;
  options.stop = &g_stop;
  options.detect_taps = !args.no_taps;
  // Without the guide they did nothing, silently (review, 2026-11-27).
  if (args.guide.empty() && (args.poses_given || args.init_static_given))
    throw UsageError(
        "record: --poses and --init-static are --guide multipos's; add --guide multipos");
  if (!args.guide.empty()) add_pose_guide(args, tty, options);
  if (::isatty(STDIN_FILENO)) {
    auto markers = std::make_shared<Markers>();
    start_marker_thread(markers);
    options.take_markers = [markers](std::vector<Event>& out) {
      const std::lock_guard lock(markers->mutex);
      out.swap(markers->pending);
    };
    fmt::print("type a line and Enter to mark the recording (empty line: a plain mark)\n");
  }
  options.progress = [&](const std::vector<capture::DeviceProgress>& p) {
    if (tty) {
      fmt::print("\r\033[K{}", progress_line(p));
      std::fflush(stdout);
    } else if (std::chrono::steady_clock::now() - last_plain > std::chrono::seconds(5)) {
      last_plain = std::chrono::steady_clock::now();
      fmt::print("{}\n", progress_line(p));
      std::fflush(stdout);
    }
  };
  fmt::print("recording {} device(s) to {}{}\n", devices.size(), args.output,
             args.duration_s > 0 ? fmt::format(" for {} s", args.duration_s)
             : args.samples > 0  ? fmt::format(" until {} samples per device", args.samples)
                                 : std::string(" until Ctrl-C"));
  if (options.guide) {
    fmt::print(
        "guided multi-position capture: first hold the device still for {:g} s (the initial "
        "static period that `imukit calibrate` measures the stillness threshold on), then in {} "
        "different orientations, 2 s each\n",
        args.init_static_s, args.poses);
  }
  const capture::SessionReport report = capture::record_session(std::move(devices), options);
  if (tty) fmt::print("\n");
  const std::string silent = print_report(report);
  fmt::print("wrote {}\n", args.output);
  if (std::fflush(stdout) != 0) {
    throw IoError(
        fmt::format("record: the report could not be written to standard output: {} "
                    "(the recording {} is complete)",
                    std::strerror(errno), args.output));
  }
  if (!silent.empty())
    throw IoError(fmt::format("record: no samples from {} (see the end reason above)", silent));
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    record,
    CommandSpec{
        "record", "Record devices into an MCAP file, with clocks mapped and every loss counted", 10,
        [](CLI::App& sub) -> std::function<int()> {
          auto args = std::make_shared<RecordArgs>();
          sub.add_option("uris", args->uris,
                         "device URIs (see `imukit devices` and docs/devices.md)")
              ->required();
          sub.add_option("-o,--output", args->output, "output FILE.mcap")->required();
          sub.add_option("--duration", args->duration_s,
                         "keep the samples made in the first this many seconds of each device "
                         "(by its own clock where it has one; docs/formats.md)")
              ->check(real_in(0, 1e7, "s", LowEnd::open));
          sub.add_option("--samples", args->samples, "stop each device after this many samples")
              ->check(whole_in(1, 1'000'000'000'000'000));
          sub.add_option("--rate", args->rate_hz,
                         "output data rate to configure (Hz), for the URIs without rate= whose "
                         "device takes one")
              ->check(sample_rate_range());
          sub.add_option("--no-data-timeout", args->no_data_timeout_s,
                         "stop a device that sends no sample for this long, s of wall-clock time "
                         "(default 10)")
              ->check(real_in(0, 86400, "s", LowEnd::open));
          sub.add_option(
              "--guide", args->guide,
              "multipos: guided multi-position capture for `imukit calibrate`: counts the "
              "distinct still poses and stops when there are --poses of them");
          sub.add_option("--poses", args->poses, "distinct orientations wanted by --guide multipos")
              ->check(whole_in(1, 200))
              ->each([args](const std::string&) { args->poses_given = true; });
          sub.add_option("--init-static", args->init_static_s,
                         "--guide multipos: how long the device must first lie still, s (default "
                         "10; `imukit calibrate` reads it from the recording)")
              ->check(real_in(1, 3600, "s"))
              ->each([args](const std::string&) { args->init_static_given = true; });
          sub.add_flag("--no-taps", args->no_taps, "do not detect sync taps in the accelerometer");
          sub.add_flag(
              "--no-refit", args->no_refit,
              "keep the online clock fit instead of refitting over the whole file at the end");
          sub.footer(
              "Stops at --duration/--samples, on Ctrl-C, SIGTERM or SIGHUP (the file is flushed "
              "and closed), or\n"
              "when every device is gone. While recording, FILE.partial.mcap is readable up to "
              "its\n"
              "last chunk at any moment (after a crash, `imukit convert --recover` completes it); "
              "at\n"
              "the end the clocks are refitted over the whole recording and FILE.mcap replaces "
              "it.\n"
              "The report counts every loss per device; samples with a non-finite value, samples "
              "of the\n"
              "device's stream before the recording's start and stale samples (frames repeated or "
              "late)\n"
              "are named when there are any (the last two are no loss).\n\n"
              "Examples:\n"
              "  imukit record 'mock:static?rate=1000&clock=virtual' -o still.mcap --duration 60\n"
              "  imukit record 'serial:/dev/ttyUSB0?codec=witmotion' hid:054c:09cc -o "
              "session.mcap\n"
              "  imukit record 'mock:poses?clock=virtual&poses=12&profile=examples/profiles/"
              "wrist_watch_imu.json' \\\n"
              "      --guide multipos --poses 12 --duration 600 -o poses.mcap\n"
              "  (a guided capture asks for --init-static s of stillness first, 10 by default; "
              "`imukit calibrate`\n"
              "  reads it from the recording)\n\n"
              "Virtual-clock mocks need --duration or --samples: they run as fast as the disk "
              "takes.\n"
              "A device that sends nothing for --no-data-timeout s is stopped; a device that sent "
              "no sample\n"
              "makes the command fail (exit 3).\n\n"
              "Events (/events): sync taps found in the accelerometer (a sharp jerk), poses of "
              "--guide,\n"
              "and lines typed while recording (host time).\n");
          return [args] { return run_record(*args); };
        }});

}  // namespace imukit::cli
