#include "imukit/core/profile.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <system_error>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/json_text.hpp"

namespace imukit {
namespace {

// ordered_json keeps keys in the order written, so files read the way they were laid out.
using Json = nlohmann::ordered_json;

// No profile nests deeper than 5; the limit keeps hostile input from costing stack (the
// formatter recurses when update_profile keeps unknown sections).
constexpr int kMaxDepth = 64;

const char* const kSensorNames[3] = {"accelerometer", "gyroscope", "magnetometer"};

// The one set of units imukit.profile/1 uses; the writer names them, the reader checks them.
const std::pair<const char*, const char*> kUnits[] = {
    {"accelerometer", "m/s^2"},
    {"gyroscope", "rad/s"},
    {"magnetometer", "T"},
    {"gravity", "m/s^2"},
    {"noise_density", "sensor unit/sqrt(Hz)"},
    {"bias_instability", "sensor unit"},
    {"random_walk", "sensor unit/s/sqrt(Hz)"},
    {"tau", "s"},
    {"adev", "sensor unit"},
    {"rate", "Hz"},
    {"bandwidth", "Hz"},
    {"range", "sensor unit"},
    {"resolution", "sensor unit"},
    {"scale", "1"},
    {"misalignment", "rad"},
    {"g_sensitivity", "(rad/s)/(m/s^2)"},
    {"hard_iron", "T"},
    {"soft_iron", "1"},
};

Json parse_json(std::string_view text, const std::string& source) {
  return parse_json_text<Json>(text, source, kMaxDepth);
}

// ---------------------------------------------------------------------------------------------
// Reading: every value is checked and an error names its JSON path.

std::string describe(const Json& j) {
  switch (j.type()) {
    case Json::value_t::null:
      return "null";
    case Json::value_t::boolean:
      return j.get<bool>() ? "true" : "false";
    case Json::value_t::string:
      return "a string";
    case Json::value_t::object:
      return "an object";
    case Json::value_t::array:
      return fmt::format("an array of {}", j.size());
    case Json::value_t::binary:
      return "binary data";
    case Json::value_t::discarded:
      return "nothing";
    default:
      return fmt::format("{}", j.get<double>());
  }
}

// The profile's sensor sections by name, null where absent.
std::array<std::pair<const char*, const SensorProfile*>, 3> sensors_of(const DeviceProfile& p) {
  return {{{"accelerometer", p.accelerometer ? &*p.accelerometer : nullptr},
           {"gyroscope", p.gyroscope ? &*p.gyroscope : nullptr},
           {"magnetometer", p.magnetometer ? &*p.magnetometer : nullptr}}};
}

std::string join(const std::string& path, const char* key) {
  return path.empty() ? std::string(key) : path + "." + key;
}

// The path in an error about the document itself (not an object).
constexpr const char* kTopLevel = "(top level)";

// Checks a parsed profile. Given the text it was parsed from, an error names the line and
// column of the value at fault; without (the writer checks what it is about to write), the path.
// With a prefix, the profile is the value at that path of `text` (parse_inline_profile), and
// paths in errors are the whole path from the document's root.
class Reader {
 public:
  explicit Reader(std::string source, std::string_view text = {}, std::string prefix = {})
      : source_(std::move(source)), text_(text), prefix_(std::move(prefix)) {}

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    const std::string full = prefix_.empty()     ? path
                             : path == kTopLevel ? prefix_
                                                 : prefix_ + "." + path;
    throw Error(text_.empty() ? InputLocation{source_, {}, {}, {}}
                              : locate_in_text(text_, json_path_offset(text_, full), source_),
                full + ": " + what);
  }

  const Json* member(const Json& object, const char* key) const {
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
  }

  const Json& required(const Json& object, const std::string& path, const char* key) const {
    const Json* j = member(object, key);
    if (j == nullptr) fail(join(path, key), "missing");
    return *j;
  }

  void expect_object(const Json& j, const std::string& path) const {
    if (!j.is_object()) fail(path, "expected an object, got " + describe(j));
  }

  enum class Sign { kAny, kNonNegative, kPositive, kNonZero };
  // A value to_hardware_model makes a model parameter is held to the model's magnitude limit
  // here, so a file is refused at its key and place (found in review: only the model checked it,
  // naming its own field, "accelerometer.noise_density[1]", and no file).
  enum class Magnitude { kAny, kModelParameter };

