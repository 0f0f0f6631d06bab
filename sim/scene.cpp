#include "imukit/sim/scene.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/json_text.hpp"
#include "imukit/core/parallel.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/time.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/placement.hpp"

namespace imukit::sim {
namespace {

using nlohmann::json;

// A position in metres within PlausibilityLimits::max_position_m (a joint offset, a sensor
// position).
Eigen::Vector3d position(const json& j, const std::string& source, const std::string& path) {
  const Eigen::Vector3d v = json_vec3(j, source, path);
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v(k)) > PlausibilityLimits::max_position_m) {
      json_fail(source, fmt::format("{}[{}]", path, k),
                fmt::format("{:g} m is beyond {:g} m (not metres?)", v(k),
                            PlausibilityLimits::max_position_m));
    }
  }
  return v;
}

std::string resolve(const std::string& base, const std::string& name) {
  const std::filesystem::path p(name);
  return p.is_absolute() || base.empty() ? name : (std::filesystem::path(base) / p).string();
}

Eigen::Quaterniond rotation_of(const json& j, const std::string& source, const std::string& path) {
  json_only_keys(j, {"quaternion_wxyz", "euler", "order", "intrinsic", "unit"}, source, path);
  // One or the other: Euler angles beside a quaternion were dropped (found in review,
  // 2026-11-27).
  if (j.contains("quaternion_wxyz")) {
    for (const char* k : {"euler", "order", "intrinsic", "unit"})
      if (j.contains(k))
        json_fail(source, path + "." + k, "give either quaternion_wxyz or euler, not both");
  }
  if (j.contains("quaternion_wxyz")) {
    const json& q = j["quaternion_wxyz"];
    if (!q.is_array() || q.size() != 4)
      json_fail(source, path + ".quaternion_wxyz", "expected 4 numbers w, x, y, z");
    Eigen::Quaterniond r(json_number(q[0], source, path), json_number(q[1], source, path),
                         json_number(q[2], source, path), json_number(q[3], source, path));
    const double n = r.norm();
    if (std::abs(n - 1.0) > 1e-6)
      json_fail(source, path + ".quaternion_wxyz",
                "not a unit quaternion (norm " + std::to_string(n) + ")");
    r.coeffs() /= n;
    return r;
  }
  if (j.contains("euler")) {
    // The convention must be spelled out (DESIGN.md): no default order or unit.
    for (const char* k : {"order", "intrinsic", "unit"}) {
      if (!j.contains(k))
        json_fail(source, path,
                  std::string("Euler angles need \"") + k +
                      "\" (e.g. {\"order\": \"XYZ\", \"intrinsic\": true, \"unit\": \"deg\"})");
    }
    if (!j["intrinsic"].is_boolean())
      json_fail(source, path + ".intrinsic", "expected true or false");
    const std::string unit = json_string(j["unit"], source, path + ".unit");
    if (unit != "deg" && unit != "rad")
      json_fail(source, path + ".unit", "expected \"deg\" or \"rad\"");
    const Eigen::Vector3d angles = json_vec3(j["euler"], source, path + ".euler");
    const double to_deg = unit == "deg" ? 1.0 : kDegPerRad;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(angles(k) * to_deg) > PlausibilityLimits::max_euler_deg) {
        json_fail(source, fmt::format("{}.euler[{}]", path, k),
                  fmt::format("{:g} {} is beyond {:g} deg: no placement turns that far (a corrupt "
                              "file?)",
                              angles(k), unit, PlausibilityLimits::max_euler_deg));
      }
    }
    try {
      return euler_to_quaternion(angles, json_string(j["order"], source, path + ".order"),
                                 j["intrinsic"].get<bool>(), unit == "deg");
    } catch (const Error& e) {
      json_fail(source, path + ".order", e.what());
    }
  }
  json_fail(source, path, "expected quaternion_wxyz or euler");
}

