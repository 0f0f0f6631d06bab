// Fuzzes the device-profile reader. Only imukit::Error may escape; whatever parses must also
// write and read back to the same profile (the writer's promise), merge into itself, and, when
// it maps to a hardware model, drive the generator for a few samples without UB.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include <Eigen/Core>

#include "imukit/core/error.hpp"
#include "imukit/core/hardware_model.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/rng.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  imukit::DeviceProfile profile;
  try {
    profile = imukit::parse_profile(text, "fuzz.json");
  } catch (const imukit::Error&) {
    return 0;
  }
  // Round trip: a profile that was read must be written and read back unchanged.
  const std::string written = imukit::format_profile(profile);
  if (!(imukit::parse_profile(written, "written.json") == profile)) std::abort();
  const std::string merged = imukit::merge_profile_text(text, "fuzz.json", profile);
  if (!(imukit::parse_profile(merged, "merged.json") == profile)) std::abort();

  try {
    const imukit::HardwareModel model = imukit::to_hardware_model(profile);
    imukit::Rng rng(1);
    imukit::ImuErrorGenerator generator(model, 1000.0, rng);
    Eigen::Matrix3Xd accel = Eigen::Matrix3Xd::Constant(3, 8, 9.81);
    Eigen::Matrix3Xd gyro = Eigen::Matrix3Xd::Constant(3, 8, 0.1);
    Eigen::Matrix3Xd mag = Eigen::Matrix3Xd::Constant(3, 8, 5e-5);
    generator.apply_gyroscope(gyro, accel);
    generator.apply_accelerometer(accel);
    generator.apply_magnetometer(mag);
  } catch (const imukit::Error&) {
    // Raw-count calibrations, bandwidths above 500 Hz, bands under 5 samples: refused cleanly.
  }
  return 0;
}
