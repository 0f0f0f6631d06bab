// Fuzzes the keypoint readers and the pipeline behind them. Only imukit::Error may escape. The
// first byte picks the input: a keypoint topology JSON, or keypoint CSV text for the h36m_17
// topology, which (when it parses, with at most 400 frames) goes through motion_from_keypoints
// with the options the byte also picks (up given or estimated, repairs on or off).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "imukit/core/error.hpp"
#include "imukit/sim/keypoints.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t mode = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  static const imukit::sim::KeypointTopology h36m = imukit::sim::keypoint_topology("h36m_17");
  try {
    if ((mode & 1) == 0) {
      const imukit::sim::KeypointTopology t =
          imukit::sim::parse_keypoint_topology(text, "fuzz.json");
      // A topology that parses is written and read back to the same text.
      const std::string json = imukit::sim::keypoint_topology_json(t);
      if (imukit::sim::keypoint_topology_json(
              imukit::sim::parse_keypoint_topology(json, "again")) != json)
        __builtin_trap();
      return 0;
    }
    const imukit::sim::Keypoints k = imukit::sim::parse_keypoints_csv(
        text, "fuzz.csv", h36m, (mode & 2) ? std::optional<double>(30.0) : std::nullopt);
    if (k.frames() > 400) return 0;
    imukit::sim::KeypointMotionOptions o;
    o.rate_hz = 50.0;
    if (mode & 4) o.up = Eigen::Vector3d(0, 1, 0);
    if (mode & 8) {
      o.fix_swaps = false;
      o.max_bone_deviation = 0.0;
      o.jump_speed_mps = 0.0;
    }
    const imukit::sim::KeypointMotion r = imukit::sim::motion_from_keypoints(k, h36m, o);
    for (int64_t f = 0; f < r.motion.frames(); ++f) {
      for (std::size_t j = 0; j < r.body.size(); ++j) {
        if (!r.motion.rotation(f, j).coeffs().allFinite()) __builtin_trap();
      }
    }
  } catch (const imukit::Error&) {
  }
  return 0;
}
