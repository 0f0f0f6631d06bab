// The ROS 2 messages imukit records, encoded as CDR (little-endian, XCDR1 plain) with their
// ros2msg schema text, so ROS 2 tools and Foxglove open imukit's MCAP files:
// - sensor_msgs/msg/Imu on /imu/<device>: calibrated samples in SI units;
// - imukit_msgs/msg/RawImu on /imu/<device>/raw: raw counts, device ticks, cumulative sample
//   index and host receive time (defined in docs/formats.md);
// - sensor_msgs/msg/MagneticField on /imu/<device>/mag: the magnetometer, T (simulate writes it).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/time.hpp"

namespace imukit::capture {

extern const std::string_view kImuSchemaName;     // "sensor_msgs/msg/Imu"
extern const std::string_view kImuSchemaText;     // ros2msg definition with dependencies
extern const std::string_view kRawImuSchemaName;  // "imukit_msgs/msg/RawImu"
extern const std::string_view kRawImuSchemaText;
extern const std::string_view kMagneticFieldSchemaName;  // "sensor_msgs/msg/MagneticField"
extern const std::string_view kMagneticFieldSchemaText;
// Events (labels, markers) are not ROS messages: JSON on kEventTopic, described by a JSON schema.
extern const std::string_view kEventTopic;       // "/events"
extern const std::string_view kEventSchemaName;  // "imukit_msgs/Event"
extern const std::string_view kEventSchemaText;  // jsonschema: {kind, label}

struct ImuMessage {
  TimeNs stamp = 0;  // ns since the Unix epoch (split into sec/nanosec, floor)
  std::string frame_id;
  std::array<double, 4> orientation_xyzw = {0, 0, 0, 1};  // ROS order: x, y, z, w
  // Row-major 3x3. As sensor_msgs/Imu says: all zeros = covariance unknown; element 0 = -1 =
  // this quantity is not provided (imukit sets that for orientation).
  std::array<double, 9> orientation_covariance = {-1, 0, 0, 0, 0, 0, 0, 0, 0};
  std::array<double, 3> angular_velocity = {};  // rad/s
  std::array<double, 9> angular_velocity_covariance = {};
  std::array<double, 3> linear_acceleration = {};  // m/s^2
  std::array<double, 9> linear_acceleration_covariance = {};
};

struct RawImuMessage {
  TimeNs stamp = 0;                   // mapped sample time (host clock, ns since the epoch)
  TimeNs host_receive_time = 0;       // when the packet holding the sample reached the host
  uint64_t sample_index = 0;          // cumulative since streaming started, unwrapped
  uint64_t device_ticks = 0;          // device clock, unwrapped
  double tick_hz = 0;                 // device clock rate
  std::array<int32_t, 3> accel = {};  // raw counts
  std::array<int32_t, 3> gyro = {};
  std::array<int32_t, 3> mag = {};
  int32_t temperature = 0;
  // Raw counts: bit 0 accel, 1 gyro, 2 mag, 3 temperature; bit 4 device clock; bit 5
  // sample_index counts every sample made (a device's counter).
  uint8_t channels = 0;
};

struct MagneticFieldMessage {
  TimeNs stamp = 0;
  std::string frame_id;
  std::array<double, 3> magnetic_field = {};  // T, sensor frame
  // Row-major 3x3; all zeros = covariance unknown (sensor_msgs/MagneticField).
  std::array<double, 9> magnetic_field_covariance = {};
};

std::vector<uint8_t> encode_cdr(const ImuMessage& m);
std::vector<uint8_t> encode_cdr(const RawImuMessage& m);
std::vector<uint8_t> encode_cdr(const MagneticFieldMessage& m);
// Throw imukit::Error (naming `source` and the byte) on malformed input.
ImuMessage decode_imu_cdr(std::span<const uint8_t> data, const std::string& source);
RawImuMessage decode_raw_imu_cdr(std::span<const uint8_t> data, const std::string& source);
MagneticFieldMessage decode_magnetic_field_cdr(std::span<const uint8_t> data,
                                               const std::string& source);

}  // namespace imukit::capture
