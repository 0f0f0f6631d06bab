// imukit simulate: body motion + sensor placement + hardware -> accelerometer and gyroscope
// signals (sim module). Either a scene JSON (docs/formats.md, "imukit.scene/1") or the quick
// form --bvh FILE --preset NAME. Writes one EuRoC CSV per sensor into the output folder, streamed
// chunk by chunk (constant memory for hours-long scenes).
#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

#include "command.hpp"
#include "imukit/capture/mcap.hpp"
#include "imukit/capture/ros_messages.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"
#include "inputs.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct SimulateArgs {
  std::string scene;
  std::string output;
  std::string method;
  double rate_hz = 0.0;
  std::optional<uint64_t> seed;
  std::string bvh;
  BvhArgs bvh_args;
  std::vector<std::string> presets;
  std::string hardware;
  bool ground_truth = false;
  bool list_presets = false;
  std::optional<double> gravity;
};

// A CSV file written block by block into the temporary write_file_atomically gives it.
class StreamFile {
 public:
  StreamFile(std::string path, std::FILE* f) : path_(std::move(path)), f_(f) {}
  void put(const std::string& s) {
    if (std::fwrite(s.data(), 1, s.size(), f_) != s.size())
      throw IoError(fmt::format("{}: write failed: {}", path_, std::strerror(errno)));
  }

 private:
  std::string path_;
  std::FILE* f_;
};

// Opens paths[k..] each through write_file_atomically, one inside the other, and runs `body`
// with all of them open: each replaces its name only when `body` has returned, so a run stopped
// by an error (bad input found while simulating, a full disk) leaves every earlier file as it
// was and no temporary (found in review, 2026-11-27: the CSVs were written in place).
void with_files_atomically(const std::vector<std::string>& paths, std::size_t k,
                           std::vector<std::FILE*>& files, const std::function<void()>& body) {
  if (k == paths.size()) {
    body();
    return;
  }
  write_file_atomically(paths[k], [&](std::FILE* f) {
    files[k] = f;
    with_files_atomically(paths, k + 1, files, body);
  });
}

void write_rows(StreamFile& file, const sim::SensorBlock& b) {
  std::string buf;
  for (std::size_t i = 0; i < b.t.size(); ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    buf += fmt::format("{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", b.t[i],
                       b.angular_rate(0, c), b.angular_rate(1, c), b.angular_rate(2, c),
                       b.specific_force(0, c), b.specific_force(1, c), b.specific_force(2, c));
  }
  file.put(buf);
}

void write_orientation_rows(StreamFile& file, const sim::SensorBlock& b) {
  std::string buf;
  for (std::size_t i = 0; i < b.t.size(); ++i) {
    const Eigen::Quaterniond& q = b.q_world_sensor[i];
    buf += fmt::format("{},{:.17g},{:.17g},{:.17g},{:.17g}\n", b.t[i], q.w(), q.x(), q.y(), q.z());
  }
  file.put(buf);
}

void write_mag_rows(StreamFile& file, const sim::SensorBlock& b) {
  std::string buf;
  for (std::size_t i = 0; i < b.t.size(); ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    buf += fmt::format("{},{:.17g},{:.17g},{:.17g}\n", b.t[i], b.magnetic_field(0, c),
                       b.magnetic_field(1, c), b.magnetic_field(2, c));
  }
  file.put(buf);
}

constexpr const char* kMagHeader = "#timestamp [ns],m_S_x [T],m_S_y [T],m_S_z [T]";

int list_presets() {
  for (const sim::PlacementPreset& p : sim::placement_presets()) {
    fmt::print("{:<26} on {:<16} {}\n", p.name, sim::segment_name(p.joint), p.description);
  }
  return 0;
}

