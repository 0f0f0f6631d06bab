#include "imukit/capture/session.hpp"

#include <fmt/core.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "imukit/capture/ros_messages.hpp"
#include "imukit/capture/sequence_gaps.hpp"
#include "imukit/capture/spsc_queue.hpp"
#include "imukit/core/error.hpp"
#include "imukit/drivers/codec.hpp"
#include "imukit/drivers/reader.hpp"
#include "imukit/drivers/sample.hpp"

namespace imukit::capture {
namespace {

constexpr std::string_view kSyncSchema =
    R"({"type":"object","properties":{"host_send_ns":{"type":"integer"},"host_receive_ns":{"type":"integer"},"device_rx_ns":{"type":"integer"},"device_tx_ns":{"type":"integer"}}})";
// RawImuMessage::channels bits meaning "device_ticks holds the device clock" and "sample_index
// counts every sample made" (drivers::Sample::has_sample_counter), so that the offline refit
// holds ticks to it as the recording did (bits 0-3 name the raw channels present).
constexpr uint8_t kRawHasDeviceClock = 1u << 4;
constexpr uint8_t kRawHasSampleCounter = 1u << 5;

std::span<const uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// A sample on its way from the reader thread to the writer, with the number of samples the full
// queue refused just before it: they leave a gap in the sequence that is the recorder's loss
// (counted in backpressure), not the device's.
struct QueuedSample {
  drivers::Sample sample;
  uint64_t refused_before = 0;
};

// Everything the writer knows about one device; the reader thread touches only the queues, the
// atomics and (under the mutex) the stats snapshot.
struct Device {
  SessionDevice spec;
  SpscQueue<QueuedSample> samples;
  SpscQueue<drivers::SyncPoint> syncs{1024};
  std::atomic<bool> stop{false};
  std::atomic<bool> ended{false};
  std::atomic<uint64_t> backpressure{0};
  std::mutex mutex;
  drivers::CodecStats stats;
  std::string end_reason;
  std::thread thread;

  // Writer side.
  DeviceClock clock{1e9};  // device times arrive in ns
  // Samples missing between consecutive written samples (sequence gaps), less those the queue
  // refused.
  SequenceGaps sequence;
  // Between consecutive written samples on one clock (DeviceClock::continues, or forward
  // sequence numbers for a device without a clock): the sequence's steps and, with a clock, the
  // device time elapsed. Restarts and outliers add nothing. `spanned`: the last sample's step
  // was summed (a damaged index found at the next one is mended there).
  uint64_t sequence_span = 0;
  TimeNs device_span = 0;
  bool spanned = false;
  bool full =
      false;  // reached the duration or sample limit: later samples are outside the recording
  uint16_t imu_channel = 0, raw_channel = 0, sync_channel = 0;
  bool sync_channel_made = false;
  // Time-sync replies taken from the queue and not yet written: each waits for the first sample
  // received at or after it (Pump::write_syncs_until).
  std::deque<drivers::SyncPoint> pending_syncs;
  uint64_t written = 0;
  TimeNs first_host = 0, last_host = 0;
  TimeNs last_device = 0;  // device time of the last sample written that had one
  bool has_device_time = false;
  ImuMessage imu;
  RawImuMessage raw;
  TapDetector taps;
  std::optional<PoseGuide> guide;
  std::chrono::steady_clock::time_point last_data = std::chrono::steady_clock::now();
  std::string silent_reason;  // set when the no-data timeout stopped the device

