// Fuzzes the recovery of a damaged recording and everything that reads its result, as `imukit
// convert --recover` then `imukit convert` do: recover_recording (MCAP recovery, the clock refit
// over what was kept), a strict read of the recovered file, which must be complete MCAP (else
// abort: recovery wrote something imukit cannot read), then read_recording_mcap and each stream
// validated and written as EuRoC CSV. Only imukit::Error may escape the readers.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "imukit/capture/mcap.hpp"
#include "imukit/capture/recording_mcap.hpp"
#include "imukit/capture/session.hpp"
#include "imukit/core/error.hpp"
#include "recording_use.hpp"
#include "temp_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& folder = imukit::fuzz::temp_folder();
  const std::string in = folder.write("damaged.mcap", data, size);
  const std::string out = folder.file("recovered.mcap");
  imukit::capture::RecoveredRecording r;
  try {
    r = imukit::capture::recover_recording(in, out);
  } catch (const imukit::Error&) {
    return 0;  // not MCAP at all
  }
  uint64_t messages = 0;
  imukit::capture::McapReadSummary back;
  try {
    back = imukit::capture::read_mcap(out,
                                      [&](const imukit::capture::McapMessageView&) { ++messages; });
  } catch (const imukit::Error&) {
    std::abort();
  }
  if (!back.complete || messages != r.read.messages - r.undecodable_messages) std::abort();
  try {
    imukit::fuzz::use_recording(imukit::capture::read_recording_mcap(out).recording);
  } catch (const imukit::Error&) {
  }
  return 0;
}