// "body": {"joints": [{"name": N, "parent": P or null, "offset_m": [x, y, z],
// "end_offset_m": [x, y, z]}]}: parents by name, each before its children.
Body body_of_joints(const json& joints, const std::string& source) {
  if (!joints.is_array() || joints.empty())
    json_fail(source, "body.joints", "expected a non-empty array of joints");
  std::vector<std::string> names;
  std::vector<int> parents;
  Eigen::Matrix3Xd offsets(3, static_cast<Eigen::Index>(joints.size()));
  std::vector<std::optional<Eigen::Vector3d>> ends;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const std::string path = "body.joints[" + std::to_string(i) + "]";
    const json& j = joints[i];
    json_only_keys(j, {"name", "parent", "offset_m", "end_offset_m"}, source, path);
    if (!j.contains("name")) json_fail(source, path + ".name", "missing");
    names.push_back(json_string(j["name"], source, path + ".name"));
    int parent = -1;
    if (j.contains("parent") && !j["parent"].is_null()) {
      const std::string p = json_string(j["parent"], source, path + ".parent");
      for (std::size_t k = 0; k < i; ++k) {
        if (names[k] == p) parent = static_cast<int>(k);
      }
      if (parent < 0) json_fail(source, path + ".parent", "'" + p + "' is not an earlier joint");
    } else if (i > 0) {
      json_fail(source, path + ".parent", "missing (only the first joint is the root)");
    }
    parents.push_back(parent);
    if (!j.contains("offset_m")) json_fail(source, path + ".offset_m", "missing");
    offsets.col(static_cast<Eigen::Index>(i)) = position(j["offset_m"], source, path + ".offset_m");
    ends.push_back(j.contains("end_offset_m")
                       ? std::optional(position(j["end_offset_m"], source, path + ".end_offset_m"))
                       : std::nullopt);
  }
  Body body;
  try {
    body = body_from_joints(names, parents, offsets, "body.joints");
  } catch (const Error& e) {
    throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt}, e.what());
  }
  for (std::size_t i = 0; i < ends.size(); ++i) body.joint(i).end_offset = ends[i];
  return body;
}

}  // namespace

namespace {
Scene parse_scene_impl(std::string_view text, const std::string& source,
                       const std::string& base_dir, std::optional<double> rate_hz);

// A seed is a JSON integer in [0, kMaxSeed], the range of --seed (core/rng.hpp): the JSON
// reader keeps integers exact, while a number with a fraction or exponent is a double, which
// beyond 2^53 is not (9007199254740993 read as a double was 9007199254740992). An error quotes
// the value as the file writes it, at its line and column.
uint64_t seed_of(const json& j, std::string_view text, const std::string& source,
                 const std::string& path) {
  if (j.is_number_unsigned() && j.get<uint64_t>() <= kMaxSeed) return j.get<uint64_t>();
  if (j.is_number_integer() && !j.is_number_unsigned() && j.get<int64_t>() >= 0)
    return static_cast<uint64_t>(j.get<int64_t>());  // only "-0": others >= 0 read unsigned
  const std::size_t offset = json_path_offset(text, path);
  std::string written = j.type_name();
  bool whole_double = false;
  if (j.is_number()) {
    const std::size_t end = text.find_first_of(",}] \t\r\n", offset);
    written = std::string(text.substr(offset, end - offset));
    const double v = j.get<double>();
    // <= 2^63: the largest seed written with ".0" reads as the double 2^63 (found in review:
    // "9223372036854775807.0" got no hint and looked inside the range it was refused from).
    whole_double = j.is_number_float() && v >= 0 && v <= std::ldexp(1.0, 63) && v == std::floor(v);
  }
  throw Error(locate_in_text(text, offset, source),
              fmt::format("{}: expected an integer in [0, {}]{}, got {}", path, kMaxSeed,
                          whole_double ? " written without a fraction or exponent" : "", written));
}
}  // namespace

Scene parse_scene(std::string_view text, const std::string& source, const std::string& base_dir,
                  std::optional<double> rate_hz) {
  assert(!rate_hz || rate_within_limits(*rate_hz));
  try {
    return parse_scene_impl(text, source, base_dir, rate_hz);
  } catch (const json::exception& e) {
    // Numbers out of range, invalid UTF-8 in strings, ...: the JSON library's own checks.
    throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt},
                std::string("invalid JSON: ") + e.what());
  }
}