  double number(const Json& j, const std::string& path, Sign sign = Sign::kAny,
                Magnitude magnitude = Magnitude::kAny) const {
    if (!j.is_number()) fail(path, "expected a number, got " + describe(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, fmt::format("expected a finite number, got {}", v));
    if (sign == Sign::kNonNegative && v < 0.0) fail(path, fmt::format("expected >= 0, got {}", v));
    if (sign == Sign::kPositive && v <= 0.0) fail(path, fmt::format("expected > 0, got {}", v));
    if (sign == Sign::kNonZero && v == 0.0) fail(path, "expected a non-zero number, got 0");
    if (magnitude == Magnitude::kModelParameter &&
        !(std::abs(v) <= HardwareModel::kMaxParameterMagnitude)) {
      fail(path, fmt::format("{} is beyond any sensor's (at most {:g} in magnitude)", v,
                             HardwareModel::kMaxParameterMagnitude));
    }
    return v;
  }

  int64_t count(const Json& j, const std::string& path, int64_t minimum) const {
    if (!j.is_number_integer() || (j.is_number_unsigned() && j.get<uint64_t>() > INT64_MAX)) {
      fail(path, "expected an integer, got " + describe(j));
    }
    const auto v = j.get<int64_t>();
    if (v < minimum) fail(path, fmt::format("expected an integer >= {}, got {}", minimum, v));
    return v;
  }

  std::string string(const Json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, "expected a string, got " + describe(j));
    return j.get<std::string>();
  }

  bool boolean(const Json& j, const std::string& path) const {
    if (!j.is_boolean()) fail(path, "expected true or false, got " + describe(j));
    return j.get<bool>();
  }

  std::vector<double> numbers(const Json& j, const std::string& path, Sign sign,
                              std::optional<std::size_t> size = {},
                              Magnitude magnitude = Magnitude::kAny) const {
    if (!j.is_array() || (size && j.size() != *size)) {
      fail(path, (size ? fmt::format("expected an array of {} numbers, got ", *size)
                       : std::string("expected an array of numbers, got ")) +
                     describe(j));
    }
    std::vector<double> out;
    out.reserve(j.size());
    for (std::size_t i = 0; i < j.size(); ++i) {
      out.push_back(number(j[i], fmt::format("{}[{}]", path, i), sign, magnitude));
    }
    return out;
  }

  Eigen::Vector3d vec3(const Json& j, const std::string& path, Sign sign = Sign::kAny,
                       Magnitude magnitude = Magnitude::kAny) const {
    const auto v = numbers(j, path, sign, 3, magnitude);
    return {v[0], v[1], v[2]};
  }

  // Rows of a 3 x 3 matrix.
  Eigen::Matrix3d mat3(const Json& j, const std::string& path,
                       Magnitude magnitude = Magnitude::kAny) const {
    if (!j.is_array() || j.size() != 3) {
      fail(path, "expected 3 rows of 3 numbers, got " + describe(j));
    }
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) {
      m.row(r) = vec3(j[r], fmt::format("{}[{}]", path, r), Sign::kAny, magnitude).transpose();
    }
    return m;
  }

  std::optional<Eigen::Vector3d> optional_vec3(const Json& object, const std::string& path,
                                               const char* key, Sign sign,
                                               Magnitude magnitude = Magnitude::kAny) const {
    const Json* j = member(object, key);
    if (j == nullptr) return std::nullopt;
    return vec3(*j, join(path, key), sign, magnitude);
  }

  std::optional<double> optional_number(const Json& object, const std::string& path,
                                        const char* key, Sign sign) const {
    const Json* j = member(object, key);
    if (j == nullptr) return std::nullopt;
    return number(*j, join(path, key), sign);
  }

  DeviceProfile profile(const Json& root) const;
  void check_at_rate(const DeviceProfile& p, double rate_hz) const;

 private:
  void schema(const Json& root) const;
  void units(const Json& root) const;
  NoiseEstimate noise(const Json& j, const std::string& path) const;
  TurnOnBias turn_on_bias(const Json& j, const std::string& path) const;
  Calibration calibration(const Json& j, const std::string& path) const;
  SensorLimits limits(const Json& j, const std::string& path) const;
  void sensor(const Json& j, const std::string& path, SensorProfile& out) const;
  void check_jitter(const DeviceProfile& p, double rate_hz, const char* which) const;

  std::string source_;
  std::string_view text_;
  std::string prefix_;
};

