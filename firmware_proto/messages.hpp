// Messages of the imukit wire protocol v1 (docs/protocol.md, section "Messages"): one plain struct
// per message type with fixed-capacity arrays (no heap), and for each a payload writer and a
// payload parser. Layouts are little-endian and packed field by field; every count and length read
// from the wire is checked against its bound before it is used, and a v1 payload must have exactly
// the size its fields imply (no trailing bytes).
//
// Physical quantities on the wire are SI (m/s^2, rad/s, tesla, degrees Celsius for temperature) as
// IEEE-754 binary32; rates are integers in millihertz so 12.5 Hz or 104 Hz are exact.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "imukit/firmware_proto/bytes.hpp"
#include "imukit/firmware_proto/frame.hpp"

namespace imukit::proto {

inline constexpr size_t kMaxTextSize = 32;      // vendor, model, serial
inline constexpr size_t kMaxRates = 8;          // output data rates a device lists
inline constexpr size_t kMaxSensors = 4;        // one of each SensorKind
inline constexpr size_t kMaxRanges = 8;         // full-scale ranges per sensor
inline constexpr size_t kMaxBlockSamples = 32;  // samples per SampleBlock
inline constexpr size_t kMaxCalibrationData = 512;
inline constexpr size_t kMaxLogText = 200;

// A sensor's kind is also its channel bit: channel mask bit (1 << kind).
enum class SensorKind : uint8_t {
  kAccelerometer = 0,
  kGyroscope = 1,
  kMagnetometer = 2,
  kTemperature = 3,
};
inline constexpr uint8_t kChannelAccel = 1u << 0;
inline constexpr uint8_t kChannelGyro = 1u << 1;
inline constexpr uint8_t kChannelMag = 1u << 2;
inline constexpr uint8_t kChannelTemperature = 1u << 3;
inline constexpr uint8_t kChannelMaskAll = 0x0F;

constexpr uint8_t channel_bit(SensorKind kind) {
  return static_cast<uint8_t>(1u << static_cast<uint8_t>(kind));
}
constexpr uint8_t axes_of(SensorKind kind) { return kind == SensorKind::kTemperature ? 1 : 3; }
// Bytes one sample occupies in a SampleBlock for a channel mask (int16 per axis).
constexpr size_t sample_size(uint8_t channels) {
  return ((channels & kChannelAccel) ? 6u : 0u) + ((channels & kChannelGyro) ? 6u : 0u) +
         ((channels & kChannelMag) ? 6u : 0u) + ((channels & kChannelTemperature) ? 2u : 0u);
}

enum class ParseStatus : uint8_t {
  kOk = 0,
  kWrongType,    // the frame carries another message type
  kBadLength,    // payload shorter or longer than its fields imply
  kBadValue,     // a field outside its allowed range (count, enum, reserved bits, NaN, ...)
  kBadChecksum,  // a calibration blob whose own CRC does not match
};

// Not-acknowledge reasons (Nack::code).
enum class NackCode : uint8_t {
  kUnknownMessage = 1,       // type not handled by the device (or sent in the wrong direction)
  kMalformed = 2,            // payload failed to parse
  kBadState = 3,             // not allowed now (configure or start while streaming, ...)
  kUnsupportedRate = 4,      // rate_mhz not in DeviceInfo::rates_mhz
  kUnsupportedSensor = 5,    // a channel bit for a sensor the device does not have
  kNoSensorsEnabled = 6,     // channel mask is zero
  kUnsupportedRange = 7,     // range index beyond the sensor's range list
  kInvalidBlockSize = 8,     // samples_per_block not in 1..32
  kHardwareError = 9,        // the sensor refused the configuration
  kCalibrationInvalid = 10,  // blob CRC or format version wrong (sent or stored)
  kNoCalibration = 11,       // nothing stored
  kStorageError = 12,        // storing the blob failed
};

enum class LogLevel : uint8_t { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// Short text: size bytes of UTF-8, not NUL-terminated.
struct Text {
  uint8_t size = 0;
  char chars[kMaxTextSize] = {};
  // Copies a NUL-terminated string, cut at kMaxTextSize bytes.
  void set(const char* s);
};
bool operator==(const Text& a, const Text& b);

// One full-scale setting: readings span [-full_scale, +full_scale] and one LSB is `scale`, both in
// the sensor's SI unit. value = offset + scale * raw.
struct SensorRange {
  float full_scale = 0;
  float scale = 0;
};

struct SensorInfo {
  SensorKind kind = SensorKind::kAccelerometer;
  uint8_t axes = 3;  // 3, or 1 for temperature
  float offset = 0;  // SI value at raw 0 (e.g. 25 degC for many temperature sensors)
  uint8_t range_count = 0;
  SensorRange ranges[kMaxRanges] = {};
};

// 0x01, host -> device: ask for DeviceInfo. Empty payload.
struct GetDeviceInfo {
  static constexpr MessageType kType = MessageType::kGetDeviceInfo;
};

// 0x81, device -> host.
struct DeviceInfo {
  static constexpr MessageType kType = MessageType::kDeviceInfo;
  Text vendor;
  Text model;
  Text serial;
  uint8_t firmware_major = 0;
  uint8_t firmware_minor = 0;
  uint16_t firmware_patch = 0;
  uint32_t tick_hz = 0;  // rate of the device clock that stamps samples and pongs
  uint8_t rate_count = 0;
  uint32_t rates_mhz[kMaxRates] = {};  // supported output data rates, millihertz
  uint8_t sensor_count = 0;
  SensorInfo sensors[kMaxSensors] = {};

