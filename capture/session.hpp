// Recording sessions: one or more devices at once, each read on a thread of its own and handed
// to the writer through a bounded lock-free queue, every loss counted (by the device's own
// counters, by corrupt frames, and by back-pressure in the recorder), device clocks mapped to
// host time, everything written to an MCAP file as DESIGN.md lays it out:
//   /imu/<name>            sensor_msgs/msg/Imu, log_time = mapped sample time
//   /imu/<name>/raw        imukit_msgs/msg/RawImu: device ticks, host receive time, index, counts
//   /imu/<name>/time_sync  JSON time-sync exchanges (host send/receive, device rx/tx), if any
//   /events                JSON events (markers, detected sync taps)
// While recording, times come from the online clock fit; at the end every device is refitted
// over the whole file (the offline fit, which also uses the time-sync exchanges) and the times
// are rewritten, so both the live file and the final one are valid MCAP at every moment.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "imukit/capture/clock_map.hpp"
#include "imukit/capture/live_detectors.hpp"
#include "imukit/capture/mcap.hpp"
#include "imukit/core/hardware_model.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/drivers/uri.hpp"

namespace imukit::capture {

struct SessionDevice {
  std::string name;  // stream name: topics /imu/<name>...
  std::string uri;   // recorded in the metadata
  drivers::OpenedDevice device;
  std::optional<HardwareModel> hardware;  // white-noise covariances in sensor_msgs/Imu when known
};

struct DeviceProgress {
  std::string name;
  uint64_t samples = 0;         // written to the file
  uint64_t dropped = 0;         // gaps in the device's sample counter within the recording
  uint64_t codec_dropped = 0;   // every loss the codec saw (also past the end, and for devices
                                // without a counter, samples of frames that did not arrive)
  uint64_t frames_corrupt = 0;  // frames that failed their checksum or format
  // Samples dropped for a NaN or infinite value (in codec_dropped and frames_corrupt too).
  uint64_t non_finite = 0;
  // Samples of an earlier session's stream discarded at the start (CodecStats::
  // samples_before_start): not losses of this recording.
  uint64_t before_start = 0;
  // Samples of frames the link repeated or delivered late (CodecStats::samples_stale): not
  // written again, not losses.
  uint64_t stale = 0;
  // Optional feature reports (a pad's calibration) that could not be read: the nominal scale
  // was used (CodecStats::feature_reports_failed).
  uint64_t feature_reports_failed = 0;
  uint64_t backpressure = 0;  // samples the recorder's own queue had to refuse
  std::size_t queue_high_water = 0;
  double rate_hz = 0.0;  // the device's sample rate on the host clock (sample numbers over
                         // the device clock span, corrected by the fitted skew)
  // A replay of a device without a sample clock: its receive times are when the bytes were
  // read, so it has no rate (rate_hz 0) and its times are not sample times.
  bool rate_unknown = false;
  bool ended = false;
  std::string end_reason;
  ClockFit clock;
};

struct SessionOptions {
  std::string path;  // output .mcap
  // Per device, the samples made within this many seconds of its first one written are kept
  // (0: no limit): those whose time since the first is in [0, duration_s), measured on the
  // device's own clock where its samples have one (through damaged ticks, and a clock restart
  // adds nothing: DeviceClock::elapsed_s), else on their receive times. A device at a steady rate
  // thus gives duration_s * rate samples (2000 for 2 s at 1 kHz); the final, refitted times span
  // that device time scaled by the fitted skew (a few ppm). The session stops when every device is
  // past it.
  double duration_s = 0.0;
  uint64_t max_samples = 0;  // per device (0: no limit)
  // A device that delivers no sample for this long of wall-clock time (from the start, or since
  // its last sample) is stopped with a reason saying so: a silent device (wrong baud rate or
  // codec, a mock that drops everything) would otherwise keep a data-time limit from ever
  // being reached. 0: wait forever.
  double no_data_timeout_s = 0.0;
  std::size_t queue_capacity = 1 << 15;     // samples per device
  bool finalize = true;                     // offline clock fit and rewrite at the end
  const std::atomic<bool>* stop = nullptr;  // e.g. set by SIGINT/SIGTERM
  // Called about four times a second on the writer thread.
  std::function<void(const std::vector<DeviceProgress>&)> progress;
  McapWriterOptions mcap;
  std::vector<Event> events;  // markers known before the start (written at their times)
  // Markers that arrive while recording (typed by the user, sent by an API): called on the
  // writer thread, it moves new events (host times) into its argument.
  std::function<void(std::vector<Event>&)> take_markers;
  bool detect_taps = true;  // sync taps found in each accelerometer become /events "tap"
  // Guided multi-position capture: poses are counted per device, each becomes an /events
  // "pose" entry, `on_pose` hears about it (to prompt for the next), and the session stops when
  // every device has its poses.
  std::optional<PoseGuideOptions> guide;
  std::function<void(const std::string& device, const PoseEvent&)> on_pose;
};

// What rate_unknown means, for reports and the recording's metadata.
inline constexpr const char* kRateUnknownNote =
    "unknown: a replay of a device without a sample clock, whose times are when the bytes were "
    "read, not when the samples were made (give rate= in the URI to time them)";

struct SessionReport {
  std::vector<DeviceProgress> devices;
  std::string stop_reason;
};

// Where a session writes while it records (FILE.partial.mcap for FILE.mcap): readable up to its
// last chunk at any moment, replaced by FILE.mcap when the session ends.
std::string partial_path(const std::string& path);

// Throws IoError (saying how to recover it) when partial_path(path) exists: what a crashed
// recording to `path` kept, which a new recording would truncate and then delete. record_session
// checks it too; a caller checks it before opening any device, so the refusal comes first.
void check_no_partial_recording(const std::string& path);

// Records until the duration, the sample limit, `stop`, or the loss of every device. Throws
// imukit::Error only for problems with the output file; device failures end that device's
// stream with a reason in the report.
SessionReport record_session(std::vector<SessionDevice> devices, const SessionOptions& options);

// The offline clock fit of a recording: one fit per device over all its RawImu messages (device
// ticks against host receive times) and time-sync exchanges, written to `out` with every IMU and
// raw message re-timed. Returns the fits by device name.
std::map<std::string, ClockFit> refit_recording_clocks(const std::string& in,
                                                       const std::string& out);

// A recording cut short by a crash (FILE.partial.mcap after kill -9 or a power cut) or damaged
// on disk, rewritten as a complete file: every intact chunk is kept, damaged records are skipped
// (McapReadOptions::recover), and the clocks are refitted over the samples kept, as at the end
// of a normal recording. Messages that do not decode are left out.
//
// A recording that did not close has no session record (its loss counts are written at the
// end): the recovered file gets one per device saying what the samples kept still show, the
// samples missing by sample_index gaps, and that the other counts were lost with the crash.
struct RecoveredLosses {
  uint64_t samples = 0;           // raw messages kept
  uint64_t missing_by_index = 0;  // gaps in sample_index between them
  bool counts_lost = false;       // no session record: the recording did not close
};
struct RecoveredRecording {
  McapReadSummary read;  // what the damaged file held: truncation note, damage, counts
  std::map<std::string, ClockFit> clocks;
  uint64_t undecodable_messages = 0;
  std::map<std::string, RecoveredLosses> losses;  // by device name
};
RecoveredRecording recover_recording(const std::string& in, const std::string& out);

}  // namespace imukit::capture
