// Codec for Sony DualShock 4 (USB HID 054c:05c4, 054c:09cc) and DualSense (054c:0ce6) input
// reports, with the motion-sensor calibration from their feature reports applied as the Linux
// kernel's hid-playstation driver does (drivers/hid/hid-playstation.c,
// dualshock4_get_calibration_data() USB branch and dualsense_get_calibration_data()):
//
//   gyro (1/1024 deg/s)  = (raw - bias) * speed_2x * 1024 / denom
//   accel (1/8192 g)     = (raw - bias) * 2 * 8192 / range_2g
//
// with speed_2x = speed_plus + speed_minus, range_2g = acc_plus - acc_minus and
// bias = acc_plus - range_2g / 2 (integer division, as in C). The gyro's denom is
// |plus - bias| + |minus - bias| with a zero applied bias, for both models (the kernel applied
// the DualSense's bias as an offset with denom plus - minus until its 2023 fix "correct
// DualSense gyro bias handling": the bias is part of the sensitivity). A zero denominator disables
// that axis' calibration (kernel fallback: range / 32767). The kernel rounds the result to an
// integer (mult_frac); imukit keeps the fraction.
//
// Report layout, report ID at byte 0 (seed-summary section 4):
//   DualShock 4 report 0x01, 64 bytes: counter in byte 7 bits 2..7, timestamp u16 LE at 10
//     (units of 16/3 us), temperature at 12, gyro 3 x i16 at 13, accel 3 x i16 at 19.
//   DualSense report 0x01, 64 bytes: sequence u8 at 7, gyro at 16, accel at 22, timestamp u32 LE
//     at 28 (units of 1/3 us).
// The report counter (6 or 8 bits) is unwrapped with the half-range rule and its gaps are the
// dropped samples; the timestamp is unwrapped to 64 bits for the device time.
#pragma once

#include <optional>

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

enum class PlaystationModel { kDualShock4, kDualSense };

// Per-axis calibration in the kernel's form.
struct PsAxisCalibration {
  int bias = 0;
  int numer = 1;
  int denom = 1;
};
struct PsCalibration {
  std::array<PsAxisCalibration, 3> gyro;   // result in 1/1024 deg/s
  std::array<PsAxisCalibration, 3> accel;  // result in 1/8192 g
};

// The kernel's uncalibrated fallback (range / 32767 per LSB).
PsCalibration playstation_default_calibration();
// Parses the calibration feature report (DualShock 4 USB: 0x02, 37 bytes; DualSense: 0x05, 41
// bytes; report ID at byte 0). Throws imukit::Error if the report is too short or has the wrong
// ID.
PsCalibration parse_playstation_calibration(PlaystationModel model,
                                            std::span<const uint8_t> report);

class PlaystationCodec : public Codec {
 public:
  explicit PlaystationCodec(PlaystationModel model);
  std::string name() const override {
    return model_ == PlaystationModel::kDualShock4 ? "dualshock4" : "dualsense";
  }
  bool report_based() const override { return true; }
  std::vector<FeatureRequest> feature_requests() const override;
  void on_feature_report(uint8_t id, std::span<const uint8_t> report) override;
  void set_calibration(const PsCalibration& c) {
    calibration_ = c;
    calibrated_ = true;
  }
  bool calibrated() const { return calibrated_; }
  const PsCalibration& calibration() const { return calibration_; }

 protected:
  void decode(std::span<const uint8_t> report, TimeNs host_time, std::vector<Sample>& out) override;

 private:
  PlaystationModel model_;
  PsCalibration calibration_;
  bool calibrated_ = false;
  CounterUnwrapper counter_;
  CounterUnwrapper time_;
};

}  // namespace imukit::drivers