  Device(SessionDevice s, std::size_t capacity) : spec(std::move(s)), samples(capacity) {}
};

void reader_thread(Device& d, bool wait_when_full) {
  drivers::ReaderOptions options;
  std::size_t syncs_forwarded = 0;
  uint64_t refused = 0;  // since the last sample the queue took
  // Time-sync replies go to the writer with the samples of the read that decoded them, or of a
  // later one (a read without samples updates the counts only), and this runs once more at the
  // end for replies that came after the last sample (a stop, an unplugged device, the end of a
  // file).
  const auto forward_syncs = [&] {
    const std::span<const drivers::SyncPoint> points = d.spec.device.codec->sync_points();
    while (syncs_forwarded < points.size() &&
           d.syncs.push(drivers::SyncPoint(points[syncs_forwarded]))) {
      ++syncs_forwarded;
    }
  };
  const drivers::EndReason end = drivers::DeviceReader::run(
      *d.spec.device.transport, *d.spec.device.codec, options, d.stop,
      [&](std::vector<drivers::Sample>& batch) {
        // Bytes that decoded to no sample: their counts only. Their time-sync replies go with
        // the next samples, as before: forwarded first, they moved the first chunk's close
        // (and the live file's first bytes on disk) from 20 ms to 250 ms after the start.
        if (batch.empty()) {
          const std::lock_guard lock(d.mutex);
          d.stats = d.spec.device.codec->stats();
          return;
        }
        for (drivers::Sample& s : batch) {
          QueuedSample q{std::move(s), refused};
          bool taken = d.samples.push(std::move(q));  // a refused push leaves q as it was
          while (!taken && wait_when_full && !d.stop.load()) {
            std::this_thread::yield();
            taken = d.samples.push(std::move(q));
          }
          if (taken) {
            refused = 0;
          } else {
            d.backpressure.fetch_add(1);
            ++refused;
          }
        }
        batch.clear();
        forward_syncs();
        const std::lock_guard lock(d.mutex);
        d.stats = d.spec.device.codec->stats();
      });
  forward_syncs();
  {
    const std::lock_guard lock(d.mutex);
    d.stats = d.spec.device.codec->stats();
    d.end_reason = end.message.empty() ? std::string("stopped") : end.message;
  }
  d.ended.store(true, std::memory_order_release);
}

// The sample rate on the host clock: from the device clock span and the fitted skew where the
// device has a clock (receive times would fold the link's jitter into it), else from receive
// times, which only a live device gives: a replay's are when the bytes were read (found in
// review: a WitMotion file replay measured 1e7 Hz), so without a clock it has no rate.
void set_rate(const Device& d, DeviceProgress& p) {
  p.rate_hz = 0.0;
  p.rate_unknown = d.written > 0 && !d.has_device_time && d.spec.device.transport->replay();
  if (d.written < 2 || p.rate_unknown) return;
  double host_span = to_seconds(d.last_host - d.first_host);
  if (d.has_device_time) host_span = to_seconds(d.device_span) / (1.0 + p.clock.skew_ppm * 1e-6);
  // Sample numbers, not samples written: dropped samples were made at the device's rate too.
  if (host_span > 0) p.rate_hz = static_cast<double>(d.sequence_span) / host_span;
}

DeviceProgress progress_of(Device& d) {
  DeviceProgress p;
  p.name = d.spec.name;
  p.samples = d.written;
  p.dropped = d.sequence.missing();
  {
    const std::lock_guard lock(d.mutex);
    p.codec_dropped = d.stats.samples_dropped;
    p.frames_corrupt = d.stats.frames_corrupt;
    p.non_finite = d.stats.samples_non_finite;
    p.before_start = d.stats.samples_before_start;
    p.stale = d.stats.samples_stale;
    p.feature_reports_failed = d.stats.feature_reports_failed;
    p.end_reason = d.silent_reason.empty() ? d.end_reason : d.silent_reason;
  }
  p.backpressure = d.backpressure.load();
  p.queue_high_water = d.samples.high_water();
  p.ended = d.ended.load(std::memory_order_acquire);
  p.clock = d.clock.fit();
  set_rate(d, p);
  return p;
}

// Events found in a device's samples carry the sample's device time, so the offline refit can
// re-time them with the samples.
void write_event(McapWriter& writer, uint16_t channel, const Event& e,
                 const std::string& device = {}, std::optional<TimeNs> device_time = std::nullopt) {
  nlohmann::json j{{"kind", e.kind}, {"label", e.label}};
  if (!device.empty()) j["device"] = device;
  if (device_time) j["device_ns"] = *device_time;
  const std::string text = j.dump();
  writer.write_message(channel, static_cast<uint64_t>(e.t), static_cast<uint64_t>(e.t),
                       bytes_of(text));
}

struct Live {
  uint16_t event_channel;
  const SessionOptions& options;
};

// s with the number of samples the queue refused just before it (not the device's loss).
void write_sample(McapWriter& writer, Device& d, const drivers::Sample& s, uint64_t refused_before,
                  const Live& live) {
  TimeNs t = s.host_time;
  if (s.has_device_time) {
    d.clock.add_sample(static_cast<uint64_t>(s.device_time), s.host_time, s.sequence,
                       s.has_sample_counter);
    t = d.clock.online_time();
    if (const auto w = d.clock.withdrawn()) {
      // The step to the second sample, summed below as it arrived, was a damaged tick's.
      d.sequence_span -= std::min(d.sequence_span, w->index);
      d.device_span -= std::min(d.device_span, static_cast<TimeNs>(w->ticks));
    }
  }
  // Raw first: the offline refit maps the raw message and gives its time to the IMU message
  // that follows it.
  RawImuMessage& raw = d.raw;
  raw.stamp = t;
  raw.host_receive_time = s.host_time;
  raw.sample_index = s.sequence;
  // The device clock in its own ticks where the codec knows them, else in ns.
  const bool ticks = s.has_device_time && s.tick_hz > 0;
  raw.device_ticks = ticks               ? s.device_ticks
                     : s.has_device_time ? static_cast<uint64_t>(s.device_time)
                                         : 0;
  raw.tick_hz = ticks ? s.tick_hz : s.has_device_time ? 1e9 : 0.0;
  raw.channels =
      static_cast<uint8_t>((s.raw_channels & 0x0F) | (s.has_device_time ? kRawHasDeviceClock : 0) |
                           (s.has_sample_counter ? kRawHasSampleCounter : 0));
  raw.accel = s.raw_accel;
  raw.gyro = s.raw_gyro;
  raw.mag = s.raw_mag;
  raw.temperature = s.raw_temperature;
  const auto raw_bytes = encode_cdr(raw);
  writer.write_message(d.raw_channel, static_cast<uint64_t>(t), static_cast<uint64_t>(s.host_time),
                       raw_bytes);
  ImuMessage& m = d.imu;
  m.stamp = t;
  m.angular_velocity = s.gyro;
  m.linear_acceleration = s.accel;
  const auto imu_bytes = encode_cdr(m);
  writer.write_message(d.imu_channel, static_cast<uint64_t>(t), static_cast<uint64_t>(s.host_time),
                       imu_bytes);
  if (d.written == 0) d.first_host = s.host_time;
  // A counter that went back (the device restarted its stream) adds nothing here.
  const SequenceGaps::Step step = d.sequence.add(s.sequence, refused_before);
  if (step.repaired_previous && d.spanned) {
    d.sequence_span -= std::min(d.sequence_span, step.previous_step);
    d.sequence_span += step.previous_repaired_step;
  }
  d.spanned = step.forward && (!s.has_device_time || d.clock.continues());
  if (d.spanned) {
    d.sequence_span += step.index_step;
    if (s.has_device_time) d.device_span += s.device_time - d.last_device;
  }
  if (s.channels & drivers::kHasAccel) {
    const Eigen::Vector3d a(s.accel[0], s.accel[1], s.accel[2]);
    const std::optional<TimeNs> device_time =
        s.has_device_time ? std::optional(s.device_time) : std::nullopt;
    if (live.options.detect_taps) {
      if (const auto tap = d.taps.feed(t, a)) {
        write_event(writer, live.event_channel, {*tap, "tap", "sync tap on " + d.spec.name},
                    d.spec.name,
                    device_time ? std::optional(*device_time - (t - *tap)) : std::nullopt);
      }
    }
    if (d.guide) {
      const Eigen::Vector3d w(s.gyro[0], s.gyro[1], s.gyro[2]);
      if (const auto e = d.guide->feed(t, a, (s.channels & drivers::kHasGyro) ? &w : nullptr)) {
        if (e->initial) {
          // Where calibrate's initial static period starts (imukit.guide gives its length).
          write_event(
              writer, live.event_channel,
              {e->still_since, "initial_still",
               fmt::format("{}: still for {:g} s from here", d.spec.name,
                           to_seconds(t - e->still_since))},
              d.spec.name,
              device_time ? std::optional(*device_time - (t - e->still_since)) : std::nullopt);
        }
        const char* what =
            e->kind == PoseEvent::Kind::repeated_pose ? "orientation already held" : "new pose";
        write_event(writer, live.event_channel,
                    {t, "pose",
                     fmt::format("{} {}: {} (gravity {:.3f} {:.3f} {:.3f})", d.spec.name, e->count,
                                 what, e->gravity_dir.x(), e->gravity_dir.y(), e->gravity_dir.z())},
                    d.spec.name, device_time);
        if (live.options.on_pose) live.options.on_pose(d.spec.name, *e);
      }
    }
  }
  d.last_host = s.host_time;
  if (s.has_device_time) {
    d.last_device = s.device_time;
    d.has_device_time = true;
  }
  ++d.written;
}

void write_sync(McapWriter& writer, Device& d, const drivers::SyncPoint& p, uint16_t schema) {
  if (!d.sync_channel_made) {
    d.sync_channel = writer.add_channel(schema, "/imu/" + d.spec.name + "/time_sync", "json");
    d.sync_channel_made = true;
  }
  d.clock.add_ping(p.host_send, static_cast<uint64_t>(p.device_rx),
                   static_cast<uint64_t>(p.device_tx), p.host_receive);
  const std::string text = nlohmann::json{
      {"host_send_ns", p.host_send},
      {"host_receive_ns", p.host_receive},
      {"device_rx_ns", p.device_rx},
      {"device_tx_ns",
       p.device_tx}}.dump();
  writer.write_message(d.sync_channel, static_cast<uint64_t>(p.host_receive),
                       static_cast<uint64_t>(p.host_receive), bytes_of(text));
}

using Devices = std::vector<std::unique_ptr<Device>>;

// What the session writes to after the start: the schema of the time-sync channels (made when a
// device's first sync point arrives) and the event channel.
struct SessionChannels {
  uint16_t sync_schema;
  uint16_t event_channel;
};

// The schemas, the event channel (with the events given up front), the guide's metadata and
// every device's channels and metadata.
SessionChannels open_channels(McapWriter& writer, Devices& devices, const SessionOptions& options) {
  const uint16_t imu_schema = writer.add_schema(kImuSchemaName, "ros2msg", kImuSchemaText);
  const uint16_t raw_schema = writer.add_schema(kRawImuSchemaName, "ros2msg", kRawImuSchemaText);
  const uint16_t sync_schema = writer.add_schema("imukit_msgs/TimeSync", "jsonschema", kSyncSchema);
  const uint16_t event_schema = writer.add_schema(kEventSchemaName, "jsonschema", kEventSchemaText);
  const uint16_t event_channel = writer.add_channel(event_schema, kEventTopic, "json");
  for (const Event& e : options.events) write_event(writer, event_channel, e);
  if (options.guide) {
    writer.write_metadata(
        "imukit.guide", {{"guide", "multipos"},
                         {"poses_wanted", std::to_string(options.guide->poses_wanted)},
                         {"initial_still_s", fmt::format("{:g}", options.guide->initial_still_s)}});
  }
  for (auto& d : devices) {
    d->imu_channel = writer.add_channel(imu_schema, "/imu/" + d->spec.name, "cdr");
    d->raw_channel = writer.add_channel(raw_schema, "/imu/" + d->spec.name + "/raw", "cdr");
    d->imu.frame_id = d->spec.name;
    if (options.guide) d->guide.emplace(*options.guide);
    if (d->spec.hardware) {
      // Per-sample white-noise variance: sigma^2 = density^2 * rate (rate from the model).
      // Needs the model's output rates; without them the covariances stay "unknown".
      const HardwareModel& h = *d->spec.hardware;
      for (int k = 0; k < 3; ++k) {
        const double g = h.gyroscope.noise_density[k];
        const double a = h.accelerometer.noise_density[k];
        d->imu.angular_velocity_covariance[static_cast<std::size_t>(4 * k)] =
            g * g * h.gyroscope.rate_hz;
        d->imu.linear_acceleration_covariance[static_cast<std::size_t>(4 * k)] =
            a * a * h.accelerometer.rate_hz;
      }
    }
    writer.write_metadata("imukit.device." + d->spec.name,
                          {{"uri", d->spec.uri},
                           {"codec", d->spec.device.codec->name()},
                           {"transport", d->spec.device.transport->describe()}});
  }
  return {sync_schema, event_channel};
}

void start_readers(Devices& devices) {
  // Virtual-time mocks run ahead of the writer; waiting for queue space loses nothing there.
  const bool wait_when_full = std::all_of(devices.begin(), devices.end(), [](const auto& d) {
    return d->spec.device.transport->virtual_time();
  });
  for (auto& d : devices) {
    Device* raw = d.get();
    d->thread = std::thread([raw, wait_when_full] { reader_thread(*raw, wait_when_full); });
  }
}

// How long after the device's first sample written `s` was made, in seconds, as the duration
// limit measures it: on the device's clock where the samples have one, else by receive times.
// Not by receive times where there is a clock: the samples of a block share its receive time, so
// the limit took in the whole block that arrived in time (found in review: 2008 samples for
// --duration 2 at 1 kHz, in blocks of 8). Not by summing the steps between samples the clock fit
// continues either: a damaged tick took out two steps and a restart those of the samples that
// confirmed it (found in review: 520 samples for 0.5 s at 1 kHz with a damaged tick every 50).
double seconds_since_first(const Device& d, const drivers::Sample& s) {
  if (!s.has_device_time || !d.has_device_time) return to_seconds(s.host_time - d.first_host);
  return d.clock.elapsed_s(static_cast<uint64_t>(s.device_time), s.host_time, s.sequence,
                           s.has_sample_counter);
}

// The writer's side of a running session: moves what the reader threads queue into the file.
struct Pump {
  McapWriter& writer;
  Devices& devices;
  const SessionOptions& options;
  uint16_t sync_schema;
  Live live;
  bool start_on_disk = false;

