// A core Recording as an MCAP file, in the layout of DESIGN.md, and back:
// - each stream `name` on topic /imu/<name> as ROS 2 sensor_msgs/msg/Imu (ros2msg + cdr),
//   log_time = sample time, covariances from the stream's noise where known (else "unknown");
//   a stream with a magnetometer also on /imu/<name>/mag as sensor_msgs/msg/MagneticField (T),
//   one message per sample at the same stamps;
// - events on /events as JSON messages {"kind": ..., "label": ...} (schema imukit_msgs/Event,
//   jsonschema), log_time = event time;
// - recording metadata in one MCAP Metadata record named "imukit.recording".
#pragma once

#include <map>
#include <span>
#include <string>

#include "imukit/capture/mcap.hpp"
#include "imukit/core/imu_series.hpp"

namespace imukit::capture {

// Per-stream white-noise variances for the ROS covariance fields (rad^2/s^2, m^2/s^4 per sample);
// streams without an entry get all-zero covariances, which sensor_msgs/Imu defines as unknown.
struct ImuCovariance {
  double gyro_variance = 0.0;
  double accel_variance = 0.0;
};

void write_recording_mcap(const std::string& path, const Recording& recording,
                          const std::map<std::string, ImuCovariance>& covariance = {},
                          const McapWriterOptions& options = {});

struct RecordingRead {
  Recording recording;
  McapReadSummary summary;  // complete == false with a note when the file was cut short
  // Streams whose sensor_msgs/Imu carried an orientation (orientation_covariance[0] != -1, the
  // ROS mark of "not provided"): a Recording does not hold it, so a rewrite loses it.
  std::vector<std::string> streams_with_orientation;
};

// Reads the sensor_msgs/Imu channels (streams named after their topic without "/imu/"), their
// /imu/<name>/mag MagneticField channels into the streams' mag (an error unless one message per
// sample at the same stamps), the
// /events channel and the metadata (keys of records other than "imukit.recording" are prefixed
// with the record's name, e.g. "imukit.session.mock.samples_dropped"); other channels are
// ignored.
RecordingRead read_recording_mcap(const std::string& path);
// The same for a file already in memory; `source_name` is used in messages.
RecordingRead read_recording_mcap(std::span<const uint8_t> bytes, const std::string& source_name);

}  // namespace imukit::capture