void Reader::schema(const Json& root) const {
  const Json* j = member(root, "schema");
  if (j == nullptr)
    fail("schema", fmt::format("missing; a device profile has \"schema\": \"{}\"", kProfileSchema));
  const std::string name = string(*j, "schema");
  if (name == kProfileSchema) return;
  if (name.rfind("imukit.profile/", 0) == 0) {
    fail("schema",
         fmt::format("unsupported version \"{}\"; this imukit reads \"{}\"", name, kProfileSchema));
  }
  fail("schema",
       fmt::format("\"{}\" is not a device profile (expected \"{}\")", name, kProfileSchema));
}

void Reader::units(const Json& root) const {
  const Json* j = member(root, "units");
  if (j == nullptr) return;
  expect_object(*j, "units");
  for (const auto& [key, unit] : kUnits) {
    const Json* named = member(*j, key);
    if (named == nullptr) continue;
    const std::string path = join("units", key);
    const std::string value = string(*named, path);
    if (value != unit) {
      fail(path,
           fmt::format("expected \"{}\", got \"{}\" ({} is SI only)", unit, value, kProfileSchema));
    }
  }
}

NoiseEstimate Reader::noise(const Json& j, const std::string& path) const {
  expect_object(j, path);
  NoiseEstimate n;
  constexpr Magnitude kModel = Magnitude::kModelParameter;
  n.noise_density = optional_vec3(j, path, "noise_density", Sign::kNonNegative, kModel);
  n.noise_density_sigma = optional_vec3(j, path, "noise_density_sigma", Sign::kNonNegative);
  n.bias_instability = optional_vec3(j, path, "bias_instability", Sign::kNonNegative, kModel);
  n.bias_instability_sigma = optional_vec3(j, path, "bias_instability_sigma", Sign::kNonNegative);
  if (const Json* band = member(j, "bias_instability_band")) {
    const std::string band_path = join(path, "bias_instability_band");
    const auto v = numbers(*band, band_path, Sign::kPositive, 2);
    if (!(v[1] > v[0]) || v[1] > 1e6 * v[0] || v[1] > 1e9) {
      fail(band_path, fmt::format("expected [tau_min, tau_max] with tau_min < tau_max <= "
                                  "min(1e6 tau_min, 1e9 s), got [{}, {}]",
                                  v[0], v[1]));
    }
    n.bias_instability_band_s = std::array<double, 2>{v[0], v[1]};
  }
  n.random_walk = optional_vec3(j, path, "random_walk", Sign::kNonNegative, kModel);
  n.random_walk_sigma = optional_vec3(j, path, "random_walk_sigma", Sign::kNonNegative);
  if (const Json* allan = member(j, "allan")) {
    const std::string allan_path = join(path, "allan");
    expect_object(*allan, allan_path);
    AllanCurve curve;
    const std::string tau_path = join(allan_path, "tau");
    curve.tau_s = numbers(required(*allan, allan_path, "tau"), tau_path, Sign::kPositive);
    for (std::size_t i = 1; i < curve.tau_s.size(); ++i) {
      if (!(curve.tau_s[i] > curve.tau_s[i - 1])) {
        fail(fmt::format("{}[{}]", tau_path, i),
             fmt::format("tau must increase, got {} after {}", curve.tau_s[i], curve.tau_s[i - 1]));
      }
    }
    const std::string adev_path = join(allan_path, "adev");
    const Json& adev = required(*allan, allan_path, "adev");
    if (!adev.is_array() || adev.size() != 3) {
      fail(adev_path, "expected 3 arrays (x, y, z), got " + describe(adev));
    }
    for (std::size_t axis = 0; axis < 3; ++axis) {
      curve.adev[axis] = numbers(adev[axis], fmt::format("{}[{}]", adev_path, axis),
                                 Sign::kNonNegative, curve.tau_s.size());
    }
    n.allan = std::move(curve);
  }
  return n;
}

TurnOnBias Reader::turn_on_bias(const Json& j, const std::string& path) const {
  expect_object(j, path);
  TurnOnBias t;
  constexpr Magnitude kModel = Magnitude::kModelParameter;
  t.mean = vec3(required(j, path, "mean"), join(path, "mean"), Sign::kAny, kModel);
  t.spread = vec3(required(j, path, "spread"), join(path, "spread"), Sign::kNonNegative, kModel);
  if (const Json* runs = member(j, "runs")) t.runs = count(*runs, join(path, "runs"), 1);
  return t;
}

