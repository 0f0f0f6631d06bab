// Codec for WitMotion WT901-family serial IMUs: 11-byte frames `55 TYPE d0..d7 SUM`, SUM the low
// byte of the sum of the first 10 bytes, four int16 LE values each (seed-summary section 4;
// WitMotion WT901 manual): 0x51 acceleration raw/32768 * 16 g plus temperature raw/100 degC,
// 0x52 angular rate raw/32768 * 2000 deg/s, 0x53 angles raw/32768 * 180 deg, 0x54 magnetic field
// (raw LSB, arbitrary units). Other types (time, pressure, quaternion) are counted and skipped.
//
// The device has no sample counter, so samples are stamped with the host time of the bytes that
// carried their acceleration frame. A sample is the group of frames from one 0x51 to the next;
// the codec learns which types a group holds from the first group without damage around it (a
// damaged group before it is dropped), and a later group missing one of them (its frame was
// corrupted or lost) is counted as a dropped sample instead of being emitted half-filled. A
// stretch of rejected bytes counts as ceil(bytes / 11) corrupt frames, and when it holds at
// least a whole group's frames, as that many groups' samples dropped too (a sample all of whose
// frames were damaged leaves no frame to show it). Types arrive in the learned group's order, so
// a stretch holding more frame starts (a header and a type) than there are frames between the
// frames on either side of it within a group crossed into a later group: the frame after it begins
// no sample of its own (its acceleration frame was lost) and is not merged into the one before
// (found in review: the tail of one group and the acceleration frame of the next damaged together
// gave one sample the acceleration of one and the angular rate of the next).
//
// A replay (decode only) reads bytes as fast as storage gives them, so receive times say nothing
// of when the samples were made. Given the rate the stream was made at, the codec times sample
// slot n (dropped samples included, so they leave a gap in `sequence` as a counter would) at
// n / rate on a device clock of `rate` ticks per second; without it samples carry receive times
// only and have no rate (capture/ says so instead of measuring one).
//
// Commands: `FF AA reg lo hi` (witmotion_command): unlock, set output rate, save.
#pragma once

#include <array>

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

std::vector<uint8_t> witmotion_command(uint8_t reg, uint16_t value);
// Unlock (FF AA 69 88 B5), RRATE (register 0x03) for the nearest supported rate, save
// (FF AA 00 00 00). Throws imukit::Error for a rate the device cannot do.
std::vector<uint8_t> witmotion_rate_commands(double rate_hz);
// One frame of `type` with values v (checksum computed), for tests and mocks.
std::vector<uint8_t> witmotion_frame(uint8_t type, const int16_t v[4]);

struct WitmotionCodecOptions {
  // With commands: the rate to set (0: leave the device's rate alone). Decoding only (a replay):
  // the rate the stream was made at, which times its samples (0: they have only receive times).
  double rate_hz = 0;
  double accel_range_g = 16.0;
  double gyro_range_dps = 2000.0;
  bool send_commands = true;  // false: decode only (a replay of a capture)
};

class WitmotionCodec : public Codec {
 public:
  explicit WitmotionCodec(WitmotionCodecOptions options = {});
  std::string name() const override { return "witmotion"; }
  void start(TimeNs now) override;
  std::size_t bytes_pending() const override { return buf_.size() - head_; }

 protected:
  void decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) override;
  void decode_end(TimeNs host_time, std::vector<Sample>& out) override;

 private:
  void emit(std::vector<Sample>& out);
  void count_damage();
  // After `damaged` frames were rejected, a frame at `position` of the learned group ends the
  // current group when more frames were damaged than lie between it and the group's latest
  // frame: the stretch ran past the group's end (and the next group's acceleration frame).
  bool damage_ends_group(int position, uint64_t damaged) const;

  WitmotionCodecOptions opt_;
  std::vector<uint8_t> buf_;
  std::size_t head_ = 0;
  bool in_group_ = false;
  uint8_t last_type_ = 0;       // type of the group's latest frame
  uint8_t group_types_ = 0;     // bit (type - 0x51) for the types seen in this group
  uint8_t expected_types_ = 0;  // learned from the first complete group
  bool learned_ = false;
  bool group_had_error_ = false;
  bool pending_error_ = false;   // corruption seen since the last accel frame
  uint64_t rejected_bytes_ = 0;  // bytes rejected since the last valid frame
  // Of them, the frame starts (a header byte and a type) that do not lie inside the frame of the
  // start before, and where the last of those lay in the stretch.
  uint64_t rejected_starts_ = 0;
  uint64_t last_start_ = 0;
  uint64_t frames_in_group_ = 0;   // valid frames since the group's acceleration frame
  uint64_t frames_per_group_ = 0;  // frames of the first clean group (0: not learned yet)
  // Per type (0x50..0x5F): its place among the frames of this group, and of the learned one
  // (-1: none); the place of this group's latest frame in the learned one.
  std::array<int8_t, 16> group_position_{};
  std::array<int8_t, 16> position_{};
  int last_position_ = -1;
  Sample current_;
  uint64_t sequence_ = 0;
  uint64_t group_slot_ = 0;  // decode only with a rate: the current group's slot (its tick)
};

}  // namespace imukit::drivers