  // The sensor of a kind, or nullptr.
  const SensorInfo* find(SensorKind kind) const;
  // Channel mask of the sensors present.
  uint8_t channels() const;
  // A rate's sample period is 1 to 2^30 ticks (poll()'s signed tick comparison): what Configure
  // accepts, and what every listed rate must be for the DeviceInfo to be valid.
  bool rate_fits_clock(uint32_t rate_mhz) const {
    const uint64_t period = rate_mhz == 0 ? 0 : uint64_t{tick_hz} * 1000u / rate_mhz;
    return period >= 1 && period <= (uint64_t{1} << 30);
  }
};

// 0x02, host -> device: acknowledged, or not-acknowledged with the reason.
struct Configure {
  static constexpr MessageType kType = MessageType::kConfigure;
  uint32_t rate_mhz = 0;                  // output data rate, one of DeviceInfo::rates_mhz
  uint8_t channels = 0;                   // sensors on (kChannel* bits)
  uint8_t range_index[kMaxSensors] = {};  // per SensorKind, index into SensorInfo::ranges
  uint8_t samples_per_block = 0;          // 1..kMaxBlockSamples
};

// 0x03 / 0x04, host -> device: start or stop streaming. Empty payloads.
struct Start {
  static constexpr MessageType kType = MessageType::kStart;
};
struct Stop {
  static constexpr MessageType kType = MessageType::kStop;
};

// 0x05, host -> device: time-sync request. host_time is opaque to the device and echoed.
struct Ping {
  static constexpr MessageType kType = MessageType::kPing;
  uint64_t host_time = 0;
};

// 0x83, device -> host: rx_tick when the ping's last byte arrived, tx_tick when the pong left.
struct Pong {
  static constexpr MessageType kType = MessageType::kPong;
  uint64_t host_time = 0;
  uint32_t rx_tick = 0;
  uint32_t tx_tick = 0;
};

// A calibration record the device stores for the host: format_version names the layout of data
// (defined by the host software, never 0), crc = CRC-32C over format_version, size (u16 LE) and
// data, so corruption in the device's storage is detected on its way back.
struct CalibrationBlob {
  uint8_t format_version = 0;
  uint16_t size = 0;
  uint8_t data[kMaxCalibrationData] = {};
  uint32_t crc = 0;

