// Codec for Xsens MTi devices over serial: XBus frames `FA BID MID LEN [LENH LENL] DATA CS`
// (the checksum makes the byte sum from BID to CS zero mod 256; LEN 0xFF announces a 2-byte
// big-endian extended length) carrying MTData2 (MID 0x36), a list of {data id u16 BE, size u8,
// big-endian value} items (seed-summary section 4; Xsens MT Low-Level Communication Protocol).
//
// Decoded: PacketCounter (0x1020, u16, unwrapped: gaps are dropped packets), SampleTimeFine
// (0x1060, u32 at 10 kHz, unwrapped: the device time), Acceleration (0x4020, m/s^2), RateOfTurn
// (0x8020, rad/s), MagneticField (0xC020, arbitrary units normalised to the Earth field),
// Temperature (0x0810, degC), StatusWord (0xE020). The low two bits of a data id give the
// precision: float32, fixed 12.20, fixed 16.32 or float64; all four are read.
//
// Configuration: xsens_configure_commands() builds GoToConfig, SetOutputConfiguration and
// GoToMeasurement, which the codec queues at start when a rate is asked for.
#pragma once

#include <optional>

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

namespace xsens {
inline constexpr uint8_t kPreamble = 0xFA;
inline constexpr uint8_t kMasterBid = 0xFF;
inline constexpr uint8_t kMidGoToConfig = 0x30;
inline constexpr uint8_t kMidGoToConfigAck = 0x31;
inline constexpr uint8_t kMidGoToMeasurement = 0x10;
inline constexpr uint8_t kMidGoToMeasurementAck = 0x11;
inline constexpr uint8_t kMidSetOutputConfiguration = 0xC0;
inline constexpr uint8_t kMidOutputConfiguration = 0xC1;
inline constexpr uint8_t kMidMtData2 = 0x36;
inline constexpr uint8_t kMidError = 0x42;
inline constexpr uint16_t kPacketCounter = 0x1020;
inline constexpr uint16_t kSampleTimeFine = 0x1060;
inline constexpr uint16_t kAcceleration = 0x4020;
inline constexpr uint16_t kRateOfTurn = 0x8020;
inline constexpr uint16_t kMagneticField = 0xC020;
inline constexpr uint16_t kTemperature = 0x0810;
inline constexpr uint16_t kStatusWord = 0xE020;
inline constexpr uint16_t kMaxRate = 0xFFFF;  // "every packet" in SetOutputConfiguration
inline constexpr std::size_t kMaxDataLength = 2048;
}  // namespace xsens

// One XBus frame to the device (BID 0xFF), checksum included.
std::vector<uint8_t> xsens_frame(uint8_t mid, std::span<const uint8_t> payload);

struct XsensOutput {
  uint16_t data_id;
  uint16_t rate_hz;  // 0xFFFF: with every packet
};
// SetOutputConfiguration's payload: {data id u16 BE, rate u16 BE} per output.
std::vector<uint8_t> xsens_output_configuration(std::span<const XsensOutput> outputs);
// GoToConfig, SetOutputConfiguration (counter, time, acceleration, rate of turn, magnetic field
// at min(rate, mag_rate_hz), temperature, status), GoToMeasurement.
std::vector<uint8_t> xsens_configure_commands(uint16_t rate_hz, uint16_t mag_rate_hz = 100);

// One MTData2 message's items (the parts imukit reads).
struct XsensPacket {
  std::optional<uint16_t> packet_counter;
  std::optional<uint32_t> sample_time_fine;
  std::optional<std::array<double, 3>> acceleration, rate_of_turn, magnetic_field;
  std::optional<double> temperature;
  std::optional<uint32_t> status_word;
};
// Parses an MTData2 payload; false if an item runs past the end or has a size its precision
// does not allow.
bool parse_mtdata2(std::span<const uint8_t> payload, XsensPacket& out);

struct XsensCodecOptions {
  uint16_t rate_hz = 0;  // 0: do not configure
  uint16_t mag_rate_hz = 100;
};

class XsensCodec : public Codec {
 public:
  explicit XsensCodec(XsensCodecOptions options = {});
  std::string name() const override { return "xsens"; }
  void start(TimeNs now) override;
  std::size_t bytes_pending() const override { return buf_.size() - head_; }
  // MIDs of the non-data messages received (acks, errors), in order.
  const std::vector<uint8_t>& messages() const { return messages_; }

 protected:
  void decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) override;
  void decode_end(TimeNs host_time, std::vector<Sample>& out) override;

 private:
  void parse(TimeNs host_time, std::vector<Sample>& out, bool at_end);
  void on_message(uint8_t mid, std::span<const uint8_t> data, TimeNs host_time,
                  std::vector<Sample>& out);

  XsensCodecOptions opt_;
  std::vector<uint8_t> buf_;
  std::size_t head_ = 0;
  uint64_t base_ = 0;  // stream offset of buf_[0]
  // Stream offset up to which rejected bytes belong to the damaged frame counted last (the end
  // its length gives; UINT64_MAX when unknown: up to the next valid frame); 0 after a valid one.
  uint64_t damaged_until_ = 0;
  CounterUnwrapper counter_{16};
  CounterUnwrapper time_{32};
  uint64_t decoded_ = 0;
  std::vector<uint8_t> messages_;
};

}  // namespace imukit::drivers