namespace {

// "motion": {"bvh": ...}: the motion, its skeleton (into scene.body) and the reader's warnings;
// nullptr when the motion is not a BVH file.
std::shared_ptr<Motion> parse_bvh_motion(const json& m, const std::string& source,
                                         const std::string& base_dir, Scene& scene) {
  // One kind of motion; scale and up are the BVH reader's. Anything else beside it was dropped
  // (found in review, 2026-11-27: a BVH's rate_hz, a procedural motion next to a BVH).
  int kinds = 0;
  for (const char* k : {"bvh", "quaternion_csv", "procedural"}) kinds += m.contains(k) ? 1 : 0;
  if (kinds > 1) json_fail(source, "motion", "give one of bvh, quaternion_csv and procedural");
  for (const char* k : {"scale", "up"})
    if (m.contains(k) && !m.contains("bvh"))
      json_fail(source, std::string("motion.") + k, "applies to a bvh motion only");
  if (m.contains("rate_hz") && !m.contains("quaternion_csv"))
    json_fail(source, "motion.rate_hz",
              "applies to a quaternion_csv motion only (a BVH has its frame time, a procedural "
              "motion its own rate_hz)");
  if (!m.contains("bvh")) return nullptr;
  BvhOptions o;
  if (m.contains("scale")) o.scale = json_number(m["scale"], source, "motion.scale");
  if (m.contains("up")) {
    const std::string up = json_string(m["up"], source, "motion.up");
    if (up != "y" && up != "z") json_fail(source, "motion.up", "expected \"y\" or \"z\"");
    o.up = up == "y" ? UpAxis::y : UpAxis::z;
  }
  BvhData d = read_bvh(resolve(base_dir, json_string(m["bvh"], source, "motion.bvh")), o);
  scene.body = std::move(d.body);
  auto loaded = std::make_shared<Motion>(std::move(d.motion));
  scene.warnings = std::move(d.warnings);
  return loaded;
}

// "body": joints or the default humanoid (also without "body", unless a BVH motion brought one).
void parse_body(const json& root, const std::string& source, bool body_from_motion, Scene& scene) {
  if (root.contains("body")) {
    if (body_from_motion)
      json_fail(source, "body", "a BVH motion brings its own skeleton; remove \"body\"");
    const json& b = root["body"];
    json_only_keys(b, {"schema", "default_humanoid", "joints"}, source, "body");
    if (b.contains("default_humanoid") == b.contains("joints"))
      json_fail(source, "body", "expected one of default_humanoid or joints");
    // A body file of `imukit motion --body-json` pasted in whole keeps its schema.
    if (b.contains("schema") && b["schema"] != std::string(kBodySchema))
      json_fail(source, "body.schema",
                "expected \"" + std::string(kBodySchema) + "\" or no schema");
  }
  if (root.contains("body") && root["body"].contains("joints")) {
    scene.body = body_of_joints(root["body"]["joints"], source);
  } else if (root.contains("body")) {
    const json& h = root["body"]["default_humanoid"];
    json_only_keys(h, {"height_m"}, source, "body.default_humanoid");
    try {
      scene.body = Body::default_humanoid(
          h.contains("height_m")
              ? json_number(h["height_m"], source, "body.default_humanoid.height_m")
              : 1.75);
    } catch (const Error& e) {
      json_fail(source, "body.default_humanoid.height_m", e.what());
    }
  } else if (!body_from_motion) {
    scene.body = Body::default_humanoid();
  }
}

// The rest of "motion" once the body is known: a quaternion CSV or a procedural motion (unless
// `loaded` holds the BVH motion), checked against the body's joint count.
void parse_motion(const json& m, std::string_view text, const std::string& source,
                  const std::string& base_dir, std::shared_ptr<Motion> loaded, Scene& scene) {
  if (m.contains("quaternion_csv")) {
    std::optional<double> rate;
    if (m.contains("rate_hz")) {
      rate = json_number(m["rate_hz"], source, "motion.rate_hz");
      if (!rate_within_limits(*rate))
        json_fail(source, "motion.rate_hz", std::string("must be in ") + RateLimits::text);
    }
    loaded = std::make_shared<Motion>(read_quaternion_csv(
        resolve(base_dir, json_string(m["quaternion_csv"], source, "motion.quaternion_csv")),
        scene.body, rate, &scene.warnings));
  }
  if (loaded) {
    scene.motion = loaded;
  } else if (m.contains("procedural")) {
    const json& p = m["procedural"];
    json_only_keys(p, {"rate_hz", "duration_s", "seed", "amplitude_rad"}, source,
                   "motion.procedural");
    ProceduralMotionOptions po;
    if (p.contains("rate_hz"))
      po.rate_hz = json_number(p["rate_hz"], source, "motion.procedural.rate_hz");
    if (!(po.rate_hz >= 1 && po.rate_hz <= 1e6))
      json_fail(source, "motion.procedural.rate_hz", "must be a whole number of Hz in [1, 1e6]");
    if (p.contains("seed")) po.seed = seed_of(p["seed"], text, source, "motion.procedural.seed");
    // Its range is checked by ProceduralMotion itself (below), Python's too.
    if (p.contains("amplitude_rad"))
      po.amplitude_rad = json_number(p["amplitude_rad"], source, "motion.procedural.amplitude_rad");
    if (!p.contains("duration_s")) json_fail(source, "motion.procedural.duration_s", "missing");
    const double dur = json_number(p["duration_s"], source, "motion.procedural.duration_s");
    if (!(dur > 0.0 && dur < 1e7))
      json_fail(source, "motion.procedural.duration_s", "must be in (0, 1e7) s");
    try {
      po.frames = samples_spanning(dur, po.rate_hz);
      scene.motion = std::make_shared<ProceduralMotion>(scene.body.size(), po);
    } catch (const Error& e) {
      json_fail(source, "motion.procedural", e.what());
    }
  } else if (!loaded) {
    json_fail(source, "motion", "expected bvh, quaternion_csv or procedural");
  }
  if (scene.motion->joint_count() != scene.body.size()) {
    json_fail(source, "motion",
              "the motion has " + std::to_string(scene.motion->joint_count()) +
                  " joints, the body " + std::to_string(scene.body.size()));
  }
  scene.frames = scene.motion->frame_count();
}

// "simulation": method, rate, anti-aliasing, gravity, magnetic field, seed, chunk size.
void parse_simulation(const json& s, std::string_view text, const std::string& source,
                      Scene& scene) {
  json_only_keys(
      s, {"method", "rate_hz", "anti_alias", "gravity", "magnetic_field", "seed", "chunk_frames"},
      source, "simulation");
  if (s.contains("anti_alias")) {
    if (!s["anti_alias"].is_boolean())
      json_fail(source, "simulation.anti_alias", "expected true or false");
    scene.options.anti_alias = s["anti_alias"].get<bool>();
  }
  if (s.contains("method")) {
    try {
      scene.options.method =
          parse_derivative_method(json_string(s["method"], source, "simulation.method"));
    } catch (const Error& e) {
      json_fail(source, "simulation.method", e.what());
    }
  }
  if (s.contains("rate_hz")) {
    scene.options.rate_hz = json_number(s["rate_hz"], source, "simulation.rate_hz");
    if (!rate_within_limits(scene.options.rate_hz))
      json_fail(source, "simulation.rate_hz", std::string("must be in ") + RateLimits::text);
  }
  if (s.contains("gravity")) {
    scene.options.gravity_world = json_vec3(s["gravity"], source, "simulation.gravity");
    try {
      check_gravity(scene.options.gravity_world, "simulation.gravity");
    } catch (const Error& e) {
      throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt}, e.what());
    }
  }
  if (s.contains("magnetic_field")) {
    scene.options.magnetic_field_world =
        json_vec3(s["magnetic_field"], source, "simulation.magnetic_field");
    // Tesla, not microtesla or gauss: the Earth's field is 25-65 uT; 1e-2 T is a strong magnet.
    if (!(scene.options.magnetic_field_world.norm() <= 1e-2))
      json_fail(source, "simulation.magnetic_field",
                "expected Tesla (the Earth's field is 25e-6 to 65e-6 T), got a field of " +
                    std::to_string(scene.options.magnetic_field_world.norm()) + " T");
  }
  if (s.contains("seed")) scene.seed = seed_of(s["seed"], text, source, "simulation.seed");
  if (s.contains("chunk_frames")) {
    const double c = json_number(s["chunk_frames"], source, "simulation.chunk_frames");
    try {
      check_chunk_frames(c, "simulation.chunk_frames");
    } catch (const Error& e) {
      throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt}, e.what());
    }
    scene.options.chunk_frames = static_cast<int64_t>(c);
  }
}

