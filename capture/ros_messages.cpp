#include "imukit/capture/ros_messages.hpp"

#include <fmt/core.h>

#include <limits>

#include "imukit/capture/bytes.hpp"
#include "imukit/core/error.hpp"

namespace imukit::capture {

// The nested definitions a ROS 2 schema text appends after its own fields, each behind a
// separator line (string literals, so the texts below are assembled at compile time).
#define IMUKIT_ROS_SEPARATOR \
  "================================================================================\n"
#define IMUKIT_ROS_TIME \
  IMUKIT_ROS_SEPARATOR "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
#define IMUKIT_ROS_HEADER \
  IMUKIT_ROS_SEPARATOR "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
#define IMUKIT_ROS_VECTOR3 \
  IMUKIT_ROS_SEPARATOR "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"

const std::string_view kImuSchemaName = "sensor_msgs/msg/Imu";
const std::string_view kImuSchemaText =
    "std_msgs/Header header\n"
    "geometry_msgs/Quaternion orientation\n"
    "float64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\n"
    "float64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\n"
    "float64[9] linear_acceleration_covariance\n" IMUKIT_ROS_HEADER IMUKIT_ROS_TIME
        IMUKIT_ROS_SEPARATOR
    "MSG: geometry_msgs/Quaternion\n"
    "float64 x\n"
    "float64 y\n"
    "float64 z\n"
    "float64 w\n" IMUKIT_ROS_VECTOR3;

const std::string_view kRawImuSchemaName = "imukit_msgs/msg/RawImu";
const std::string_view kRawImuSchemaText =
    "builtin_interfaces/Time stamp\n"
    "int64 host_receive_time_ns\n"
    "uint64 sample_index\n"
    "uint64 device_ticks\n"
    "float64 tick_hz\n"
    "int32[3] accel\n"
    "int32[3] gyro\n"
    "int32[3] mag\n"
    "int32 temperature\n"
    "uint8 channels\n" IMUKIT_ROS_TIME;

const std::string_view kMagneticFieldSchemaName = "sensor_msgs/msg/MagneticField";
const std::string_view kMagneticFieldSchemaText =
    "std_msgs/Header header\n"
    "geometry_msgs/Vector3 magnetic_field\n"
    "float64[9] magnetic_field_covariance\n" IMUKIT_ROS_HEADER IMUKIT_ROS_TIME IMUKIT_ROS_VECTOR3;

const std::string_view kEventTopic = "/events";
const std::string_view kEventSchemaName = "imukit_msgs/Event";
const std::string_view kEventSchemaText =
    R"({"type":"object","properties":{"kind":{"type":"string"},"label":{"type":"string"}}})";

#undef IMUKIT_ROS_SEPARATOR
#undef IMUKIT_ROS_TIME
#undef IMUKIT_ROS_HEADER
#undef IMUKIT_ROS_VECTOR3

namespace {

// CDR aligns each primitive to its own size, counted from the end of the 4-byte encapsulation
// header.
constexpr std::size_t kOrigin = 4;

class CdrWriter {
 public:
  // The encapsulation header (CDR_LE, no options) as the vector's initial contents: appending it
  // to an empty vector tripped gcc 12's -Wstringop-overflow (a false positive).
  // Room for a whole sensor_msgs/Imu (about 330 bytes) from the start: growing from 4 bytes
  // took seven reallocations per message.
  CdrWriter() : out_{0x00, 0x01, 0x00, 0x00}, w_(out_) { out_.reserve(kReserve); }
  void align(std::size_t n) {
    while ((out_.size() - kOrigin) % n != 0) w_.u8(0);
  }
  void time(TimeNs t) {
    // Floor division, so times before 1970 still give 0 <= nanosec < 1e9.
    int64_t sec = t / kNsPerSecond;
    int64_t nsec = t % kNsPerSecond;
    if (nsec < 0) {
      nsec += kNsPerSecond;
      --sec;
    }
    // Callers check their times first (recording_mcap); a live session would need to run past
    // 2038 to get here.
    if (sec < std::numeric_limits<int32_t>::min() || sec > std::numeric_limits<int32_t>::max())
      throw Error(fmt::format("sensor_msgs time {} ns: its seconds do not fit an int32", t));
    i32(static_cast<int32_t>(sec));
    u32(static_cast<uint32_t>(nsec));
  }
  void i32(int32_t v) {
    align(4);
    w_.i32(v);
  }
  void u32(uint32_t v) {
    align(4);
    w_.u32(v);
  }
  void u64(uint64_t v) {
    align(8);
    w_.u64(v);
  }
  void f64(double v) {
    align(8);
    w_.f64(v);
  }
  void u8(uint8_t v) { w_.u8(v); }
  void string(const std::string& s) {
    u32(static_cast<uint32_t>(s.size() + 1));
    w_.bytes(s);
    w_.u8(0);
  }
  std::vector<uint8_t> take() { return std::move(out_); }