  // Samples past the duration or the sample limit are outside the recording (a virtual-time
  // mock runs ahead of the writer); they are not written, and not counted as lost either.
  void accept(Device& d, const QueuedSample& q) {
    const drivers::Sample& s = q.sample;
    if (d.full) return;
    if (d.guide && d.guide->done()) {
      d.full = true;
    } else if (options.duration_s > 0 && d.written > 0 &&
               seconds_since_first(d, s) >= options.duration_s) {
      d.full = true;
    } else if (options.max_samples && d.written >= options.max_samples) {
      d.full = true;
    } else {
      write_sample(writer, d, s, q.refused_before, live);
      return;
    }
    d.stop.store(true);
  }
  void stop_all() {
    for (auto& d : devices) d->stop.store(true);
  }
  void stop_and_join() {
    stop_all();
    for (auto& d : devices) {
      if (d->thread.joinable()) d->thread.join();
    }
  }
  static void take_syncs(Device& d) {
    drivers::SyncPoint sync;
    while (d.syncs.pop(sync)) d.pending_syncs.push_back(sync);
  }
  // Writes the device's time-sync replies received up to `until` (all of them without it), so
  // they sit in the file in host-time order with the samples. Written as they came off their
  // queue, they landed in bursts seconds before or after their samples (the reader runs ahead of
  // the writer by up to a queue of samples), and how many pings a crash kept depended on the
  // threads' timing: a virtual-time mock cut at 37 % kept 4 to 20 of its 7 (found by CI,
  // 2026-11-27).
  void write_syncs_until(Device& d, std::optional<TimeNs> until) {
    take_syncs(d);
    while (!d.pending_syncs.empty() && (!until || d.pending_syncs.front().host_receive <= *until)) {
      write_sync(writer, d, d.pending_syncs.front(), sync_schema);
      d.pending_syncs.pop_front();
    }
  }
  std::string run();
  void drain();
};

// The main loop, until a signal, the guide, the limits or the devices end the session; returns
// why it stopped.
std::string Pump::run() {
  auto last_progress = std::chrono::steady_clock::now();
  QueuedSample sample;
  for (;;) {
    bool busy = false;
    const auto now = std::chrono::steady_clock::now();
    for (auto& d : devices) {
      for (int n = 0; n < 4096 && d->samples.pop(sample); ++n) {
        busy = true;
        d->last_data = now;
        // The reader queues a read's replies before the next read's samples: taken here, they
        // are all in hand before the first sample received after them.
        write_syncs_until(*d, sample.sample.host_time);
        accept(*d, sample);
      }
      // The replies in hand; if no sample waits after them, each was received before any sample
      // still to come (the reader queues a read's replies before the next read's samples), and
      // all go now. A device that answers pings and writes no samples (none made, or past its
      // limit) held them to the end, and a crash lost them (review, 2026-11-27).
      take_syncs(*d);
      write_syncs_until(*d, d->samples.empty() ? std::nullopt : std::optional(d->last_host));
      if (options.no_data_timeout_s > 0 && d->silent_reason.empty() && !d->full &&
          !d->ended.load(std::memory_order_acquire) &&
          std::chrono::duration<double>(now - d->last_data).count() > options.no_data_timeout_s) {
        const std::lock_guard lock(d->mutex);
        // What to check differs: nothing at all arrived, or bytes did and none decoded (a
        // damaged stream on a pipe was "nothing was written to the FIFO"; review, 2026-11-27).
        const uint64_t bytes = d->stats.bytes_received;
        d->silent_reason = fmt::format(
            "no data for {:g} s{}", options.no_data_timeout_s,
            d->written > 0 ? ""
            : bytes == 0
                ? fmt::format(" since the start ({})", d->spec.device.transport->when_silent())
                : fmt::format(" since the start ({} bytes arrived and no sample decoded from "
                              "them: check the codec and its keys in the URI)",
                              bytes));
        d->stop.store(true);
      }
    }
    // The first samples close a chunk of their own: a recording killed in its first quarter
    // second (a chunk spans 250 ms) still holds its channels and what came first.
    if (!start_on_disk && busy) {
      writer.flush();
      start_on_disk = true;
    }
    if (options.take_markers) {
      std::vector<Event> markers;
      options.take_markers(markers);
      for (const Event& e : markers) write_event(writer, live.event_channel, e);
    }
    if (options.stop && options.stop->load()) return "stopped by signal";
    if (options.guide && std::all_of(devices.begin(), devices.end(),
                                     [](const auto& d) { return d->guide && d->guide->done(); })) {
      for (auto& d : devices) d->full = true;  // what a virtual-time mock made since is not wanted
      return fmt::format("{} distinct poses held", options.guide->poses_wanted);
    }
    bool all_done = true;
    bool all_ended = true;
    for (auto& d : devices) {
      const bool ended = d->ended.load(std::memory_order_acquire);
      all_ended = all_ended && ended;
      all_done = all_done && (d->full || ended);
    }
    if (all_ended && !busy) {  // drain() writes anything pushed since this pass
      const bool limited =
          std::any_of(devices.begin(), devices.end(), [](const auto& d) { return d->full; });
      const bool silent = std::all_of(devices.begin(), devices.end(),
                                      [](const auto& d) { return !d->silent_reason.empty(); });
      return limited  ? "limit reached"
             : silent ? fmt::format("no data from any device for {:g} s", options.no_data_timeout_s)
                      : "every device ended";
    }
    if (all_done) stop_all();
    if (options.progress && now - last_progress > std::chrono::milliseconds(250)) {
      last_progress = now;
      std::vector<DeviceProgress> p;
      for (auto& d : devices) p.push_back(progress_of(*d));
      options.progress(p);
    }
    if (!busy) std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
}

// Stops the readers and writes what arrived before they ended: nothing received is lost.
void Pump::drain() {
  stop_and_join();
  QueuedSample sample;
  for (auto& d : devices) {
    while (d->samples.pop(sample)) {
      write_syncs_until(*d, sample.sample.host_time);
      accept(*d, sample);
    }
    write_syncs_until(*d, std::nullopt);
    d->clock.flush();
  }
}

// Closes the recording with each device's session statistics, refits its clocks (when
// finalizing: the finished file replaces the live one) and reports on every device.
SessionReport finish(McapWriter& writer, Devices& devices, const SessionOptions& options,
                     const std::string& live_path, SessionReport report) {
  // Every sample on disk before the session records: written while the last chunk was open, they
  // came before it in the file, and a crash while closing lost that chunk's samples
  // (Session.RecoveryRebuildsTheLossesTheSampleIndexShows kept 1922-1960 of 2000 under load,
  // where an out-of-order time had happened to close the chunk before; review, 2026-11-27).
  writer.flush();
  for (auto& d : devices) {
    const DeviceProgress p = progress_of(*d);
    McapMetadataMap entries{{"samples", std::to_string(p.samples)},
                            {"samples_dropped", std::to_string(p.dropped)},
                            {"codec_samples_dropped", std::to_string(p.codec_dropped)},
                            {"frames_corrupt", std::to_string(p.frames_corrupt)},
                            {"samples_non_finite", std::to_string(p.non_finite)},
                            {"samples_before_start", std::to_string(p.before_start)},
                            {"samples_stale", std::to_string(p.stale)},
                            {"feature_reports_failed", std::to_string(p.feature_reports_failed)},
                            {"backpressure_dropped", std::to_string(p.backpressure)},
                            {"end_reason", p.end_reason},
                            {"online_clock_skew_ppm", fmt::format("{:.3f}", p.clock.skew_ppm)}};
    // `imukit info` reads this instead of measuring a rate from times that are not sample times.
    if (p.rate_unknown) entries["rate"] = kRateUnknownNote;
    writer.write_metadata("imukit.session." + d->spec.name, entries);
  }
  writer.close();

  std::map<std::string, ClockFit> fits;
  if (options.finalize) {
    fits = refit_recording_clocks(live_path, options.path);
    std::filesystem::remove(live_path);
  } else {
    // Complete: it replaces the output now (a file there stays as it was until then).
    std::filesystem::rename(live_path, options.path);
  }
  for (auto& d : devices) {
    DeviceProgress p = progress_of(*d);
    if (const auto it = fits.find(d->spec.name); it != fits.end()) {
      p.clock = it->second;
      set_rate(*d, p);
    }
    report.devices.push_back(std::move(p));
  }
  return report;
}

}  // namespace

std::string partial_path(const std::string& path) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".partial.mcap")).string();
}