  uint32_t compute_crc() const;
  void seal() { crc = compute_crc(); }
  bool valid() const {
    return format_version != 0 && size <= kMaxCalibrationData && crc == compute_crc();
  }
};
inline constexpr size_t kMaxCalibrationBlobSize = 1 + 2 + kMaxCalibrationData + 4;

// 0x06, host -> device: read the stored blob. Empty payload.
struct CalibrationRead {
  static constexpr MessageType kType = MessageType::kCalibrationRead;
};
// 0x07, host -> device: store a blob (acknowledged once stored).
struct CalibrationWrite {
  static constexpr MessageType kType = MessageType::kCalibrationWrite;
  CalibrationBlob blob;
};
// 0x84, device -> host: the stored blob, answer to CalibrationRead.
struct CalibrationData {
  static constexpr MessageType kType = MessageType::kCalibrationData;
  CalibrationBlob blob;
};

// 0x85 / 0x86, device -> host: outcome of a request, naming its type and sequence number.
struct Ack {
  static constexpr MessageType kType = MessageType::kAck;
  uint8_t request_type = 0;
  uint16_t request_sequence = 0;
};
struct Nack {
  static constexpr MessageType kType = MessageType::kNack;
  uint8_t request_type = 0;
  uint16_t request_sequence = 0;
  NackCode code = NackCode::kUnknownMessage;
};

// 0x87, device -> host: a line of text for the host's log.
struct Log {
  static constexpr MessageType kType = MessageType::kLog;
  LogLevel level = LogLevel::kInfo;
  uint32_t tick = 0;
  uint8_t size = 0;
  char text[kMaxLogText] = {};
};

// 0x82, device -> host: `count` consecutive samples. Sample i of the block has cumulative index
// sample_index + i since streaming started; first_tick stamps sample 0 on the device clock.
struct SampleBlock {
  static constexpr MessageType kType = MessageType::kSampleBlock;
  uint32_t sample_index = 0;
  uint32_t first_tick = 0;
  uint8_t count = 0;     // 1..kMaxBlockSamples
  uint8_t channels = 0;  // kChannel* bits present in every sample, not zero
  int16_t accel[kMaxBlockSamples][3] = {};
  int16_t gyro[kMaxBlockSamples][3] = {};
  int16_t mag[kMaxBlockSamples][3] = {};
  int16_t temperature[kMaxBlockSamples] = {};
};
inline constexpr size_t kSampleBlockHeaderSize = 10;
static_assert(kSampleBlockHeaderSize + kMaxBlockSamples * sample_size(kChannelMaskAll) <=
                  kMaxPayloadSize,
              "a full sample block with every channel must fit one frame");
static_assert(kMaxCalibrationBlobSize <= kMaxPayloadSize, "calibration blob must fit one frame");

// Payload writers: false (and w.ok() false) when the struct holds values the protocol does not
// allow (a count beyond its bound, an unknown enum, ...) or the buffer is too small.
bool write_payload(ByteWriter& w, const GetDeviceInfo& m);
bool write_payload(ByteWriter& w, const DeviceInfo& m);
bool write_payload(ByteWriter& w, const Configure& m);
bool write_payload(ByteWriter& w, const Start& m);
bool write_payload(ByteWriter& w, const Stop& m);
bool write_payload(ByteWriter& w, const Ping& m);
bool write_payload(ByteWriter& w, const Pong& m);
bool write_payload(ByteWriter& w, const CalibrationRead& m);
bool write_payload(ByteWriter& w, const CalibrationWrite& m);
bool write_payload(ByteWriter& w, const CalibrationData& m);
bool write_payload(ByteWriter& w, const Ack& m);
bool write_payload(ByteWriter& w, const Nack& m);
bool write_payload(ByteWriter& w, const Log& m);
bool write_payload(ByteWriter& w, const SampleBlock& m);
// The serialised blob alone (what CalibrationWrite/CalibrationData carry and the device stores).
bool write_blob(ByteWriter& w, const CalibrationBlob& blob);

// Payload parsers. On anything but kOk the output is unspecified (partly filled).
ParseStatus read_payload(const uint8_t* p, size_t n, GetDeviceInfo& out);
ParseStatus read_payload(const uint8_t* p, size_t n, DeviceInfo& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Configure& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Start& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Stop& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Ping& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Pong& out);
ParseStatus read_payload(const uint8_t* p, size_t n, CalibrationRead& out);
ParseStatus read_payload(const uint8_t* p, size_t n, CalibrationWrite& out);
ParseStatus read_payload(const uint8_t* p, size_t n, CalibrationData& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Ack& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Nack& out);
ParseStatus read_payload(const uint8_t* p, size_t n, Log& out);
ParseStatus read_payload(const uint8_t* p, size_t n, SampleBlock& out);
// A serialised blob; kBadChecksum when its CRC does not match, kBadValue for format_version 0.
ParseStatus read_blob(const uint8_t* p, size_t n, CalibrationBlob& out);
// The same verdict as read_blob without copying the blob out (what a device needs to store or
// return the bytes as they are).
ParseStatus check_blob(const uint8_t* p, size_t n);

// Encodes message m as a complete frame with the given sequence number. Returns the frame's size
// (delimiter included) or 0 if m is not valid or out_capacity is too small (kMaxFrameSize always
// suffices).
template <class M>
size_t encode_message(const M& m, uint16_t sequence, uint8_t* out, size_t out_capacity) {
  uint8_t payload[kMaxPayloadSize];
  ByteWriter w(payload, sizeof payload);
  if (!write_payload(w, m) || !w.ok()) return 0;
  return encode_frame(static_cast<uint8_t>(M::kType), sequence, payload, w.size(), out,
                      out_capacity);
}

// Parses a decoded frame as message M.
template <class M>
ParseStatus parse_message(const Frame& frame, M& out) {
  if (frame.type != static_cast<uint8_t>(M::kType)) return ParseStatus::kWrongType;
  return read_payload(frame.payload, frame.payload_size, out);
}

}  // namespace imukit::proto