 private:
  static constexpr std::size_t kReserve = 384;
  std::vector<uint8_t> out_;
  ByteWriter w_;
};

class CdrReader {
 public:
  CdrReader(std::span<const uint8_t> data, const std::string& source) : r_(data, source, 0) {
    const auto header = r_.bytes(4, "CDR encapsulation header");
    if (header[0] != 0x00 || header[1] != 0x01) {
      r_.fail("CDR encapsulation is not little-endian plain CDR (00 01)");
    }
  }
  TimeNs time() {
    const int64_t sec = i32();
    const int64_t nsec = u32();
    if (nsec >= kNsPerSecond) r_.fail("nanosec field is 1e9 or more");
    return sec * kNsPerSecond + nsec;
  }
  int32_t i32() {
    r_.align(4, kOrigin);
    return r_.i32();
  }
  uint32_t u32() {
    r_.align(4, kOrigin);
    return r_.u32();
  }
  uint64_t u64() {
    r_.align(8, kOrigin);
    return r_.u64();
  }
  double f64() {
    r_.align(8, kOrigin);
    return r_.f64();
  }
  uint8_t u8() { return r_.u8(); }
  std::string string() {
    const uint32_t n = u32();
    if (n == 0) r_.fail("CDR string without its terminating NUL");
    const auto b = r_.bytes(n, "CDR string");
    if (b.back() != 0) r_.fail("CDR string is not NUL-terminated");
    return std::string(b.begin(), b.end() - 1);
  }
  void finish() {
    // Trailing padding to a 4-byte boundary is allowed, nothing else.
    if (r_.remaining() > 3) r_.fail("trailing bytes after the message");
  }

 private:
  ByteReader r_;
};

}  // namespace

std::vector<uint8_t> encode_cdr(const ImuMessage& m) {
  CdrWriter w;
  w.time(m.stamp);
  w.string(m.frame_id);
  for (double v : m.orientation_xyzw) w.f64(v);
  for (double v : m.orientation_covariance) w.f64(v);
  for (double v : m.angular_velocity) w.f64(v);
  for (double v : m.angular_velocity_covariance) w.f64(v);
  for (double v : m.linear_acceleration) w.f64(v);
  for (double v : m.linear_acceleration_covariance) w.f64(v);
  return w.take();
}

std::vector<uint8_t> encode_cdr(const RawImuMessage& m) {
  CdrWriter w;
  w.time(m.stamp);
  w.u64(static_cast<uint64_t>(m.host_receive_time));
  w.u64(m.sample_index);
  w.u64(m.device_ticks);
  w.f64(m.tick_hz);
  for (int32_t v : m.accel) w.i32(v);
  for (int32_t v : m.gyro) w.i32(v);
  for (int32_t v : m.mag) w.i32(v);
  w.i32(m.temperature);
  w.u8(m.channels);
  return w.take();
}

std::vector<uint8_t> encode_cdr(const MagneticFieldMessage& m) {
  CdrWriter w;
  w.time(m.stamp);
  w.string(m.frame_id);
  for (double v : m.magnetic_field) w.f64(v);
  for (double v : m.magnetic_field_covariance) w.f64(v);
  return w.take();
}

ImuMessage decode_imu_cdr(std::span<const uint8_t> data, const std::string& source) {
  CdrReader r(data, source);
  ImuMessage m;
  m.stamp = r.time();
  m.frame_id = r.string();
  for (double& v : m.orientation_xyzw) v = r.f64();
  for (double& v : m.orientation_covariance) v = r.f64();
  for (double& v : m.angular_velocity) v = r.f64();
  for (double& v : m.angular_velocity_covariance) v = r.f64();
  for (double& v : m.linear_acceleration) v = r.f64();
  for (double& v : m.linear_acceleration_covariance) v = r.f64();
  r.finish();
  return m;
}

RawImuMessage decode_raw_imu_cdr(std::span<const uint8_t> data, const std::string& source) {
  CdrReader r(data, source);
  RawImuMessage m;
  m.stamp = r.time();
  m.host_receive_time = static_cast<TimeNs>(r.u64());
  m.sample_index = r.u64();
  m.device_ticks = r.u64();
  m.tick_hz = r.f64();
  for (int32_t& v : m.accel) v = r.i32();
  for (int32_t& v : m.gyro) v = r.i32();
  for (int32_t& v : m.mag) v = r.i32();
  m.temperature = r.i32();
  m.channels = r.u8();
  r.finish();
  return m;
}

MagneticFieldMessage decode_magnetic_field_cdr(std::span<const uint8_t> data,
                                               const std::string& source) {
  CdrReader r(data, source);
  MagneticFieldMessage m;
  m.stamp = r.time();
  m.frame_id = r.string();
  for (double& v : m.magnetic_field) v = r.f64();
  for (double& v : m.magnetic_field_covariance) v = r.f64();
  r.finish();
  return m;
}

}  // namespace imukit::capture
