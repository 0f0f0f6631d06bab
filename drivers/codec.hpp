// Codec: turns what a transport delivers (a byte stream in any chunking, or whole HID reports)
// into Samples, counting every loss in CodecStats. Codecs do no I/O themselves: commands for the
// device (configuration, time-sync pings) are queued and taken by the reader with
// take_outgoing(), and feature reports they need are listed by feature_requests() and handed
// back through on_feature_report(). So each codec is tested, benchmarked and fuzzed on plain
// byte buffers.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "imukit/drivers/sample.hpp"

namespace imukit::drivers {

// One time-sync exchange (a Ping answered by a Pong): the four stamps capture/ fits the clock
// map from.
struct SyncPoint {
  TimeNs host_send = 0;     // host clock when the Ping was queued
  TimeNs host_receive = 0;  // host clock when the Pong arrived
  TimeNs device_rx = 0;     // device clock (unwrapped, ns) when the Ping arrived
  TimeNs device_tx = 0;     // device clock when the Pong left
};

struct FeatureRequest {
  uint8_t report_id = 0;
  std::size_t size = 0;  // bytes, report ID included
  // The codec has defaults to stream with when the report cannot be read (counted in
  // CodecStats::feature_reports_failed); otherwise that failure ends the stream.
  bool optional = false;
};

class Codec {
 public:
  virtual ~Codec() = default;

  virtual std::string name() const = 0;
  // True when feed() takes one whole HID report per call; false for byte streams.
  virtual bool report_based() const { return false; }

  // The transport is open (host clock `now`): queue start-up commands.
  virtual void start(TimeNs /*now*/) {}
  // The first bytes may be the middle of a frame or line (Transport::may_start_mid_stream); the
  // reader says so before start(). Binary codecs resynchronise on their own; text needs it.
  void set_may_start_mid_stream(bool may) { may_start_mid_stream_ = may; }
  // Bytes (or one report) that arrived at host_time; decoded samples are appended to out.
  // Every codec's samples pass through here, so a sample with a NaN or infinite value (a
  // device's bad float, or a unit scale that overflowed) is dropped and counted for all of them
  // (samples_non_finite) instead of reaching a recording that no reader would then accept.
  void feed(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out);
  // Called between reads (host clock now): e.g. periodic time-sync requests.
  virtual void tick(TimeNs /*now*/) {}
  // End of stream: hand out anything complete that was held back, and count what is cut off.
  // host_time is when the last bytes arrived (what the held-back data is stamped with).
  void finish(TimeNs host_time, std::vector<Sample>& out);

  // Bytes received but not yet decided on (an unfinished frame or line).
  virtual std::size_t bytes_pending() const { return 0; }

  // Time-sync exchanges so far, in arrival order; empty for devices without a sync protocol.
  // capture/ fits the device-to-host clock map from them. Valid until the next feed() or tick().
  virtual std::span<const SyncPoint> sync_points() const { return {}; }

  virtual std::vector<FeatureRequest> feature_requests() const { return {}; }
  // Throws imukit::Error when the report is not what the codec needs (the reader asks again).
  virtual void on_feature_report(uint8_t /*id*/, std::span<const uint8_t> /*report*/) {}
  // The reader could not get an optional report: counted; the codec keeps its defaults.
  void on_optional_feature_report_missing() { ++stats_.feature_reports_failed; }

  // Commands queued for the device since the last call.
  std::vector<uint8_t> take_outgoing() {
    std::vector<uint8_t> out;
    out.swap(outgoing_);
    return out;
  }
  const CodecStats& stats() const { return stats_; }

 protected:
  // What feed() and finish() do for this codec: decode into out, counting in stats_.
  virtual void decode(std::span<const uint8_t> data, TimeNs host_time,
                      std::vector<Sample>& out) = 0;
  virtual void decode_end(TimeNs /*host_time*/, std::vector<Sample>& /*out*/) {}

  void queue(std::span<const uint8_t> bytes) {
    outgoing_.insert(outgoing_.end(), bytes.begin(), bytes.end());
  }
  CodecStats stats_;
  std::vector<uint8_t> outgoing_;
  bool may_start_mid_stream_ = false;

 private:
  // Removes the samples from out[first] on that hold a non-finite value, counting them.
  void drop_non_finite(std::vector<Sample>& out, std::size_t first);
};

// Codec options as given in a device URI's query (docs/devices.md lists the keys per codec).
using CodecOptions = std::map<std::string, std::string>;

// Option helpers shared by the codecs and the URI parser: parse a number or fail with an error
// that names the key and the text.
double option_double(const CodecOptions& options, const std::string& key, double fallback);
int64_t option_int(const CodecOptions& options, const std::string& key, int64_t fallback);
bool option_bool(const CodecOptions& options, const std::string& key, bool fallback);
std::string option_string(const CodecOptions& options, const std::string& key,
                          const std::string& fallback);

}  // namespace imukit::drivers