Calibration Reader::calibration(const Json& j, const std::string& path) const {
  expect_object(j, path);
  Calibration c;
  constexpr Magnitude kModel = Magnitude::kModelParameter;
  c.scale = vec3(required(j, path, "scale"), join(path, "scale"), Sign::kNonZero, kModel);
  const std::string m_path = join(path, "misalignment");
  c.misalignment = mat3(required(j, path, "misalignment"), m_path, kModel);
  for (int i = 0; i < 3; ++i) {
    if (std::abs(c.misalignment(i, i) - 1.0) > 1e-9) {
      fail(fmt::format("{}[{}][{}]", m_path, i, i),
           fmt::format("the diagonal must be 1 (gains belong in scale), got {}",
                       c.misalignment(i, i)));
    }
  }
  c.bias = vec3(required(j, path, "bias"), join(path, "bias"), Sign::kAny, kModel);
  if (const Json* raw = member(j, "raw_counts"))
    c.raw_counts = boolean(*raw, join(path, "raw_counts"));
  if (const Json* r = member(j, "residual")) {
    const std::string r_path = join(path, "residual");
    expect_object(*r, r_path);
    CalibrationResidual residual;
    residual.rms = number(required(*r, r_path, "rms"), join(r_path, "rms"), Sign::kNonNegative);
    residual.max = number(required(*r, r_path, "max"), join(r_path, "max"), Sign::kNonNegative);
    residual.count = count(required(*r, r_path, "count"), join(r_path, "count"), 0);
    c.residual = residual;
  }
  return c;
}

SensorLimits Reader::limits(const Json& j, const std::string& path) const {
  expect_object(j, path);
  SensorLimits l;
  l.range = optional_number(j, path, "range", Sign::kNonNegative);
  l.resolution = optional_number(j, path, "resolution", Sign::kNonNegative);
  l.rate_hz = optional_number(j, path, "rate", Sign::kPositive);
  l.bandwidth_hz = optional_number(j, path, "bandwidth", Sign::kNonNegative);
  if (l.rate_hz && l.bandwidth_hz && *l.bandwidth_hz > 0.0 &&
      !(*l.bandwidth_hz < 0.5 * *l.rate_hz)) {
    fail(join(path, "bandwidth"), fmt::format("{} Hz is not below half the rate ({} Hz)",
                                              *l.bandwidth_hz, 0.5 * *l.rate_hz));
  }
  return l;
}

void Reader::sensor(const Json& j, const std::string& path, SensorProfile& out) const {
  expect_object(j, path);
  if (const Json* s = member(j, "noise")) out.noise = noise(*s, join(path, "noise"));
  if (const Json* s = member(j, "turn_on_bias"))
    out.turn_on_bias = turn_on_bias(*s, join(path, "turn_on_bias"));
  if (const Json* s = member(j, "calibration"))
    out.calibration = calibration(*s, join(path, "calibration"));
  if (const Json* s = member(j, "limits")) out.limits = limits(*s, join(path, "limits"));
}

DeviceProfile Reader::profile(const Json& root) const {
  if (!root.is_object()) fail(kTopLevel, "expected a JSON object, got " + describe(root));
  schema(root);
  units(root);
  DeviceProfile p;
  if (const Json* d = member(root, "device")) {
    expect_object(*d, "device");
    DeviceInfo info;
    for (auto [key, field] : {std::pair{"vendor", &info.vendor}, std::pair{"model", &info.model},
                              std::pair{"serial", &info.serial}, std::pair{"name", &info.name}}) {
      if (const Json* s = member(*d, key)) *field = string(*s, join("device", key));
    }
    p.device = std::move(info);
  }
  p.gravity = optional_number(root, "", "gravity", Sign::kPositive);
  if (const Json* c = member(root, "clock")) {
    expect_object(*c, "clock");
    ClockProfile clock;
    clock.error_ppm = optional_number(*c, "clock", "error_ppm", Sign::kAny);
    // validate_hardware_model's bound, checked here so the file is refused where it says so
    // (found in review: 1e5 was read, and refused later naming neither file nor key).
    if (clock.error_ppm && !(std::abs(*clock.error_ppm) <= ClockModel::kMaxErrorPpm)) {
      fail("clock.error_ppm", fmt::format("{} ppm is not within +-{:g} ppm", *clock.error_ppm,
                                          ClockModel::kMaxErrorPpm));
    }
    clock.jitter_s = optional_number(*c, "clock", "jitter_s", Sign::kNonNegative);
    p.clock = clock;
  }
  if (const Json* s = member(root, "accelerometer")) {
    p.accelerometer.emplace();
    sensor(*s, "accelerometer", *p.accelerometer);
  }
  if (const Json* s = member(root, "gyroscope")) {
    p.gyroscope.emplace();
    sensor(*s, "gyroscope", *p.gyroscope);
    if (const Json* g = member(*s, "g_sensitivity")) {
      p.gyroscope->g_sensitivity = mat3(*g, "gyroscope.g_sensitivity", Magnitude::kModelParameter);
    }
  }
  if (const Json* s = member(root, "magnetometer")) {
    p.magnetometer.emplace();
    sensor(*s, "magnetometer", *p.magnetometer);
    p.magnetometer->hard_iron =
        optional_vec3(*s, "magnetometer", "hard_iron", Sign::kAny, Magnitude::kModelParameter);
    if (const Json* m = member(*s, "soft_iron")) {
      p.magnetometer->soft_iron = mat3(*m, "magnetometer.soft_iron", Magnitude::kModelParameter);
    }
  }
  // Jitter is bounded by the sample period of the rate a model runs at (check_at_rate), not of a
  // rate the file states: a clock whose jitter is fine at 100 Hz may list 1 kHz among its rates
  // (found in review: the bound at the fastest stated rate refused such a profile at every rate).
  return p;
}

