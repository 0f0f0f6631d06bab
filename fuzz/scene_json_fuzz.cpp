// Fuzzes a scene's whole read-and-use path: the JSON reader, then (for short scenes) the
// simulation of every sensor through its hardware model, then one window of physically
// plausible augmentation of it. Only imukit::Error may escape, and whatever a scene that was
// accepted produces must be finite (a silent NaN is a bug). File names in a scene resolve against
// a folder that does not exist, and inputs naming absolute paths are skipped (a fuzzer must not
// read /dev/zero).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "imukit/augment/policy.hpp"
#include "imukit/augment/ppda.hpp"
#include "imukit/core/error.hpp"
#include "imukit/sim/scene.hpp"
#include "json_fuzz.hpp"

namespace {

void require_finite(const Eigen::Matrix3Xd& m) {
  if (!m.allFinite()) std::abort();
}

}  // namespace

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
    imukit::sim::run_scene(scene, [](std::size_t, const imukit::sim::SensorBlock& m,
                                     const imukit::sim::SensorBlock* t) {
      for (const auto* b : {&m, t}) {
        if (b == nullptr) continue;
        require_finite(b->specific_force);
        require_finite(b->angular_rate);
        require_finite(b->magnetic_field);
      }
    });
  } catch (const imukit::Error&) {
    return 0;
  }
  // One window of 16 samples under a sub-policy of the built-in grid chosen by the input.
  static const imukit::augment::Policy grid = imukit::augment::builtin_policy("imukit");
  try {
    imukit::augment::PpdaOptions o;
    o.window = 16;
    imukit::augment::PpdaAugmenter augmenter(scene, o);
    const std::vector<int64_t> starts = augmenter.window_starts(16);
    if (starts.empty()) return 0;
    const std::vector<int64_t> one{starts[size % starts.size()]};
    std::vector<float> out(o.window * augmenter.channels());
    imukit::Rng rng(size);
    augmenter.apply(grid.sub_policies[size % grid.sub_policies.size()], one, rng, out);
    for (float v : out) {
      if (!std::isfinite(v)) std::abort();
    }
  } catch (const imukit::Error&) {
  }
  return 0;
}