// "outputs": {"ground_truth": bool}.
void parse_outputs(const json& o, const std::string& source, Scene& scene) {
  json_only_keys(o, {"ground_truth"}, source, "outputs");
  if (o.contains("ground_truth")) {
    if (!o["ground_truth"].is_boolean())
      json_fail(source, "outputs.ground_truth", "expected true or false");
    scene.ground_truth = o["ground_truth"].get<bool>();
  }
}

// A sensor's "outputs": a non-empty array of signal names.
SensorOutputs parse_sensor_outputs(const json& o, const std::string& source,
                                   const std::string& path) {
  if (!o.is_array() || o.empty())
    json_fail(source, path + ".outputs", "expected a non-empty array of names");
  SensorOutputs outputs{false, false, false};
  for (const json& name : o) {
    const std::string n = json_string(name, source, path + ".outputs");
    if (n == "accelerometer")
      outputs.accelerometer = true;
    else if (n == "gyroscope")
      outputs.gyroscope = true;
    else if (n == "orientation")
      outputs.orientation = true;
    else if (n == "magnetometer")
      outputs.magnetometer = true;
    else
      json_fail(source, path + ".outputs",
                "unknown output '" + n + "' (accelerometer, gyroscope, orientation, magnetometer)");
  }
  return outputs;
}