void Reader::check_jitter(const DeviceProfile& p, double rate_hz, const char* which) const {
  if (p.clock && p.clock->jitter_s && *p.clock->jitter_s > 0.1 / rate_hz) {
    fail("clock.jitter_s",
         fmt::format("{} s is more than a tenth of the sample period at {} ({} Hz: {:.3g} s)",
                     *p.clock->jitter_s, which, rate_hz, 0.1 / rate_hz));
  }
}

void Reader::check_at_rate(const DeviceProfile& p, double rate_hz) const {
  for (const auto& [name, s] : sensors_of(p)) {
    if (s == nullptr) continue;
    const std::string path = name;
    if (s->limits && s->limits->bandwidth_hz && *s->limits->bandwidth_hz > 0.0 &&
        !(*s->limits->bandwidth_hz < 0.5 * rate_hz)) {
      fail(path + ".limits.bandwidth",
           fmt::format("{} Hz is not below half the rate the model runs at ({} Hz)",
                       *s->limits->bandwidth_hz, 0.5 * rate_hz));
    }
    // validate_hardware_model's rule: the band must start 5 samples in (TriadModel's default
    // band [10, 1000] s when the file gives none).
    if (s->noise && s->noise->bias_instability && !s->noise->bias_instability->isZero(0.0)) {
      const double tau_min = s->noise->bias_instability_band_s
                                 ? (*s->noise->bias_instability_band_s)[0]
                                 : TriadModel{}.bias_instability_tau_min_s;
      if (tau_min * rate_hz < 5.0) {
        fail(path + (s->noise->bias_instability_band_s ? ".noise.bias_instability_band"
                                                       : ".noise.bias_instability"),
             fmt::format("the bias-instability band starts at {} s, under 5 samples at {} Hz; "
                         "start it at {:.3g} s or later",
                         tau_min, rate_hz, 5.0 / rate_hz));
      }
    }
  }
  check_jitter(p, rate_hz, "the rate the model runs at");
}

// ---------------------------------------------------------------------------------------------
// Writing.

Json to_json(const Eigen::Vector3d& v) { return Json::array({v[0], v[1], v[2]}); }

Json to_json(const Eigen::Matrix3d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r) rows.push_back(to_json(Eigen::Vector3d(m.row(r).transpose())));
  return rows;
}

void put_optional(Json& object, const char* key, const std::optional<Eigen::Vector3d>& v) {
  if (v) object[key] = to_json(*v);
}

void put_optional(Json& object, const char* key, const std::optional<double>& v) {
  if (v) object[key] = *v;
}

