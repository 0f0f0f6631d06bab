#include "imukit/drivers/playstation_codec.hpp"

#include <cstdlib>

#include "imukit/core/error.hpp"
#include "imukit/core/units.hpp"

namespace imukit::drivers {
namespace {

constexpr std::size_t kInputReportSize = 64;
constexpr int kGyroResPerDps = 1024;
constexpr int kAccelResPerG = 8192;
constexpr int kGyroRange = 2048 * kGyroResPerDps;
constexpr int kAccelRange = 4 * kAccelResPerG;

int16_t le16s(const uint8_t* p) { return static_cast<int16_t>(p[0] | (p[1] << 8)); }

}  // namespace

PsCalibration playstation_default_calibration() {
  PsCalibration c;
  for (int i = 0; i < 3; ++i) {
    c.gyro[i] = {0, kGyroRange, 32767};
    c.accel[i] = {0, kAccelRange, 32767};
  }
  return c;
}

PsCalibration parse_playstation_calibration(PlaystationModel model, std::span<const uint8_t> r) {
  const bool ds4 = model == PlaystationModel::kDualShock4;
  const std::size_t need = ds4 ? 37 : 41;
  const uint8_t id = ds4 ? 0x02 : 0x05;
  if (r.size() < need || r[0] != id) {
    throw Error("calibration feature report 0x" + std::string(ds4 ? "02" : "05") + ": expected " +
                std::to_string(need) + " bytes starting with its ID, got " +
                std::to_string(r.size()) + " bytes" +
                (r.empty() ? std::string() : " starting with " + std::to_string(r[0])));
  }
  auto at = [&](std::size_t i) { return static_cast<int>(le16s(r.data() + i)); };
  const int gyro_bias[3] = {at(1), at(3), at(5)};
  // USB layout: pitch+ pitch- yaw+ yaw- roll+ roll- (the Bluetooth one interleaves them
  // differently; imukit reads USB only).
  const int gyro_plus[3] = {at(7), at(11), at(15)};
  const int gyro_minus[3] = {at(9), at(13), at(17)};
  const int speed_2x = at(19) + at(21);
  const int acc_plus[3] = {at(23), at(27), at(31)};
  const int acc_minus[3] = {at(25), at(29), at(33)};
  PsCalibration c;
  for (int i = 0; i < 3; ++i) {
    // The gyro bias belongs in the sensitivity, not subtracted as an offset, for both models
    // (the DualSense too since the kernel's "correct DualSense gyro bias handling", 2023).
    c.gyro[i].bias = 0;
    c.gyro[i].denom =
        std::abs(gyro_plus[i] - gyro_bias[i]) + std::abs(gyro_minus[i] - gyro_bias[i]);
    c.gyro[i].numer = speed_2x * kGyroResPerDps;
    const int range_2g = acc_plus[i] - acc_minus[i];
    c.accel[i].bias = acc_plus[i] - range_2g / 2;
    c.accel[i].numer = 2 * kAccelResPerG;
    c.accel[i].denom = range_2g;
    // Broken or cloned pads report zeros: fall back as the kernel does.
    if (c.gyro[i].denom == 0) c.gyro[i] = {0, kGyroRange, 32767};
    if (c.accel[i].denom == 0) c.accel[i] = {0, kAccelRange, 32767};
  }
  return c;
}

PlaystationCodec::PlaystationCodec(PlaystationModel model)
    : model_(model),
      calibration_(playstation_default_calibration()),
      counter_(model == PlaystationModel::kDualShock4 ? 6 : 8),
      time_(model == PlaystationModel::kDualShock4 ? 16 : 32) {}

std::vector<FeatureRequest> PlaystationCodec::feature_requests() const {
  // Optional: hid-playstation asks three times and then streams with the nominal scale, so
  // clone pads (and pads another hidraw user is talking to) still work; a failure ended the
  // stream here until review, 2026-11-27.
  if (model_ == PlaystationModel::kDualShock4) return {{0x02, 37, true}};
  return {{0x05, 41, true}};
}

void PlaystationCodec::on_feature_report(uint8_t, std::span<const uint8_t> report) {
  set_calibration(parse_playstation_calibration(model_, report));
}

void PlaystationCodec::decode(std::span<const uint8_t> r, TimeNs host_time,
                              std::vector<Sample>& out) {
  stats_.bytes_received += r.size();
  if (r.size() != kInputReportSize || r[0] != 0x01) {
    // Another report (a Bluetooth-mode or vendor report) or a truncated one.
    stats_.bytes_discarded += r.size();
    ++stats_.frames_corrupt;
    return;
  }
  stats_.bytes_accepted += r.size();
  ++stats_.frames_ok;
  const bool ds4 = model_ == PlaystationModel::kDualShock4;
  const std::size_t gyro_at = ds4 ? 13 : 16;
  const std::size_t accel_at = ds4 ? 19 : 22;
  const uint64_t counter = ds4 ? (r[7] >> 2) : r[7];
  const int64_t seq = counter_.unwrap(counter);
  const int64_t step = counter_.last_step();
  if (step > 1) stats_.samples_dropped += static_cast<uint64_t>(step - 1);
  if (step <= 0 && stats_.frames_ok > 1) ++stats_.counter_resets;  // repeated or reordered
  Sample s;
  s.host_time = host_time;
  s.sequence = static_cast<uint64_t>(seq < 0 ? 0 : seq);
  // has_sample_counter stays false: 6 or 8 bits wrap within a live loss after a stall, which
  // the host time cannot show (capture's DeviceClock; found in review, 2026-11-26).
  if (ds4) {
    // 16-bit timestamp in units of 16/3 us: ns = ticks * 16000 / 3.
    const int64_t ticks = time_.unwrap(static_cast<uint16_t>(r[10] | (r[11] << 8)));
    s.device_time = ticks_to_ns(ticks * 16, 3'000'000);
  } else {
    const uint32_t raw = static_cast<uint32_t>(r[28]) | (static_cast<uint32_t>(r[29]) << 8) |
                         (static_cast<uint32_t>(r[30]) << 16) |
                         (static_cast<uint32_t>(r[31]) << 24);
    s.device_time = ticks_to_ns(time_.unwrap(raw), 3'000'000);  // 1/3 us units
  }
  s.has_device_time = true;
  for (int i = 0; i < 3; ++i) {
    const PsAxisCalibration& g = calibration_.gyro[i];
    const PsAxisCalibration& a = calibration_.accel[i];
    const int graw = le16s(r.data() + gyro_at + 2 * i);
    const int araw = le16s(r.data() + accel_at + 2 * i);
    const double gyro_units = static_cast<double>(graw - g.bias) * g.numer / g.denom;
    const double accel_units = static_cast<double>(araw - a.bias) * a.numer / a.denom;
    s.gyro[i] = gyro_units / kGyroResPerDps * kRadPerDeg;
    s.accel[i] = accel_units / kAccelResPerG * kStandardGravity;
  }
  s.channels = kHasAccel | kHasGyro;
  ++stats_.samples_decoded;
  out.push_back(s);
}

}  // namespace imukit::drivers