// A sensor's "hardware": a device profile (inline or a file name), checked at the simulation
// rate (the motion's when the scene sets none) by the profile reader, so an error names the
// profile's key where it is written (found in review: a clock.jitter_s too large for the rate
// was said in the hardware model's words, naming neither the profile file nor the line). An
// inline profile's errors name the scene's line and column and the whole JSON path
// ("scene.json:8:40: sensors[0].hardware.clock.error_ppm: ..."), not a place in the one-line
// serialisation the reader is given.
void parse_sensor_hardware(const json& h, std::string_view text, const std::string& source,
                           const std::string& path, const std::string& base_dir, const Scene& scene,
                           SceneSensor& s) {
  const double rate = scene_rate_hz(scene);
  std::optional<DeviceProfile> inline_profile;  // its errors are located already: not wrapped
  if (!h.is_string())
    inline_profile = parse_inline_profile(h.dump(), text, path + ".hardware", source, rate);
  try {
    s.hardware = to_hardware_model(
        inline_profile ? *inline_profile
                       : read_profile_for_rate(resolve(base_dir, h.get<std::string>()), rate));
    validate_hardware_model(*s.hardware, rate);  // a guard: the reader has checked its rules
    if (!s.hardware->gyroscope.g_sensitivity.isZero() && s.spec.outputs.gyroscope) {
      s.spec.outputs.accelerometer = true;  // the gyroscope's g-sensitivity needs it
    }
  } catch (const Error& e) {
    json_fail(source, path + ".hardware", e.what());
  }
}