Json sensor_json(const SensorProfile& s) {
  Json out = Json::object();
  if (s.noise) {
    const NoiseEstimate& n = *s.noise;
    Json j = Json::object();
    put_optional(j, "noise_density", n.noise_density);
    put_optional(j, "noise_density_sigma", n.noise_density_sigma);
    put_optional(j, "bias_instability", n.bias_instability);
    put_optional(j, "bias_instability_sigma", n.bias_instability_sigma);
    if (n.bias_instability_band_s) {
      j["bias_instability_band"] =
          Json::array({(*n.bias_instability_band_s)[0], (*n.bias_instability_band_s)[1]});
    }
    put_optional(j, "random_walk", n.random_walk);
    put_optional(j, "random_walk_sigma", n.random_walk_sigma);
    if (n.allan) {
      j["allan"] =
          Json{{"tau", n.allan->tau_s},
               {"adev", Json::array({n.allan->adev[0], n.allan->adev[1], n.allan->adev[2]})}};
    }
    out["noise"] = std::move(j);
  }
  if (s.turn_on_bias) {
    Json j{{"mean", to_json(s.turn_on_bias->mean)}, {"spread", to_json(s.turn_on_bias->spread)}};
    if (s.turn_on_bias->runs) j["runs"] = *s.turn_on_bias->runs;
    out["turn_on_bias"] = std::move(j);
  }
  if (s.calibration) {
    const Calibration& c = *s.calibration;
    Json j{{"scale", to_json(c.scale)},
           {"misalignment", to_json(c.misalignment)},
           {"bias", to_json(c.bias)}};
    if (c.raw_counts) j["raw_counts"] = true;
    if (c.residual) {
      j["residual"] =
          Json{{"rms", c.residual->rms}, {"max", c.residual->max}, {"count", c.residual->count}};
    }
    out["calibration"] = std::move(j);
  }
  if (s.limits) {
    Json j = Json::object();
    put_optional(j, "range", s.limits->range);
    put_optional(j, "resolution", s.limits->resolution);
    put_optional(j, "rate", s.limits->rate_hz);
    put_optional(j, "bandwidth", s.limits->bandwidth_hz);
    out["limits"] = std::move(j);
  }
  return out;
}

Json units_json() {
  Json j = Json::object();
  for (const auto& [key, unit] : kUnits) j[key] = unit;
  return j;
}

Json profile_json(const DeviceProfile& p) {
  Json root = Json::object();
  root["schema"] = std::string(kProfileSchema);
  root["units"] = units_json();
  if (p.device) {
    root["device"] = Json{{"vendor", p.device->vendor},
                          {"model", p.device->model},
                          {"serial", p.device->serial},
                          {"name", p.device->name}};
  }
  if (p.gravity) root["gravity"] = *p.gravity;
  if (p.clock) {
    Json c = Json::object();
    if (p.clock->error_ppm) c["error_ppm"] = *p.clock->error_ppm;
    if (p.clock->jitter_s) c["jitter_s"] = *p.clock->jitter_s;
    root["clock"] = std::move(c);
  }
  if (p.accelerometer) root["accelerometer"] = sensor_json(*p.accelerometer);
  if (p.gyroscope) {
    Json j = sensor_json(*p.gyroscope);
    if (p.gyroscope->g_sensitivity) j["g_sensitivity"] = to_json(*p.gyroscope->g_sensitivity);
    root["gyroscope"] = std::move(j);
  }
  if (p.magnetometer) {
    Json j = sensor_json(*p.magnetometer);
    put_optional(j, "hard_iron", p.magnetometer->hard_iron);
    if (p.magnetometer->soft_iron) j["soft_iron"] = to_json(*p.magnetometer->soft_iron);
    root["magnetometer"] = std::move(j);
  }
  // What the reader would reject must not be written: run the reader over it (a NaN, say,
  // comes back as "accelerometer.noise.noise_density[1]: expected a finite number, got nan").
  Reader("profile to write").profile(root);
  return root;
}