sim::Scene quick_scene(const SimulateArgs& a) {
  // The presets are the command line's: check them before reading any file, and an unknown
  // name is a usage error like an unknown --method (found in review: it exited as bad input).
  if (a.presets.empty())
    throw UsageError("simulate --bvh: name at least one --preset (see --list-presets)");
  for (std::size_t i = 0; i < a.presets.size(); ++i) {
    const std::string& name = a.presets[i];
    // Each sensor writes a file (or an MCAP topic) of its name (found in review: two sensors
    // of one preset went into one file).
    if (std::find(a.presets.begin(), a.presets.begin() + static_cast<std::ptrdiff_t>(i), name) !=
        a.presets.begin() + static_cast<std::ptrdiff_t>(i))
      throw UsageError("simulate: --preset " + name + " is given twice");
    try {
      sim::placement_preset(name);
    } catch (const Error& e) {
      throw UsageError(std::string("simulate --preset: ") + e.what());
    }
  }
  sim::Scene scene;
  sim::BvhData d = load_bvh(a.bvh, a.bvh_args);
  scene.body = std::move(d.body);
  scene.motion = std::make_shared<sim::Motion>(std::move(d.motion));
  scene.frames = scene.motion->frame_count();
  scene.warnings = std::move(d.warnings);
  for (const std::string& name : a.presets) {
    sim::SceneSensor s = sim::preset_sensor(name, scene.body);
    if (!a.hardware.empty()) {
      try {
        s.hardware = to_hardware_model(read_profile(a.hardware));
      } catch (const IoError&) {
        throw;
      } catch (const Error& e) {
        // The profile reads, but is not a model of SI signals (a calibration of raw counts):
        // say which file (found in review: the message named none).
        const std::string what = e.what();
        throw Error(what.rfind(a.hardware, 0) == 0 ? what : a.hardware + ": " + what);
      }
    }
    scene.sensors.push_back(std::move(s));
  }
  return scene;
}

