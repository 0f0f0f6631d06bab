#include "imukit/capture/recording_mcap.hpp"

#include <fmt/core.h>
#include <array>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "imukit/capture/ros_messages.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"

namespace imukit::capture {
namespace {

constexpr std::string_view kImuPrefix = "/imu/";

// A sample that is NaN or infinite would flow silently into every result computed from it.
void require_finite(const std::array<double, 3>& v, const std::string& where, const char* what) {
  if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
    throw Error(fmt::format("{}: {} ({}, {}, {}) is not finite", where, what, v[0], v[1], v[2]));
  }
}

// An MCAP log_time is unsigned and a ROS 2 stamp's seconds an int32: a time before 1970 became a
// log_time 584 years long, one from 2038-01-19 03:14:08 UTC on wrapped to 1901 in the stamp (the
// file read back with times 136 years early; found in review, 2026-11-27).
void check_storable_time(TimeNs t, const std::string& where) {
  constexpr TimeNs kEnd = (TimeNs{1} << 31) * kNsPerSecond;
  if (t < 0 || t >= kEnd) {
    throw Error(fmt::format(
        "{}: time {} ns is outside what sensor_msgs/Imu and MCAP store (0 to 2^31 s after "
        "1970, until 2038-01-19 03:14:08 UTC)",
        where, t));
  }
}

// The recording's metadata, streams and events into writer, which it closes.
void write_recording(McapWriter& writer, const Recording& recording,
                     const std::map<std::string, ImuCovariance>& covariance) {
  McapMetadataMap meta(recording.metadata.begin(), recording.metadata.end());
  writer.write_metadata("imukit.recording", meta);
  const uint16_t imu_schema = writer.add_schema(kImuSchemaName, "ros2msg", kImuSchemaText);
  uint16_t mag_schema = 0;  // added with the first stream that has a magnetometer
  for (const auto& [name, series] : recording.streams) {
    const uint16_t channel = writer.add_channel(imu_schema, std::string(kImuPrefix) + name, "cdr");
    ImuMessage m;
    m.frame_id = name;
    if (const auto it = covariance.find(name); it != covariance.end()) {
      for (int k = 0; k < 3; ++k) {
        m.angular_velocity_covariance[4 * k] = it->second.gyro_variance;
        m.linear_acceleration_covariance[4 * k] = it->second.accel_variance;
      }
    }
    for (std::size_t i = 0; i < series.size(); ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      m.stamp = series.t[i];
      for (int k = 0; k < 3; ++k) {
        m.angular_velocity[static_cast<std::size_t>(k)] = series.gyro(k, c);
        m.linear_acceleration[static_cast<std::size_t>(k)] = series.accel(k, c);
      }
      const uint64_t t = static_cast<uint64_t>(series.t[i]);
      writer.write_message(channel, t, t, encode_cdr(m));
    }
    if (series.has_mag()) {
      // The magnetometer beside it, /imu/<name>/mag, one message per sample.
      if (mag_schema == 0)
        mag_schema =
            writer.add_schema(kMagneticFieldSchemaName, "ros2msg", kMagneticFieldSchemaText);
      const uint16_t mag_channel =
          writer.add_channel(mag_schema, std::string(kImuPrefix) + name + "/mag", "cdr");
      MagneticFieldMessage f;
      f.frame_id = name;
      for (std::size_t i = 0; i < series.size(); ++i) {
        const auto c = static_cast<Eigen::Index>(i);
        f.stamp = series.t[i];
        for (int k = 0; k < 3; ++k)
          f.magnetic_field[static_cast<std::size_t>(k)] = series.mag(k, c);
        const uint64_t t = static_cast<uint64_t>(series.t[i]);
        writer.write_message(mag_channel, t, t, encode_cdr(f));
      }
    }
  }
  if (!recording.events.empty()) {
    const uint16_t schema = writer.add_schema(kEventSchemaName, "jsonschema", kEventSchemaText);
    const uint16_t channel = writer.add_channel(schema, kEventTopic, "json");
    for (const Event& e : recording.events) {
      const std::string text = nlohmann::json{{"kind", e.kind}, {"label", e.label}}.dump();
      const uint64_t t = static_cast<uint64_t>(e.t);
      writer.write_message(channel, t, t,
                           std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
    }
  }
  writer.close();
}

}  // namespace

void write_recording_mcap(const std::string& path, const Recording& recording,
                          const std::map<std::string, ImuCovariance>& covariance,
                          const McapWriterOptions& options) {
  // Checked before the file is opened, so a refused recording leaves an earlier file as it was.
  for (const auto& [name, series] : recording.streams) {
    if (!series.has_accel() || !series.has_gyro()) {
      throw Error(fmt::format(
          "{}: stream '{}' needs accelerometer and gyroscope for sensor_msgs/Imu", path, name));
    }
    for (std::size_t i = 0; i < series.size(); ++i)
      check_storable_time(series.t[i], fmt::format("{}: stream '{}' sample {}", path, name, i));
  }
  for (std::size_t i = 0; i < recording.events.size(); ++i)
    check_storable_time(recording.events[i].t, fmt::format("{}: event {}", path, i));
  // Through a temporary renamed over path when complete: a failure (a full disk, a value the
  // encoder refuses) leaves no truncated file under the final name and an earlier file as it was.
  write_file_atomically(path, [&](std::FILE* file) {
    McapWriter writer(file, path, options);
    write_recording(writer, recording, covariance);
  });
}

namespace {

// `read` runs the MCAP reader over the file or the bytes with the handlers given.
RecordingRead read_recording(const std::string& path,
                             const std::function<McapReadSummary(const McapHandlers&)>& read) {
  RecordingRead out;
  std::map<uint16_t, std::string> schema_names;
  std::map<uint16_t, std::string> imu_channels;  // channel -> stream name
  std::map<uint16_t, bool> event_channels;
  std::map<std::string, std::vector<ImuMessage>> samples;
  std::map<uint16_t, std::string> mag_channels;  // channel -> stream name
  std::map<std::string, std::vector<MagneticFieldMessage>> mag_samples;
  std::set<std::string> with_orientation;
  McapHandlers handlers;
  handlers.on_schema = [&](const McapSchema& s) { schema_names[s.id] = s.name; };
  handlers.on_channel = [&](const McapChannel& c) {
    const auto schema = schema_names.find(c.schema_id);
    const bool imu = schema != schema_names.end() && schema->second == kImuSchemaName;
    if (imu && c.message_encoding == "cdr") {
      imu_channels[c.id] =
          c.topic.rfind(kImuPrefix, 0) == 0 ? c.topic.substr(kImuPrefix.size()) : c.topic;
    } else if (c.topic == kEventTopic && c.message_encoding == "json") {
      event_channels[c.id] = true;
    } else if (schema != schema_names.end() && schema->second == kMagneticFieldSchemaName &&
               c.message_encoding == "cdr" && c.topic.rfind(kImuPrefix, 0) == 0 &&
               c.topic.size() > kImuPrefix.size() + 4 &&
               c.topic.compare(c.topic.size() - 4, 4, "/mag") == 0) {
      // /imu/<name>/mag: the magnetometer of stream <name>.
      mag_channels[c.id] =
          c.topic.substr(kImuPrefix.size(), c.topic.size() - kImuPrefix.size() - 4);
    }
  };
  handlers.on_message = [&](const McapMessageView& m) {
    if (const auto it = imu_channels.find(m.channel_id); it != imu_channels.end()) {
      const std::string where = fmt::format("{}: message {} of {}", path, m.sequence, it->second);
      ImuMessage msg = decode_imu_cdr(m.data, where);
      require_finite(msg.angular_velocity, where, "angular velocity");
      require_finite(msg.linear_acceleration, where, "linear acceleration");
      if (msg.orientation_covariance[0] != -1.0) with_orientation.insert(it->second);
      samples[it->second].push_back(std::move(msg));
    } else if (const auto mt = mag_channels.find(m.channel_id); mt != mag_channels.end()) {
      const std::string where =
          fmt::format("{}: message {} of {}/mag", path, m.sequence, mt->second);
      MagneticFieldMessage msg = decode_magnetic_field_cdr(m.data, where);
      require_finite(msg.magnetic_field, where, "magnetic field");
      mag_samples[mt->second].push_back(std::move(msg));
    } else if (event_channels.count(m.channel_id)) {
      const auto json = nlohmann::json::parse(m.data.begin(), m.data.end(), nullptr, false);
      if (json.is_discarded() || !json.is_object()) {
        throw Error(fmt::format("{}: /events message {} is not a JSON object", path, m.sequence));
      }
      const auto text = [&](const char* key) {
        const auto it = json.find(key);
        return it != json.end() && it->is_string() ? it->get<std::string>() : std::string();
      };
      out.recording.events.push_back(
          {static_cast<TimeNs>(m.log_time), text("kind"), text("label")});
    }
  };
  out.summary = read(handlers);
  out.streams_with_orientation.assign(with_orientation.begin(), with_orientation.end());
  // The recording's own metadata as is; other records (device info, session statistics) with
  // their record's name in front of each key.
  for (const auto& md : out.summary.metadata) {
    for (const auto& [key, value] : md.entries) {
      out.recording.metadata[md.name == "imukit.recording" ? key : md.name + "." + key] = value;
    }
  }
  for (auto& [name, messages] : samples) {
    const auto mag = mag_samples.find(name);
    ImuSeries s = ImuSeries::with_channels(messages.size(), true, true, mag != mag_samples.end());
    if (mag != mag_samples.end()) {
      // One field per Imu sample, at the same stamps (how write_recording_mcap and simulate
      // write them); anything else cannot be one series.
      const std::vector<MagneticFieldMessage>& f = mag->second;
      bool same = f.size() == messages.size();
      for (std::size_t i = 0; same && i < f.size(); ++i) same = f[i].stamp == messages[i].stamp;
      if (!same) {
        throw Error(
            fmt::format("{}: /imu/{}/mag does not have one message per /imu/{} sample at "
                        "the same stamps",
                        path, name, name));
      }
      for (std::size_t i = 0; i < f.size(); ++i) {
        for (int k = 0; k < 3; ++k)
          s.mag(k, static_cast<Eigen::Index>(i)) = f[i].magnetic_field[static_cast<std::size_t>(k)];
      }
    }
    for (std::size_t i = 0; i < messages.size(); ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      s.t[i] = messages[i].stamp;
      for (int k = 0; k < 3; ++k) {
        s.gyro(k, c) = messages[i].angular_velocity[static_cast<std::size_t>(k)];
        s.accel(k, c) = messages[i].linear_acceleration[static_cast<std::size_t>(k)];
      }
    }
    out.recording.streams[name] = std::move(s);
  }
  return out;
}

}  // namespace

RecordingRead read_recording_mcap(const std::string& path) {
  return read_recording(path, [&](const McapHandlers& h) { return read_mcap(path, h); });
}

RecordingRead read_recording_mcap(std::span<const uint8_t> bytes, const std::string& source_name) {
  return read_recording(source_name,
                        [&](const McapHandlers& h) { return read_mcap(bytes, source_name, h); });
}

}  // namespace imukit::capture
