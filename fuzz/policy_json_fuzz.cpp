// Fuzzes a policy's whole read-and-use path (imukit.policy/1): the reader, the round trip through
// format_policy, then each of its first sub-policies applied to a window of a small simulated
// scene (PPDA) and the policy's STDA counterparts to a window of a recording. Only imukit::Error
// may escape; a policy that was accepted must give finite windows (a sigma of 1e300 used to pass
// the reader and abort in so3_log). Profile and scene files named inside resolve against a folder
// that does not exist, and inputs naming absolute paths are skipped (a fuzzer must not read
// /dev/zero).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string_view>
#include <vector>

#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/augment/ppda.hpp"
#include "imukit/core/error.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "json_fuzz.hpp"

namespace {

// A default humanoid in one second of smooth procedural motion at 50 Hz, a watch on the wrist.
imukit::sim::Scene small_scene() {
  imukit::sim::Scene scene;
  scene.body = imukit::sim::Body::default_humanoid();
  imukit::sim::ProceduralMotionOptions po;
  po.rate_hz = 50;
  po.frames = 50;
  imukit::sim::ProceduralMotion motion(scene.body.size(), po);
  scene.motion = std::make_shared<imukit::sim::Motion>(motion.materialize(50));
  scene.frames = 50;
  imukit::sim::SceneSensor s;
  s.spec.name = "watch";
  s.preset = "left_wrist_watch";
  s.spec.placement = imukit::sim::preset_placement(s.preset, scene.body);
  scene.sensors.push_back(s);
  return scene;
}

// The same watch's noiseless signal as a recording, for the STDA counterparts.
const imukit::ImuSeries& small_recording() {
  static const imukit::ImuSeries series = [] {
    imukit::ImuSeries s;
    imukit::sim::Scene scene = small_scene();
    imukit::sim::run_scene(scene, [&](std::size_t, const imukit::sim::SensorBlock& m,
                                      const imukit::sim::SensorBlock*) {
      const auto n0 = static_cast<Eigen::Index>(s.size());
      const auto n = static_cast<Eigen::Index>(m.t.size());
      s.t.insert(s.t.end(), m.t.begin(), m.t.end());
      s.accel.conservativeResize(3, n0 + n);
      s.gyro.conservativeResize(3, n0 + n);
      s.accel.rightCols(n) = m.specific_force;
      s.gyro.rightCols(n) = m.angular_rate;
    });
    return s;
  }();
  return series;
}

void require_finite(const std::vector<float>& values) {
  for (float v : values) {
    if (!std::isfinite(v)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (imukit::fuzz::json_names_absolute_path(text)) return 0;
  imukit::augment::Policy policy;
  try {
    policy = imukit::augment::parse_policy(text, "fuzz.json", "/nonexistent-imukit-fuzz");
  } catch (const imukit::Error&) {
    return 0;
  }
  policy.validate();  // whatever parses is valid
  const imukit::augment::Policy back =
      imukit::augment::parse_policy(imukit::augment::format_policy(policy), "back.json", "");
  if (back.sub_policies.size() != policy.sub_policies.size()) std::abort();
  for (std::size_t k = 0; k < policy.sub_policies.size(); ++k) {
    if (back.sub_policies[k].describe() != policy.sub_policies[k].describe()) std::abort();
  }
  imukit::Rng rng(1);
  if (imukit::augment::sample_sub_policy(policy, rng) >= policy.sub_policies.size()) std::abort();

  // Use it: PPDA on the scene (the augmenter's plan is compiled once), STDA on the recording.
  static const imukit::sim::Scene scene = small_scene();
  static imukit::augment::PpdaAugmenter augmenter(scene, imukit::augment::PpdaOptions{16});
  const std::vector<int64_t> starts{10};
  std::vector<float> out(16 * augmenter.channels());
  for (std::size_t k = 0; k < policy.sub_policies.size() && k < 3; ++k) {
    try {
      augmenter.apply(policy.sub_policies[k], starts, rng, out);
    } catch (const imukit::Error&) {
      continue;  // e.g. a preset to swap to that this body cannot carry
    }
    require_finite(out);
  }
  imukit::augment::DatasetOptions o;
  o.window = 16;
  o.stride = 16;
  o.count = 3;
  o.batch_size = 1;
  try {
    const imukit::augment::Dataset d =
        imukit::augment::generate_dataset({"watch"}, {&small_recording()}, policy, {}, o);
    require_finite(d.X);
  } catch (const imukit::Error&) {
  }
  return 0;
}