// The simulation as a recording into `file` (named `path` in messages): /imu/<sensor> (and
// /imu/<sensor>/truth for the noiseless signals) as sensor_msgs/msg/Imu, times in ns since the
// start of the motion, streamed in constant memory; the description goes into an
// "imukit.simulation" metadata record.
std::vector<int64_t> simulate_into_mcap(sim::Scene& scene, std::FILE* file, const std::string& path,
                                        const std::string& description) {
  capture::McapWriter writer(file, path);
  writer.write_metadata("imukit.simulation", {{"description", description}});
  const uint16_t schema =
      writer.add_schema(capture::kImuSchemaName, "ros2msg", capture::kImuSchemaText);
  uint16_t mag_schema = 0;
  std::vector<uint16_t> channels, truth_channels, mag_channels, mag_truth_channels;
  std::vector<capture::ImuMessage> messages(scene.sensors.size());
  std::vector<capture::MagneticFieldMessage> mag_messages(scene.sensors.size());
  for (std::size_t k = 0; k < scene.sensors.size(); ++k) {
    const std::string& name = scene.sensors[k].spec.name;
    channels.push_back(writer.add_channel(schema, "/imu/" + name, "cdr"));
    truth_channels.push_back(scene.ground_truth
                                 ? writer.add_channel(schema, "/imu/" + name + "/truth", "cdr")
                                 : uint16_t{0});
    messages[k].frame_id = name;
    mag_messages[k].frame_id = name;
    // The magnetometer beside each Imu topic: /imu/<name>/mag (and /imu/<name>/truth/mag).
    uint16_t mag = 0, mag_truth = 0;
    if (scene.sensors[k].spec.outputs.magnetometer) {
      if (mag_schema == 0)
        mag_schema = writer.add_schema(capture::kMagneticFieldSchemaName, "ros2msg",
                                       capture::kMagneticFieldSchemaText);
      mag = writer.add_channel(mag_schema, "/imu/" + name + "/mag", "cdr");
      if (scene.ground_truth)
        mag_truth = writer.add_channel(mag_schema, "/imu/" + name + "/truth/mag", "cdr");
    }
    mag_channels.push_back(mag);
    mag_truth_channels.push_back(mag_truth);
  }
  std::vector<int64_t> samples(scene.sensors.size(), 0);
  const auto put = [&](uint16_t channel, capture::ImuMessage& m, const sim::SensorBlock& b,
                       std::size_t i) {
    const auto c = static_cast<Eigen::Index>(i);
    m.stamp = b.t[i];
    m.angular_velocity = {b.angular_rate(0, c), b.angular_rate(1, c), b.angular_rate(2, c)};
    m.linear_acceleration = {b.specific_force(0, c), b.specific_force(1, c),
                             b.specific_force(2, c)};
    if (i < b.q_world_sensor.size()) {
      const Eigen::Quaterniond& q = b.q_world_sensor[i];
      m.orientation_xyzw = {q.x(), q.y(), q.z(), q.w()};
      m.orientation_covariance[0] = 0.0;  // provided (exact), covariance not stated
    }
    const auto t = static_cast<uint64_t>(b.t[i]);
    writer.write_message(channel, t, t, capture::encode_cdr(m));
  };
  const auto put_mag = [&](uint16_t channel, capture::MagneticFieldMessage& m,
                           const sim::SensorBlock& b, std::size_t i) {
    const auto c = static_cast<Eigen::Index>(i);
    m.stamp = b.t[i];
    m.magnetic_field = {b.magnetic_field(0, c), b.magnetic_field(1, c), b.magnetic_field(2, c)};
    const auto t = static_cast<uint64_t>(b.t[i]);
    writer.write_message(channel, t, t, capture::encode_cdr(m));
  };
  sim::run_scene(scene, [&](std::size_t s, const sim::SensorBlock& m, const sim::SensorBlock* t) {
    for (std::size_t i = 0; i < m.t.size(); ++i) {
      put(channels[s], messages[s], m, i);
      if (t != nullptr && scene.ground_truth) put(truth_channels[s], messages[s], *t, i);
      if (mag_channels[s] != 0) {
        put_mag(mag_channels[s], mag_messages[s], m, i);
        if (t != nullptr && mag_truth_channels[s] != 0)
          put_mag(mag_truth_channels[s], mag_messages[s], *t, i);
      }
    }
    samples[s] += static_cast<int64_t>(m.t.size());
  });
  writer.close();
  return samples;
}

// The summary's sample counts, per sensor ("100 samples each", or "samples 1001, 992" where a
// sensor's clock error gives it its own): it printed the sum over the sensors, 200 for two
// sensors of 100 each (review, 2026-11-27).
std::string sample_counts(const std::vector<int64_t>& samples) {
  if (!samples.empty() &&
      std::all_of(samples.begin(), samples.end(), [&](int64_t n) { return n == samples[0]; }))
    return fmt::format("{} samples each", samples[0]);
  std::string list;
  for (const int64_t n : samples) list += (list.empty() ? "" : ", ") + std::to_string(n);
  return "samples " + list;
}

// simulate_into_mcap through a temporary renamed over `path` when complete, like every finished
// MCAP file (a run stopped by an error or a full disk leaves an earlier file there as it was).
std::vector<int64_t> simulate_to_mcap(sim::Scene& scene, const std::string& path,
                                      const std::string& description) {
  std::vector<int64_t> samples;
  write_file_atomically(
      path, [&](std::FILE* file) { samples = simulate_into_mcap(scene, file, path, description); });
  return samples;
}