void check_no_partial_recording(const std::string& path) {
  // A partial file here is what a crashed recording kept: opening it would truncate it and the
  // end of this recording would delete it.
  const std::string live_path = partial_path(path);
  std::error_code ec;
  if (std::filesystem::symlink_status(live_path, ec).type() ==
      std::filesystem::file_type::not_found)
    return;
  const std::filesystem::path out(path);
  const std::string recovered =
      (out.parent_path() / (out.stem().string() + ".recovered.mcap")).string();
  throw IoError(fmt::format(
      "record: {} already exists (an earlier recording to {} did not finish); recover it "
      "with `imukit convert --recover {} -o {}`, or remove it, then record again",
      live_path, path, live_path, recovered));
}

SessionReport record_session(std::vector<SessionDevice> specs, const SessionOptions& options) {
  if (specs.empty()) throw Error("record: name at least one device");
  Devices devices;
  for (auto& s : specs)
    devices.push_back(std::make_unique<Device>(std::move(s), options.queue_capacity));

  // Record into a temporary name; the finished file (refitted, unless finalize is off) replaces
  // the output at the end, and a crash leaves the temporary file readable up to its last chunk.
  // Found in review (2026-11-27): without the refit the output itself was the live file, so an
  // earlier recording there was truncated at the start, whatever became of this one.
  const std::string live_path = partial_path(options.path);
  McapWriterOptions live_options = options.mcap;
  check_no_partial_recording(options.path);
  live_options.create_new = true;  // and no other recording may create it meanwhile
  McapWriter writer(live_path, live_options);
  const SessionChannels channels = open_channels(writer, devices, options);
  start_readers(devices);
  Pump pump{writer, devices, options, channels.sync_schema, Live{channels.event_channel, options}};
  SessionReport report;
  try {
    report.stop_reason = pump.run();
  } catch (...) {
    pump.stop_and_join();
    throw;
  }
  pump.drain();
  return finish(writer, devices, options, live_path, std::move(report));
}

