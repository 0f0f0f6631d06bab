// Fuzzes the scene JSON reader. Only imukit::Error may escape. File names in a scene resolve
// against a folder that does not exist, and inputs naming absolute paths are skipped (a fuzzer
// must not read /dev/zero); short scenes that parse are run through the simulator and hardware.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "core/error.hpp"
#include "fuzz/json_fuzz.hpp"
#include "sim/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (imukit::fuzz::json_names_absolute_path(text)) return 0;
  imukit::sim::Scene scene;
  try {
    scene = imukit::sim::parse_scene(text, "fuzz.json", "/nonexistent-imukit-fuzz-dir");
  } catch (const imukit::Error&) {
    return 0;
  }
  if (!scene.motion || scene.sensors.empty()) std::abort();
  // Keep runs short: at most 2000 frames and 2000 samples.
  if (!scene.frames || *scene.frames > 2000) return 0;
  const double rate = scene.options.rate_hz > 0 ? scene.options.rate_hz : scene.motion->rate_hz();
  if (static_cast<double>(*scene.frames) / scene.motion->rate_hz() * rate > 2000) return 0;
  try {
    imukit::sim::run_scene(scene, [](std::size_t, const imukit::sim::SensorBlock&,
                                     const imukit::sim::SensorBlock*) {});
  } catch (const imukit::Error&) {
  }
  return 0;
}
