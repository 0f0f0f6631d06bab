// Fuzzes the MCAP reader (records, chunks, zstd, CRCs, maps) and the ROS 2 CDR decoders on the
// messages it finds; only imukit::Error may escape.
#include <cstddef>
#include <cstdint>
#include <span>

#include "imukit/capture/mcap.hpp"
#include "imukit/capture/ros_messages.hpp"
#include "imukit/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    imukit::capture::read_mcap(std::span<const uint8_t>(data, size), "fuzz.mcap",
                               [](const imukit::capture::McapMessageView& m) {
                                 try {
                                   if (m.channel_id % 2 == 0) {
                                     (void)imukit::capture::decode_imu_cdr(m.data, "msg");
                                   } else {
                                     (void)imukit::capture::decode_raw_imu_cdr(m.data, "msg");
                                   }
                                 } catch (const imukit::Error&) {
                                 }
                               });
  } catch (const imukit::Error&) {
  }
  return 0;
}