namespace {

// The device clock of a RawImu message in ns (the clock fits work in ns, like the pings), or
// nothing when the message has no clock or its clock fields cannot be one (a rate outside
// [1 Hz, 9 GHz], ticks that are not 0..2^63 or whose time in ns would not fit in int64: only a
// damaged or crafted file holds those; such a message keeps the time it has).
std::optional<uint64_t> device_ns(const RawImuMessage& raw) {
  if (!(raw.channels & kRawHasDeviceClock)) return std::nullopt;
  if (!(raw.tick_hz >= 1.0 && raw.tick_hz <= 9e9)) return std::nullopt;
  const auto hz = static_cast<uint64_t>(std::llround(raw.tick_hz));
  if (raw.device_ticks > static_cast<uint64_t>(INT64_MAX) || raw.device_ticks / hz >= 9'000'000'000)
    return std::nullopt;
  return static_cast<uint64_t>(drivers::ticks_to_ns(static_cast<int64_t>(raw.device_ticks), hz));
}

// An integer field of a JSON object, if it is one.
std::optional<int64_t> json_int(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number_integer()) return std::nullopt;
  return it->get<int64_t>();
}

// decode(data, source) on message m of stream `device` (and `suffix`, "/raw") in `file`. The
// decoders count bytes from the message's start, so an error names the message (as
// read_recording_mcap does); the name is made only when the decode fails, by decoding again with it
// (the same bytes fail the same way), since every message of a recording passes here at its close.
template <class Decode>
auto decode_message(const Decode& decode, const McapMessageView& m, const std::string& file,
                    const std::string& device, std::string_view suffix = {}) {
  try {
    return decode(m.data, file);
  } catch (const Error&) {
    return decode(m.data, fmt::format("{}: message {} of {}{}", file, m.sequence, device, suffix));
  }
}

// Decodes a RawImu message; in recovery (`recover`) one that does not decode is nothing.
std::optional<RawImuMessage> decode_raw(const McapMessageView& m, const std::string& file,
                                        const std::string& device, bool recover) {
  try {
    return decode_message(decode_raw_imu_cdr, m, file, device, "/raw");
  } catch (const Error&) {
    if (!recover) throw;
    return std::nullopt;
  }
}

// What refit's first pass learns from a recording: its channels by kind (device names after
// "/imu/") and every device's clock, fed with its (ticks, receive time) pairs and time-sync
// exchanges.
struct ClockScan {
  std::map<std::string, DeviceClock> clocks;
  std::map<uint16_t, std::string> raw_channels, imu_channels, sync_channels;
  std::optional<uint16_t> event_channel;
  std::map<std::string, SequenceGaps> gaps;  // per device, over its raw messages in file order
  std::vector<McapMetadata> metadata;        // the records the file holds
};

ClockScan scan_clocks(const std::string& in, const McapReadOptions& read) {
  ClockScan scan;
  const auto name_of = [](const std::string& topic, std::string_view suffix) {
    std::string name = topic.substr(5);  // after "/imu/"
    return name.substr(0, name.size() - suffix.size());
  };
  McapHandlers handlers;
  handlers.on_channel = [&](const McapChannel& c) {
    const auto ends = [&](std::string_view s) {
      return c.topic.size() > s.size() &&
             c.topic.compare(c.topic.size() - s.size(), s.size(), s) == 0;
    };
    if (c.topic == kEventTopic) scan.event_channel = c.id;
    if (c.topic.rfind("/imu/", 0) != 0) return;
    if (ends("/raw"))
      scan.raw_channels[c.id] = name_of(c.topic, "/raw");
    else if (ends("/time_sync"))
      scan.sync_channels[c.id] = name_of(c.topic, "/time_sync");
    else
      scan.imu_channels[c.id] = name_of(c.topic, "");
  };
  handlers.on_message = [&](const McapMessageView& m) {
    if (const auto it = scan.raw_channels.find(m.channel_id); it != scan.raw_channels.end()) {
      const auto raw = decode_raw(m, in, it->second, read.recover);
      if (raw) scan.gaps[it->second].add(raw->sample_index);
      if (const auto ns = raw ? device_ns(*raw) : std::nullopt) {
        scan.clocks.try_emplace(it->second, 1e9)
            .first->second.add_sample(*ns, raw->host_receive_time, raw->sample_index,
                                      (raw->channels & kRawHasSampleCounter) != 0);
      }
    } else if (const auto s = scan.sync_channels.find(m.channel_id);
               s != scan.sync_channels.end()) {
      const auto j = nlohmann::json::parse(m.data.begin(), m.data.end(), nullptr, false);
      if (!j.is_object()) return;
      const auto send = json_int(j, "host_send_ns"), receive = json_int(j, "host_receive_ns");
      const auto rx = json_int(j, "device_rx_ns"), tx = json_int(j, "device_tx_ns");
      if (send && receive && rx && tx) {
        scan.clocks.try_emplace(s->second, 1e9)
            .first->second.add_ping(*send, static_cast<uint64_t>(*rx), static_cast<uint64_t>(*tx),
                                    *receive);
      }
    }
  };
  scan.metadata = read_mcap(in, handlers, read).metadata;
  for (auto& [name, clock] : scan.clocks) clock.flush();
  return scan;
}

// What a crash leaves of a device's loss counts: its session record is written when the
// recording closes (the counts are known only then), so a recording cut short has none. The
// samples missing between the ones kept still show as gaps in their sample_index; the codec's
// counts, the corrupt frames and the recorder's refusals do not. The record for the recovered
// file says so (docs/formats.md).
McapMetadata recovered_session_record(const std::string& device, const SequenceGaps& g) {
  const std::string lost = "unknown: lost with the crash";
  return {"imukit.session." + device,
          {{"samples", std::to_string(g.kept())},
           {"samples_dropped", std::to_string(g.missing())},
           {"codec_samples_dropped", lost},
           {"frames_corrupt", lost},
           {"samples_non_finite", lost},
           {"samples_before_start", lost},
           {"samples_stale", lost},
           {"feature_reports_failed", lost},
           {"backpressure_dropped", lost},
           {"end_reason", "the recording did not finish (recovered by imukit convert --recover)"},
           {"recovered",
            "samples_dropped is the samples missing by sample_index gaps between the samples "
            "kept (damaged chunks and the recorder's own refusals included); the session's other "
            "loss counts were lost with the crash"}}};
}

// The clock fits as metadata records of the refitted file, so `imukit info` can show them.
std::vector<McapMetadata> clock_fit_records(const std::map<std::string, DeviceClock>& clocks) {
  std::vector<McapMetadata> records;
  for (const auto& [name, clock] : clocks) {
    const ClockFit f = clock.fit();
    records.push_back(
        {"imukit.clock." + name,
         {{"skew_ppm", fmt::format("{:.4f}", f.skew_ppm)},
          {"packets", std::to_string(f.packets)},
          {"jitter_mean_us", fmt::format("{:.1f}", f.jitter_mean_s * 1e6)},
          {"jitter_std_us", fmt::format("{:.1f}", f.jitter_std_s * 1e6)},
          {"jitter_max_us", fmt::format("{:.1f}", f.jitter_max_s * 1e6)},
          {"latency_us", f.ping_corrected ? fmt::format("{:.1f}", f.latency_correction_s * 1e6)
                                          : std::string("unknown (no time-sync pings)")},
          {"pings", std::to_string(f.pings)},
          {"segments", std::to_string(f.segments)},
          {"outliers", std::to_string(f.outliers)}}});
  }
  return records;
}

// refit's second pass, message by message (an McapMessageEdit): every raw message re-timed by
// its device's clock, and the IMU message that follows it. Both were written with the same
// (online) stamp; an IMU message whose raw message was lost with a damaged chunk moves by the
// correction of the device's last raw message. Events move by their device's clock.
class Retimer {
 public:
  Retimer(const ClockScan& scan, const std::string& file, bool recover)
      : scan_(scan), file_(file), recover_(recover) {}

