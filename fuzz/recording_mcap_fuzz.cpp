// Fuzzes the recording-to-ImuSeries path of every command that takes an MCAP recording
// (convert, characterize, calibrate, identify): read_recording_mcap (schemas, channels, IMU and
// magnetometer CDR, events JSON, metadata), then each stream validated and written as EuRoC CSV
// and read back. Only imukit::Error may escape.
#include <cstddef>
#include <cstdint>
#include <span>

#include "imukit/capture/recording_mcap.hpp"
#include "imukit/core/error.hpp"
#include "recording_use.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const imukit::capture::RecordingRead r =
        imukit::capture::read_recording_mcap(std::span<const uint8_t>(data, size), "fuzz.mcap");
    imukit::fuzz::use_recording(r.recording);
  } catch (const imukit::Error&) {
  }
  return 0;
}