std::string scalar_text(const Json& j) {
  // nlohmann prints doubles with the shortest digits that read back to the same value.
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

bool is_flat_array(const Json& j) {
  for (const Json& e : j) {
    if (e.is_structured()) return false;
  }
  return true;
}

// Two-space indentation, arrays of plain values on one line (vectors, matrix rows, Allan
// curves), so a profile reads like the documentation's example.
void format_json(const Json& j, int indent, std::string& out) {
  const std::string pad(static_cast<std::size_t>(indent) + 2, ' ');
  if (j.is_object()) {
    if (j.empty()) {
      out += "{}";
      return;
    }
    out += "{\n";
    std::size_t i = 0;
    for (const auto& [key, value] : j.items()) {
      out += pad + scalar_text(Json(key)) + ": ";
      format_json(value, indent + 2, out);
      out += ++i < j.size() ? ",\n" : "\n";
    }
    out += std::string(static_cast<std::size_t>(indent), ' ') + "}";
  } else if (j.is_array()) {
    if (j.empty() || is_flat_array(j)) {
      out += "[";
      for (std::size_t i = 0; i < j.size(); ++i) {
        if (i > 0) out += ", ";
        out += scalar_text(j[i]);
      }
      out += "]";
      return;
    }
    out += "[\n";
    for (std::size_t i = 0; i < j.size(); ++i) {
      out += pad;
      format_json(j[i], indent + 2, out);
      out += i + 1 < j.size() ? ",\n" : "\n";
    }
    out += std::string(static_cast<std::size_t>(indent), ' ') + "]";
  } else {
    out += scalar_text(j);
  }
}

std::string format_text(const Json& root) {
  std::string out;
  format_json(root, 0, out);
  out += "\n";
  return out;
}

std::string read_file_text(const std::string& path) {
  return read_regular_file(path, kMaxJsonBytes, "device profile");
}

template <typename T>
void take(std::optional<T>& base, const std::optional<T>& update) {
  if (update) base = update;
}

void merge_sensor(SensorProfile& base, const SensorProfile& update) {
  take(base.noise, update.noise);
  take(base.turn_on_bias, update.turn_on_bias);
  take(base.calibration, update.calibration);
  take(base.limits, update.limits);
}

void apply_triad(const SensorProfile& s, const char* name, TriadModel& t) {
  if (s.noise) {
    const NoiseEstimate& n = *s.noise;
    if (n.noise_density) t.noise_density = *n.noise_density;
    if (n.bias_instability) t.bias_instability = *n.bias_instability;
    if (n.bias_instability_band_s) {
      t.bias_instability_tau_min_s = (*n.bias_instability_band_s)[0];
      t.bias_instability_tau_max_s = (*n.bias_instability_band_s)[1];
    }
    if (n.random_walk) t.random_walk = *n.random_walk;
  }
  if (s.calibration) {
    if (s.calibration->raw_counts) {
      throw Error(
          fmt::format("{}.calibration: a calibration of raw counts (raw_counts: true) "
                      "cannot make an SI hardware model",
                      name));
    }
    t.scale = s.calibration->scale;
    t.misalignment = s.calibration->misalignment;
    t.turn_on_bias_mean = s.calibration->bias;
  }
  if (s.turn_on_bias) {
    t.turn_on_bias_mean = s.turn_on_bias->mean;
    t.turn_on_bias_spread = s.turn_on_bias->spread;
  }
  if (s.limits) {
    if (s.limits->range) t.range = *s.limits->range;
    if (s.limits->resolution) t.resolution = *s.limits->resolution;
    if (s.limits->rate_hz) t.rate_hz = *s.limits->rate_hz;
    if (s.limits->bandwidth_hz) t.bandwidth_hz = *s.limits->bandwidth_hz;
  }
}

}  // namespace

DeviceProfile parse_profile(std::string_view text, const std::string& source_name) {
  const Json root = parse_json(text, source_name);
  return Reader(source_name, text).profile(root);
}

DeviceProfile parse_inline_profile(std::string_view profile_text, std::string_view document,
                                   std::string_view json_path, const std::string& source_name,
                                   std::optional<double> rate_hz) {
  Json root;
  try {
    root = parse_json(profile_text, source_name);
  } catch (const Error& e) {
    // Not from a serialised value; said at the value in the document all the same.
    throw Error(locate_in_text(document, json_path_offset(document, json_path), source_name),
                std::string(json_path) + ": " + e.reason());
  }
  const Reader reader(source_name, document, std::string(json_path));
  const DeviceProfile p = reader.profile(root);
  if (rate_hz) reader.check_at_rate(p, *rate_hz);
  return p;
}

DeviceProfile read_profile(const std::string& path) {
  return parse_profile(read_file_text(path), path);
}

DeviceProfile read_profile_for_rate(const std::string& path, double rate_hz) {
  const std::string text = read_file_text(path);
  const Reader reader(path, text);
  const DeviceProfile p = reader.profile(parse_json(text, path));
  reader.check_at_rate(p, rate_hz);
  return p;
}

std::string format_profile(const DeviceProfile& profile) {
  return format_text(profile_json(profile));
}

void write_profile(const std::string& path, const DeviceProfile& profile) {
  write_text_file(path, format_profile(profile));
}

DeviceProfile merge_profile(DeviceProfile base, const DeviceProfile& update) {
  take(base.device, update.device);
  take(base.gravity, update.gravity);
  take(base.clock, update.clock);
  if (update.accelerometer) {
    if (!base.accelerometer) base.accelerometer.emplace();
    merge_sensor(*base.accelerometer, *update.accelerometer);
  }
  if (update.gyroscope) {
    if (!base.gyroscope) base.gyroscope.emplace();
    merge_sensor(*base.gyroscope, *update.gyroscope);
    take(base.gyroscope->g_sensitivity, update.gyroscope->g_sensitivity);
  }
  if (update.magnetometer) {
    if (!base.magnetometer) base.magnetometer.emplace();
    merge_sensor(*base.magnetometer, *update.magnetometer);
    take(base.magnetometer->hard_iron, update.magnetometer->hard_iron);
    take(base.magnetometer->soft_iron, update.magnetometer->soft_iron);
  }
  return base;
}