  bool operator()(const McapChannel& c, McapMessageView& m) {
    if (const auto it = scan_.raw_channels.find(c.id); it != scan_.raw_channels.end())
      return raw(it->second, m);
    if (scan_.event_channel && c.id == *scan_.event_channel) return event(m);
    if (const auto it = scan_.imu_channels.find(c.id); it != scan_.imu_channels.end())
      return imu(it->second, m);
    return true;
  }

  // Messages left out because they did not decode (recovery only).
  uint64_t dropped() const { return dropped_; }

 private:
  struct Retimed {
    TimeNs original = 0, mapped = std::numeric_limits<TimeNs>::min();
    std::size_t clocked = 0;  // raw messages with a device clock so far
  };

  bool raw(const std::string& device, McapMessageView& m) {
    auto raw = decode_raw(m, file_, device, recover_);
    if (!raw) return ++dropped_, false;
    const auto clock = scan_.clocks.find(device);
    const auto ns = device_ns(*raw);
    if (!ns || clock == scan_.clocks.end()) return true;
    const TimeNs original = raw->stamp;
    // The k-th message with a clock, as scan_clocks added them. Where two segments' fits meet,
    // or an outlier's estimate sits, a time can come out a little before the previous one; a
    // recording's times never go back, so it takes the previous time instead.
    Retimed& last = last_raw_[device];
    raw->stamp = std::max(clock->second.time_of(last.clocked++, *ns), last.mapped);
    last.original = original;
    last.mapped = raw->stamp;
    buffer_ = encode_cdr(*raw);
    m.data = buffer_;
    m.log_time = static_cast<uint64_t>(raw->stamp);
    return true;
  }

