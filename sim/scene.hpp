// Scene: everything one simulation needs (body, motion source, sensors with placement, outputs
// and hardware, method, rate, gravity, seed), read from JSON ("schema": "imukit.scene/1",
// docs/formats.md), and the runners that stream a scene through the simulator and the hardware
// model, or simulate many variants over a thread pool.
//
// Randomness: sensor s's hardware errors draw from Rng(seed).child(s), so adding a sensor does
// not change the others' noise, and its clock jitter from Rng(seed).child(s).child(1); batch job
// i draws from Rng(seed).child(i) whatever the number of threads.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/hardware_model.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/simulator.hpp"

namespace imukit::sim {

inline constexpr std::string_view kSceneSchema = "imukit.scene/1";
// A body written on its own (`imukit motion --body-json`): a scene's "body" object that also
// names its schema, so the file can be pasted into a scene as it is.
inline constexpr std::string_view kBodySchema = "imukit.body/1";

struct SceneSensor {
  SensorSpec spec;
  std::optional<HardwareModel> hardware;  // none: ideal sensor
  std::string preset;                     // the preset used, if any
};

// An ideal sensor at the preset called `preset` on `body`, named `name` (the preset's name when
// empty).
SceneSensor preset_sensor(std::string_view preset, const Body& body, std::string name = {});

struct Scene {
  Body body;
  std::shared_ptr<MotionSource> motion;
  std::optional<int64_t> frames;  // frames to simulate (required for an endless source)
  SimulationOptions options;
  std::vector<SceneSensor> sensors;
  bool ground_truth = false;  // also output the noiseless signals
  uint64_t seed = 0;
  std::vector<std::string> warnings;
};

// Parses scene JSON. Relative file names inside are resolved against base_dir. Throws
// imukit::Error: JSON syntax errors name source_name:line:column, semantic errors the JSON path
// ("sensors[1].preset: unknown placement preset ..."). Each sensor's hardware profile is checked
// at the rate it will run at, in the profile's terms (its file, line, column and key, or the
// scene's for an inline profile); rate_hz, when given (a command's --rate, within RateLimits),
// replaces simulation.rate_hz before that check, so a rate given later is not checked in the
// hardware model's words alone.
Scene parse_scene(std::string_view text, const std::string& source_name,
                  const std::string& base_dir, std::optional<double> rate_hz = std::nullopt);
Scene read_scene(const std::string& path, std::optional<double> rate_hz = std::nullopt);

// The scene's sensor sample rate: its simulation rate_hz, or the motion's frame rate.
double scene_rate_hz(const Scene& scene);
// The samples per sensor a run of the scene gives (over frames_to_simulate's frames).
int64_t scene_sample_count(const Scene& scene);

// The body as a scene's "body" object, {"joints": [{"name", "parent", "offset_m",
// "end_offset_m"}]} (docs/formats.md), as JSON text that parse_scene reads back to the same body;
// with_schema adds "schema": kBodySchema (a file of its own).
std::string body_json(const Body& body, bool with_schema = false);

// Streams the scene: for each chunk and sensor, sink(sensor, measured, truth) where truth is
// the noiseless block (null unless ground_truth) and measured the block after the sensor's
// hardware model (the truth itself for an ideal sensor). Memory stays constant. A sensor whose
// hardware has a clock error or jitter (HardwareModel::clock) is sampled at its own true instants
// k / (rate (1 + ppm 1e-6)) + jitter: `measured.t` holds what its device stamps (k / rate),
// `truth->t` the true instants (docs/simulation.md, "Device clock and sample jitter").
using SceneSink =
    std::function<void(std::size_t sensor, const SensorBlock& measured, const SensorBlock* truth)>;
void run_scene(Scene& scene, const SceneSink& sink);

// One variant of a batch: a motion (shared read-only between jobs; Motion::read does not
// modify it), sensors with their hardware, options.
struct BatchJob {
  std::shared_ptr<Motion> motion;
  std::vector<SceneSensor> sensors;
  SimulationOptions options;
};

// Simulates every job on `threads` worker threads (0 = hardware concurrency) over `body`. Job i's
// hardware noise comes from Rng(seed).child(i), so the result is the same for any thread count.
// result[i][s] is job i's sensor s (accelerometer, gyroscope and magnetometer as requested;
// job clocks are ideal: batch jobs sample at the nominal rate). When jobs fail, no further job
// starts and the error of the lowest failing job is thrown (core/parallel.hpp).
std::vector<std::vector<ImuSeries>> simulate_batch(const Body& body,
                                                   const std::vector<BatchJob>& jobs, uint64_t seed,
                                                   unsigned threads = 0);

}  // namespace imukit::sim