// "sensors"[i]: name, placement (a preset or a segment with position and rotation), outputs and
// hardware; `scene` holds the body, the motion and the sensors before it.
SceneSensor parse_sensor(const json& js, std::size_t i, std::string_view text,
                         const std::string& source, const std::string& base_dir,
                         const Scene& scene) {
  const std::string path = "sensors[" + std::to_string(i) + "]";
  json_only_keys(js, {"name", "preset", "segment", "position_m", "rotation", "hardware", "outputs"},
                 source, path);
  SceneSensor s;
  s.spec.name = js.contains("name")
                    ? json_string(js["name"], source, path + ".name")
                    : (js.contains("preset") ? json_string(js["preset"], source, path + ".preset")
                                             : "sensor" + std::to_string(i));
  if (s.spec.name.empty() || s.spec.name.find_first_of("/\\") != std::string::npos) {
    json_fail(source, path + ".name", "must be non-empty without '/' (it names output files)");
  }
  // A sensor's files are <name>.csv and <name>.truth.csv, .orientation.csv, .mag.csv and
  // .mag.truth.csv: a sensor named "w.truth" beside a "w" with ground truth wrote both into one
  // file (found in review, 2026-11-27), and "W" beside "w" collide on a case-insensitive disk.
  const auto lower = [](std::string n) {
    for (char& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return n;
  };
  for (const char* suffix : {".truth", ".orientation", ".mag"}) {
    if (lower(s.spec.name).ends_with(suffix))
      json_fail(source, path + ".name",
                fmt::format("'{}' ends in {}, the name of another sensor's output file",
                            s.spec.name, suffix));
  }
  for (const SceneSensor& other : scene.sensors) {
    if (lower(other.spec.name) == lower(s.spec.name))
      json_fail(source, path + ".name",
                "duplicate sensor name '" + s.spec.name + "' (names name files; case is ignored)");
  }
  if (js.contains("preset")) {
    if (js.contains("segment")) json_fail(source, path, "give either preset or segment, not both");
    // A preset is a whole placement: a position or rotation beside it was dropped (found in
    // review, 2026-11-27).
    for (const char* k : {"position_m", "rotation"})
      if (js.contains(k))
        json_fail(source, path + "." + k,
                  "a preset places the sensor; give segment with position_m and rotation instead");
    s.preset = json_string(js["preset"], source, path + ".preset");
    try {
      s.spec.placement = preset_placement(s.preset, scene.body, s.spec.name);
    } catch (const Error& e) {
      json_fail(source, path + ".preset", e.what());
    }
  } else if (js.contains("segment")) {
    const std::string seg = json_string(js["segment"], source, path + ".segment");
    const auto j = scene.body.find(seg);
    if (!j) json_fail(source, path + ".segment", "the body has no segment or joint '" + seg + "'");
    s.spec.placement.joint = *j;
    if (js.contains("position_m"))
      s.spec.placement.p_joint_sensor = position(js["position_m"], source, path + ".position_m");
    if (js.contains("rotation"))
      s.spec.placement.q_joint_sensor = rotation_of(js["rotation"], source, path + ".rotation");
  } else {
    json_fail(source, path, "needs a preset or a segment");
  }
  if (js.contains("outputs")) s.spec.outputs = parse_sensor_outputs(js["outputs"], source, path);
  if (js.contains("hardware"))
    parse_sensor_hardware(js["hardware"], text, source, path, base_dir, scene, s);
  return s;
}

Scene parse_scene_impl(std::string_view text, const std::string& source,
                       const std::string& base_dir, std::optional<double> rate_hz) {
  const json root = parse_json_text<json>(text, source);
  json_only_keys(root,
                 {"schema", "body", "motion", "simulation", "sensors", "outputs", "description"},
                 source, "$");
  if (!root.contains("schema") || root["schema"] != std::string(kSceneSchema)) {
    json_fail(source, "schema", "expected \"" + std::string(kSceneSchema) + "\"");
  }
  Scene scene;
  // Motion (and, for BVH, the body), then the body, then the other motions (they need the body).
  if (!root.contains("motion")) json_fail(source, "motion", "missing");
  const json& m = root["motion"];
  json_only_keys(m, {"bvh", "scale", "up", "quaternion_csv", "rate_hz", "procedural"}, source,
                 "motion");
  std::shared_ptr<Motion> loaded = parse_bvh_motion(m, source, base_dir, scene);
  parse_body(root, source, loaded != nullptr, scene);
  parse_motion(m, text, source, base_dir, std::move(loaded), scene);
  if (root.contains("simulation")) parse_simulation(root["simulation"], text, source, scene);
  if (rate_hz) scene.options.rate_hz = *rate_hz;
  if (root.contains("outputs")) parse_outputs(root["outputs"], source, scene);
  // Sensors.
  if (!root.contains("sensors") || !root["sensors"].is_array() || root["sensors"].empty()) {
    json_fail(source, "sensors", "expected a non-empty array");
  }
  for (std::size_t i = 0; i < root["sensors"].size(); ++i)
    scene.sensors.push_back(parse_sensor(root["sensors"][i], i, text, source, base_dir, scene));
  return scene;
}
}  // namespace

std::string body_json(const Body& body, bool with_schema) {
  json joints = json::array();
  for (const Joint& j : body.joints()) {
    json o;
    o["name"] = j.name;
    o["parent"] =
        j.parent < 0 ? json(nullptr) : json(body.joint(static_cast<std::size_t>(j.parent)).name);
    const Eigen::Vector3d& v = j.offset_parent_joint;
    o["offset_m"] = {v.x(), v.y(), v.z()};
    if (j.end_offset) o["end_offset_m"] = {j.end_offset->x(), j.end_offset->y(), j.end_offset->z()};
    joints.push_back(o);
  }
  json out{{"joints", joints}};
  if (with_schema) out["schema"] = kBodySchema;
  return out.dump();
}

SceneSensor preset_sensor(std::string_view preset, const Body& body, std::string name) {
  SceneSensor s;
  s.preset = std::string(preset);
  s.spec.name = name.empty() ? s.preset : std::move(name);
  s.spec.placement = preset_placement(preset, body, s.spec.name);
  return s;
}

double scene_rate_hz(const Scene& scene) { return sample_rate_hz(scene.options, *scene.motion); }