  // An event carries the device time of the sample it was found in, written just after it: it
  // is on the clock of its device's last raw message.
  bool event(McapMessageView& m) const {
    const auto j = nlohmann::json::parse(m.data.begin(), m.data.end(), nullptr, false);
    if (!j.is_object()) return true;
    const auto device = j.find("device");
    const auto ns = json_int(j, "device_ns");
    if (device == j.end() || !device->is_string() || !ns) return true;
    const auto clock = scan_.clocks.find(device->get<std::string>());
    if (clock == scan_.clocks.end()) return true;
    const auto last = last_raw_.find(device->get<std::string>());
    const std::size_t k =
        last == last_raw_.end() || last->second.clocked == 0 ? 0 : last->second.clocked - 1;
    m.log_time = static_cast<uint64_t>(clock->second.map_near(k, static_cast<uint64_t>(*ns)));
    m.publish_time = m.log_time;
    return true;
  }

  bool imu(const std::string& device, McapMessageView& m) {
    const auto t = last_raw_.find(device);
    if (t == last_raw_.end()) return true;
    ImuMessage msg;
    try {
      msg = decode_message(decode_imu_cdr, m, file_, device);
    } catch (const Error&) {
      if (!recover_) throw;
      return ++dropped_, false;
    }
    TimeNs stamp = t->second.mapped, correction = 0;
    if (msg.stamp != t->second.original &&
        (__builtin_sub_overflow(t->second.mapped, t->second.original, &correction) ||
         __builtin_add_overflow(msg.stamp, correction, &stamp)))
      stamp = msg.stamp;
    msg.stamp = stamp;
    buffer_ = encode_cdr(msg);
    m.data = buffer_;
    m.log_time = static_cast<uint64_t>(stamp);
    return true;
  }