std::string merge_profile_text(std::string_view existing_text, const std::string& source_name,
                               const DeviceProfile& update) {
  Json root = parse_json(existing_text, source_name);
  Reader(source_name, existing_text).profile(root);  // must be a valid profile before we touch it
  const Json patch = profile_json(update);

  root["schema"] = std::string(kProfileSchema);
  // Our unit names replace theirs (the reader has checked they agree); unknown ones stay.
  Json& units = root["units"];
  for (const auto& [key, unit] : patch.at("units").items()) units[key] = unit;
  for (const char* key : {"device", "gravity", "clock"}) {
    if (patch.contains(key)) root[key] = patch.at(key);
  }
  for (const char* sensor : kSensorNames) {
    if (!patch.contains(sensor)) continue;
    Json& target = root[sensor];
    if (target.is_null()) target = Json::object();
    for (const auto& [section, value] : patch.at(sensor).items()) target[section] = value;
  }
  Reader(source_name).profile(root);
  return format_text(root);
}

void update_profile(const std::string& path, const DeviceProfile& update) {
  // The profile is read back before it is replaced: /dev/stdout or a folder would hang or fail
  // obscurely.
  check_updatable_file(path, "profile to create or update");
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    write_profile(path, update);
    return;
  }
  write_text_file(path, merge_profile_text(read_file_text(path), path, update));
}

HardwareModel to_hardware_model(const DeviceProfile& profile) {
  HardwareModel model;
  if (profile.accelerometer)
    apply_triad(*profile.accelerometer, "accelerometer", model.accelerometer);
  if (profile.gyroscope) {
    apply_triad(*profile.gyroscope, "gyroscope", model.gyroscope);
    if (profile.gyroscope->g_sensitivity)
      model.gyroscope.g_sensitivity = *profile.gyroscope->g_sensitivity;
  }
  if (profile.magnetometer) {
    apply_triad(*profile.magnetometer, "magnetometer", model.magnetometer);
    if (profile.magnetometer->hard_iron)
      model.magnetometer.hard_iron = *profile.magnetometer->hard_iron;
    if (profile.magnetometer->soft_iron)
      model.magnetometer.soft_iron = *profile.magnetometer->soft_iron;
  }
  if (profile.clock) {
    model.clock.error_ppm = profile.clock->error_ppm.value_or(0.0);
    model.clock.jitter_s = profile.clock->jitter_s.value_or(0.0);
  }
  return model;
}

namespace {

// draw_hardware_model's draws for one triad (sp: its profile section, null when absent).
void draw_triad(TriadModel& t, const SensorProfile* sp, const HardwareSpread& spread, Rng& rng) {
  if (sp != nullptr && sp->noise) {
    const NoiseEstimate& ne = *sp->noise;
    const auto draw = [&](Eigen::Vector3d& v, const std::optional<Eigen::Vector3d>& sigma) {
      if (!sigma) return;
      for (int k = 0; k < 3; ++k) v[k] = std::max(0.0, v[k] + (*sigma)[k] * rng.normal());
    };
    draw(t.noise_density, ne.noise_density_sigma);
    draw(t.bias_instability, ne.bias_instability_sigma);
    draw(t.random_walk, ne.random_walk_sigma);
  }
  // The factor's log is normal: 1 + spread n, the obvious draw, is zero or negative for
  // |n| >= 1 / spread (16 % of draws at the policy's largest spread of 1, 0.04 % at 0.3; found
  // in review, 2026-11-27), an axis reading backwards. exp(spread n) equals it to first order.
  for (int k = 0; k < 3; ++k) t.scale[k] *= std::exp(spread.scale * rng.normal());
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      if (r != k) t.misalignment(r, k) += spread.misalignment_rad * rng.normal();
}

}  // namespace

HardwareModel draw_hardware_model(const DeviceProfile& profile, const HardwareSpread& spread,
                                  Rng& rng) {
  HardwareModel model = to_hardware_model(profile);
  draw_triad(model.accelerometer, profile.accelerometer ? &*profile.accelerometer : nullptr, spread,
             rng);
  draw_triad(model.gyroscope, profile.gyroscope ? &*profile.gyroscope : nullptr, spread, rng);
  return model;
}

}  // namespace imukit