int64_t scene_sample_count(const Scene& scene) {
  return sample_count(scene.motion->rate_hz(),
                      frames_to_simulate(*scene.motion, scene.frames, "simulation"),
                      scene_rate_hz(scene));
}

Scene read_scene(const std::string& path, std::optional<double> rate_hz) {
  const std::string text = read_regular_file(path, kMaxJsonBytes, "scene");
  return parse_scene(text, path, std::filesystem::path(path).parent_path().string(), rate_hz);
}

namespace {

// Applies one sensor's hardware model to a block (gyroscope first: it needs the true specific
// force).
void apply_hardware(ImuErrorGenerator& gen, SensorBlock& b) {
  if (b.angular_rate.cols() > 0) gen.apply_gyroscope(b.angular_rate, b.specific_force);
  if (b.specific_force.cols() > 0) gen.apply_accelerometer(b.specific_force);
  if (b.magnetic_field.cols() > 0) gen.apply_magnetometer(b.magnetic_field);
}

// The child stream (of the sensor's Rng(seed).child(s)) its clock's jitter draws from; the
// hardware generator takes its one draw from the sensor's stream itself, so jitter leaves the
// noise unchanged.
constexpr uint64_t kJitterStream = 1;

// Sensors sampled at the same instants: every sensor with an ideal clock, or one sensor with its
// own clock. Sample k is taken at true time k / (rate (1 + ppm 1e-6)) + jitter_k (clipped to
// +-0.45 periods so samples stay in order, and to the motion) and stamped k / rate.
struct TimingGroup {
  std::vector<std::size_t> sensors;  // scene indices
  std::unique_ptr<Simulator> sim;
  ClockModel clock;
  double true_rate = 0.0;  // rate (1 + ppm 1e-6)
  int64_t total = 0;       // samples inside the motion
  int64_t next = 0;
  std::optional<Rng> jitter;
  std::optional<TimeNs> pending;  // true time of sample `next`, drawn but not yet used
  TimeNs t_last = 0;              // true time of the last unjittered sample (clip bound)
  TimeNs take_time() {
    if (pending) return *pending;
    TimeNs t = sample_time(0, next, true_rate);
    if (jitter) {
      const double limit = 0.45 / true_rate;
      const double j = std::clamp(clock.jitter_s * jitter->normal(), -limit, limit);
      t = std::clamp<TimeNs>(t + from_seconds(j), 0, t_last);
    }
    pending = t;
    return t;
  }
};

// Scenes where some sensor has a clock error or jitter: one simulator per timing group, stepped
// through the motion chunk by chunk, so sinks still see every sensor's blocks in time order.
void run_scene_clocked(Scene& scene, const SceneSink& sink, double rate, int64_t frames,
                       std::vector<std::unique_ptr<ImuErrorGenerator>>& gens) {
  const Rng base(scene.seed);
  std::vector<TimingGroup> groups;
  TimingGroup ideal;
  for (std::size_t s = 0; s < scene.sensors.size(); ++s) {
    const SceneSensor& ss = scene.sensors[s];
    if (!ss.hardware || ss.hardware->clock.ideal()) {
      ideal.sensors.push_back(s);
      continue;
    }
    TimingGroup g;
    g.sensors.push_back(s);
    g.clock = ss.hardware->clock;
    if (g.clock.jitter_s > 0.0) g.jitter = base.child(s).child(kJitterStream);
    groups.push_back(std::move(g));
  }
  if (!ideal.sensors.empty()) groups.insert(groups.begin(), std::move(ideal));
  LimitedMotion motion(*scene.motion, frames);
  for (TimingGroup& g : groups) {
    std::vector<SensorSpec> specs;
    for (std::size_t s : g.sensors) specs.push_back(scene.sensors[s].spec);
    g.sim = std::make_unique<Simulator>(scene.body, specs, scene.options);
    g.true_rate = rate * (1.0 + g.clock.error_ppm * 1e-6);
    g.total = g.sim->sample_count(motion, frames, g.true_rate);
    g.t_last = sample_time(0, g.total - 1, g.true_rate);
  }
  const double motion_rate = motion.rate_hz();
  std::vector<TimeNs> times;
  std::vector<SensorBlock> blocks;
  SensorBlock measured;
  // Blocks of frames as Simulator::run takes them (the first group's filter, where it has one:
  // every group samples at the scene's rate within its clock error).
  const int64_t block = groups.front().sim->block_frames(motion);
  for (int64_t chunk_end = block;; chunk_end += block) {
    bool more = false;
    for (TimingGroup& g : groups) {
      times.clear();
      while (g.next < g.total && times.size() < Simulator::kMaxBlockSamples) {
        const TimeNs t = g.take_time();
        if (Simulator::frame_at(t, motion_rate) >= chunk_end) break;
        times.push_back(t);
        g.pending.reset();
        ++g.next;
      }
      more |= g.next < g.total;
      if (times.empty()) continue;
      g.sim->evaluate(motion, times, blocks);
      const int64_t first = g.next - static_cast<int64_t>(times.size());
      for (std::size_t b = 0; b < g.sensors.size(); ++b) {
        const std::size_t s = g.sensors[b];
        const SensorBlock& truth = blocks[b];
        measured = truth;
        // What the device reports: its own clock's reading at the sample, k / rate.
        if (!g.clock.ideal()) {
          for (std::size_t i = 0; i < measured.t.size(); ++i)
            measured.t[i] = sample_time(0, first + static_cast<int64_t>(i), rate);
        }
        if (gens[s]) apply_hardware(*gens[s], measured);
        sink(s, measured, scene.ground_truth ? &truth : nullptr);
      }
    }
    if (!more) break;
  }
}

}  // namespace