  const ClockScan& scan_;
  const std::string& file_;
  bool recover_;
  std::map<std::string, Retimed> last_raw_;
  std::vector<uint8_t> buffer_;  // the message being rewritten
  uint64_t dropped_ = 0;
};

// Re-times `in` into `out` as refit_recording_clocks says; `read` recovers a damaged file, and
// then messages that do not decode are left out (counted in `undecodable`).
std::map<std::string, ClockFit> refit(const std::string& in, const std::string& out,
                                      const McapReadOptions& read, McapReadSummary* summary,
                                      uint64_t* undecodable,
                                      std::map<std::string, RecoveredLosses>* losses) {
  const ClockScan scan = scan_clocks(in, read);
  Retimer retimer(scan, in, read.recover);
  std::vector<McapMetadata> records = clock_fit_records(scan.clocks);
  if (losses) {
    for (const auto& [device, g] : scan.gaps) {
      const std::string name = "imukit.session." + device;
      const bool closed = std::any_of(scan.metadata.begin(), scan.metadata.end(),
                                      [&](const McapMetadata& m) { return m.name == name; });
      (*losses)[device] = RecoveredLosses{g.kept(), g.missing(), !closed};
      if (!closed) records.push_back(recovered_session_record(device, g));
    }
  }
  const McapReadSummary s = rewrite_mcap(in, out, std::ref(retimer), read, records);
  if (summary) *summary = s;
  if (undecodable) *undecodable = retimer.dropped();
  std::map<std::string, ClockFit> fits;
  for (const auto& [name, clock] : scan.clocks) fits[name] = clock.fit();
  return fits;
}

}  // namespace

std::map<std::string, ClockFit> refit_recording_clocks(const std::string& in,
                                                       const std::string& out) {
  return refit(in, out, McapReadOptions{}, nullptr, nullptr, nullptr);
}

RecoveredRecording recover_recording(const std::string& in, const std::string& out) {
  RecoveredRecording r;
  McapReadOptions read;
  read.recover = true;
  r.clocks = refit(in, out, read, &r.read, &r.undecodable_messages, &r.losses);
  return r;
}

}  // namespace imukit::capture