int run_simulate(const SimulateArgs& a) {
  if (a.list_presets) return list_presets();
  if (a.output.empty()) throw UsageError("simulate: give the output folder with -o DIR");
  const std::filesystem::path out(a.output);
  if (a.scene.empty() == a.bvh.empty())
    throw UsageError("simulate: give either SCENE.json or --bvh FILE");
  if (!a.scene.empty()) {
    // Options of the --bvh form would be ignored beside a scene (found in review).
    std::string quick;
    const auto name = [&](bool given, const char* option) {
      if (given) quick += (quick.empty() ? "" : ", ") + std::string(option);
    };
    name(!a.presets.empty(), "--preset");
    name(!a.hardware.empty(), "--hardware");
    name(a.bvh_args.scale != BvhArgs{}.scale, "--bvh-scale");
    name(a.bvh_args.up != BvhArgs{}.up, "--up");
    if (!quick.empty()) {
      throw UsageError("simulate: " + quick +
                       " belong(s) to the --bvh form; a scene names its sensors, hardware and "
                       "motion itself");
    }
  }
  if (out.extension() != ".mcap" && std::filesystem::exists(out) &&
      !std::filesystem::is_directory(out)) {
    throw UsageError(fmt::format(
        "simulate: -o {} is an existing file; give a folder (one CSV per sensor) or FILE.mcap",
        a.output));
  }
  // A --rate is the rate a scene's hardware profiles are checked at, in their own terms.
  const std::optional<double> rate_hz =
      a.rate_hz != 0.0 ? std::optional<double>(a.rate_hz) : std::nullopt;
  sim::Scene scene = a.scene.empty() ? quick_scene(a) : sim::read_scene(a.scene, rate_hz);
  if (!a.method.empty()) {
    try {
      scene.options.method = sim::parse_derivative_method(a.method);
    } catch (const Error& e) {
      throw UsageError(std::string("simulate --method: ") + e.what());
    }
  }
  if (rate_hz) scene.options.rate_hz = *rate_hz;
  if (a.seed) scene.seed = *a.seed;
  if (a.gravity) scene.options.gravity_world = Eigen::Vector3d(0, 0, -*a.gravity);
  if (a.ground_truth) scene.ground_truth = true;
  const double rate = sim::scene_rate_hz(scene);
  for (sim::SceneSensor& s : scene.sensors) {
    if (!s.spec.outputs.accelerometer || !s.spec.outputs.gyroscope) {
      throw Error("simulate: sensor " + s.spec.name +
                  ": the EuRoC CSV and the MCAP sensor_msgs/Imu outputs carry accelerometer and "
                  "gyroscope together, so list both in its outputs (the Python API simulates any "
                  "of them)");
    }
    if (!s.hardware) continue;
    try {
      // A --hardware profile is checked at this rate in its own terms first: the file, line and
      // key (found in review: "accelerometer.bandwidth_hz is 80 Hz" named neither).
      if (!a.hardware.empty()) (void)read_profile_for_rate(a.hardware, rate);
      validate_hardware_model(*s.hardware, rate);
    } catch (const Error& e) {
      // A bandwidth error is usually a sensor simulated at a motion capture's frame rate
      // (60-120 Hz) with the bandwidth of a sensor sampling much faster: simulate at the
      // sensor's own rate. Other errors (the clock's) get no such hint (found in review).
      const auto too_wide = [&](const TriadModel& t) {
        return t.bandwidth_hz > 0.0 && !(t.bandwidth_hz < 0.5 * rate);
      };
      const bool bandwidth = too_wide(s.hardware->accelerometer) ||
                             too_wide(s.hardware->gyroscope) || too_wide(s.hardware->magnetometer);
      const double own = std::max(s.hardware->accelerometer.rate_hz, s.hardware->gyroscope.rate_hz);
      const std::string hint =
          !bandwidth
              ? std::string()
              : fmt::format(
                    "; simulate at a rate above twice the bandwidth with --rate{}",
                    own > 0 ? fmt::format(" (the profile's own rate: --rate {:g})", own) : "");
      // An error located in the profile file leads with its place, as editors expect.
      if (e.where()) throw Error(*e.where(), e.reason() + hint);
      throw Error(fmt::format("sensor {}: {}{}", s.spec.name, e.what(), hint));
    }
  }
  for (const std::string& w : scene.warnings) fmt::print(stderr, "warning: {}\n", w);
  // What was simulated, so the outputs can be traced (gravity included, as DESIGN.md asks).
  const Eigen::Vector3d& g = scene.options.gravity_world;
  std::string sensors;
  for (const sim::SceneSensor& s : scene.sensors) {
    const ClockModel clock = s.hardware ? s.hardware->clock : ClockModel{};
    sensors += fmt::format(
        "{}{{\"name\": \"{}\", \"preset\": \"{}\", \"hardware\": {}, \"clock_error_ppm\": "
        "{:.17g}, \"jitter_s\": {:.17g}}}",
        sensors.empty() ? "" : ", ", s.spec.name, s.preset, s.hardware ? "true" : "false",
        clock.error_ppm, clock.jitter_s);
  }
  const Eigen::Vector3d& B = scene.options.magnetic_field_world;
  const std::string description = fmt::format(
      "{{\"schema\": \"imukit.simulation/1\", \"method\": \"{}\", \"rate_hz\": {:.17g}, "
      "\"gravity_world\": [{:.17g}, {:.17g}, {:.17g}], \"magnetic_field_world\": [{:.17g}, "
      "{:.17g}, "
      "{:.17g}], \"seed\": {}, \"sensors\": [{}]}}",
      sim::to_string(scene.options.method), rate, g.x(), g.y(), g.z(), B.x(), B.y(), B.z(),
      scene.seed, sensors);
  if (out.extension() == ".mcap") {
    const std::vector<int64_t> samples = simulate_to_mcap(scene, out.string(), description);
    fmt::print("simulate: {} sensor(s), {} at {:g} Hz ({} method) -> {}\n", scene.sensors.size(),
               sample_counts(samples), rate, sim::to_string(scene.options.method), out.string());
    return 0;
  }
  std::filesystem::create_directories(out);
  // Per sensor, the files it writes: its CSV, then (when asked for) the truth, the orientation,
  // the magnetometer and its truth, each a slot in `paths` or -1.
  enum Kind { kMeasured, kTruth, kOrientation, kMag, kMagTruth, kKinds };
  std::vector<std::string> paths, headers;
  std::vector<std::array<int, kKinds>> slot(scene.sensors.size());
  for (std::size_t s = 0; s < scene.sensors.size(); ++s) {
    const sim::SceneSensor& ss = scene.sensors[s];
    const bool m = ss.spec.outputs.magnetometer;  // in its own file (EuRoC has no magnetometer)
    struct Output {
      bool wanted;
      const char* suffix;
      std::string_view header;
    };
    const std::array<Output, kKinds> outputs{{
        {true, ".csv", kEurocHeader},
        {scene.ground_truth, ".truth.csv", kEurocHeader},
        {ss.spec.outputs.orientation, ".orientation.csv",
         "#timestamp [ns],q_WS_w,q_WS_x,q_WS_y,q_WS_z"},
        {m, ".mag.csv", kMagHeader},
        {m && scene.ground_truth, ".mag.truth.csv", kMagHeader},
    }};
    for (std::size_t k = 0; k < kKinds; ++k) {
      slot[s][k] = -1;
      if (!outputs[k].wanted) continue;
      slot[s][k] = static_cast<int>(paths.size());
      paths.push_back((out / (ss.spec.name + outputs[k].suffix)).string());
      headers.emplace_back(outputs[k].header);
    }
  }
  std::vector<int64_t> samples(scene.sensors.size(), 0);
  std::vector<std::FILE*> handles(paths.size(), nullptr);
  with_files_atomically(paths, 0, handles, [&] {
    std::vector<StreamFile> files;
    for (std::size_t i = 0; i < paths.size(); ++i) {
      files.emplace_back(paths[i], handles[i]);
      files.back().put(headers[i] + "\n");
    }
    const auto file = [&](std::size_t s, Kind k) -> StreamFile* {
      const int i = slot[s][static_cast<std::size_t>(k)];
      return i < 0 ? nullptr : &files[static_cast<std::size_t>(i)];
    };
    sim::run_scene(scene, [&](std::size_t s, const sim::SensorBlock& m, const sim::SensorBlock* t) {
      write_rows(*file(s, kMeasured), m);
      if (StreamFile* f = file(s, kTruth); f != nullptr && t != nullptr) write_rows(*f, *t);
      if (StreamFile* f = file(s, kOrientation)) write_orientation_rows(*f, m);
      if (StreamFile* f = file(s, kMag)) write_mag_rows(*f, m);
      if (StreamFile* f = file(s, kMagTruth); f != nullptr && t != nullptr) write_mag_rows(*f, *t);
      samples[s] += static_cast<int64_t>(m.t.size());
    });
  });
  write_text_file((out / "simulation.json").string(), description);
  fmt::print("simulate: {} sensor(s), {} at {:g} Hz ({} method) -> {}\n", scene.sensors.size(),
             sample_counts(samples), rate, sim::to_string(scene.options.method), out.string());
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    simulate,
    CommandSpec{
        "simulate", "Simulate wearable IMU signals from body motion (BVH, scene JSON)", 60,
        [](CLI::App& sub) -> std::function<int()> {
          auto a = std::make_shared<SimulateArgs>();
          sub.add_option("scene", a->scene, "Scene JSON (imukit.scene/1, docs/formats.md)");
          sub.add_option(
              "-o,--output", a->output,
              "Output folder: one EuRoC CSV per sensor (+ .truth.csv with --ground-truth). "
              "-o FILE.mcap writes one sensor_msgs/Imu topic per sensor instead");
          sub.add_option("--method", a->method,
                         "Derivative method: fd (default), spline, or reference (comparison only)");
          // The simulator's own limits (sim::RateLimits): a rate below them once hung the run.
          sub.add_option("--rate", a->rate_hz,
                         "Sensor sample rate in Hz, 1/3600 to 1e6 (default: the motion's frame "
                         "rate)")
              ->check(real_in(sim::RateLimits::min_hz, sim::RateLimits::max_hz, "Hz"));
          sub.add_option("--seed", a->seed,
                         "Seed of the hardware noise, 0 to 2^63 - 1, as a scene's "
                         "simulation.seed (which it replaces)")
              ->check(seed_range());
          sub.add_option("--gravity", a->gravity,
                         fmt::format("Gravity magnitude in m/s^2 (default {})", kStandardGravity))
              // The simulator's own limits, as for a scene's simulation.gravity.
              ->check(real_in(sim::GravityLimits::min_m_s2, sim::GravityLimits::max_m_s2, "m/s^2"));
          sub.add_option("--bvh", a->bvh, "Quick form: a BVH motion file");
          add_bvh_options(sub, a->bvh_args);
          sub.add_option("--preset", a->presets,
                         "Quick form: a placement preset (repeatable; see --list-presets)");
          sub.add_option("--hardware", a->hardware,
                         "Quick form: device profile JSON for every sensor");
          sub.add_flag("--ground-truth", a->ground_truth, "Also write the noiseless signals");
          sub.add_flag("--list-presets", a->list_presets, "Print the placement presets and exit");
          sub.footer(
              "\nExamples:\n"
              "  imukit simulate scene.json -o out/\n"
              "  imukit simulate --bvh walk.bvh --preset left_wrist_watch --hardware imu.json -o "
              "out/\n"
              "  imukit simulate --bvh 01_01.bvh --bvh-scale 0.056444 --preset right_wrist_watch "
              "-o out/ --method spline --rate 200\n"
              "  imukit simulate --list-presets\n");
          return [a] { return run_simulate(*a); };
        }});

}  // namespace imukit::cli