void run_scene(Scene& scene, const SceneSink& sink) {
  const double rate = scene_rate_hz(scene);
  const Rng base(scene.seed);
  std::vector<std::unique_ptr<ImuErrorGenerator>> gens(scene.sensors.size());
  bool clocked = false;
  for (std::size_t s = 0; s < scene.sensors.size(); ++s) {
    if (scene.sensors[s].hardware) {
      Rng r = base.child(s);
      gens[s] = std::make_unique<ImuErrorGenerator>(*scene.sensors[s].hardware, rate, r);
      clocked |= !scene.sensors[s].hardware->clock.ideal();
    }
  }
  if (clocked) {
    require_simulatable(*scene.motion, "simulation");
    run_scene_clocked(scene, sink, rate,
                      frames_to_simulate(*scene.motion, scene.frames, "simulation"), gens);
    return;
  }
  std::vector<SensorSpec> specs;
  for (const SceneSensor& s : scene.sensors) specs.push_back(s.spec);
  Simulator sim(scene.body, specs, scene.options);
  SensorBlock measured;
  sim.run(
      *scene.motion,
      [&](std::size_t s, const SensorBlock& truth) {
        if (!gens[s]) {
          sink(s, truth, scene.ground_truth ? &truth : nullptr);
          return;
        }
        measured = truth;
        apply_hardware(*gens[s], measured);
        sink(s, measured, scene.ground_truth ? &truth : nullptr);
      },
      scene.frames);
}

std::vector<std::vector<ImuSeries>> simulate_batch(const Body& body,
                                                   const std::vector<BatchJob>& jobs, uint64_t seed,
                                                   unsigned threads) {
  std::vector<std::vector<ImuSeries>> result(jobs.size());
  const Rng base(seed);
  parallel_for(jobs.size(), threads, [&](std::size_t i, unsigned /*worker*/) {
    const BatchJob& job = jobs[i];
    std::vector<SensorSpec> specs;
    for (const SceneSensor& s : job.sensors) specs.push_back(s.spec);
    Simulator sim(body, specs, job.options);
    const double rate = sample_rate_hz(job.options, *job.motion);
    Rng job_rng = base.child(i);
    std::vector<SensorBlock> blocks;
    std::vector<TimeNs> times;
    const int64_t n = sim.sample_count(*job.motion, job.motion->frames());
    for (int64_t k = 0; k < n; ++k) times.push_back(sim.sample_time_ns(*job.motion, k));
    sim.evaluate(*job.motion, times, blocks);
    std::vector<ImuSeries> out(specs.size());
    for (std::size_t s = 0; s < specs.size(); ++s) {
      if (job.sensors[s].hardware) {
        ImuErrorGenerator gen(*job.sensors[s].hardware, rate, job_rng);
        apply_hardware(gen, blocks[s]);
      }
      out[s].t = std::move(blocks[s].t);
      out[s].accel = std::move(blocks[s].specific_force);
      out[s].gyro = std::move(blocks[s].angular_rate);
      out[s].mag = std::move(blocks[s].magnetic_field);
    }
    result[i] = std::move(out);
  });
  return result;
}

}  // namespace imukit::sim
