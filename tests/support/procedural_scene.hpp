// The default humanoid in procedural motion (sim::ProceduralMotion, materialised in memory), with
// sensors at placement presets: the scene that many simulator and augmentation tests and the
// benchmarks start from, built one way. Header-only: the benchmarks use it without linking the
// test support library (GoogleTest).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "imukit/sim/motion.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::testing {

// The motion's options.frames frames in memory.
inline sim::Motion procedural_motion(std::size_t joints,
                                     const sim::ProceduralMotionOptions& options) {
  return sim::ProceduralMotion(joints, options).materialize(options.frames.value());
}

// The default humanoid moving as `options` says, with one sensor (accelerometer and gyroscope)
// at each preset, named after it.
inline sim::Scene preset_scene(const std::vector<std::string>& presets,
                               const sim::ProceduralMotionOptions& options) {
  sim::Scene scene;
  scene.body = sim::Body::default_humanoid();
  scene.motion = std::make_shared<sim::Motion>(procedural_motion(scene.body.size(), options));
  scene.frames = options.frames;
  for (const std::string& preset : presets)
    scene.sensors.push_back(sim::preset_sensor(preset, scene.body));
  return scene;
}

}  // namespace imukit::testing
