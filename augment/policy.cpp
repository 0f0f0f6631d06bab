// Policies: the paper's grid, JSON (imukit.policy/1), sampling (augment/policy.hpp).
#include "imukit/augment/policy.hpp"

#include <fmt/core.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/json_text.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::augment {

using json = nlohmann::json;

namespace {

double non_negative(const json& j, const std::string& source, const std::string& path) {
  const double v = json_number(j, source, path);
  if (v < 0.0) json_fail(source, path, fmt::format("must be >= 0, got {}", v));
  return v;
}

// A number in [lo, hi] (unit for the message).
double bounded(const json& j, const std::string& source, const std::string& path, double lo,
               double hi, std::string_view unit = "") {
  const double v = json_number(j, source, path);
  if (!(v >= lo && v <= hi)) {
    json_fail(source, path,
              fmt::format("expected a number in [{:g}, {:g}]{}{}, got {:g}", lo, hi,
                          unit.empty() ? "" : " ", unit, v));
  }
  return v;
}

int integer(const json& j, const std::string& source, const std::string& path, int lo, int hi) {
  const double v = json_number(j, source, path);
  if (v != std::floor(v) || v < lo || v > hi)
    json_fail(source, path, fmt::format("expected an integer in [{}, {}], got {}", lo, hi, v));
  return static_cast<int>(v);
}

WarpMethod warp_method(const json& j, const std::string& source, const std::string& path) {
  const std::string m = json_string(j, source, path);
  if (m == "identity") return WarpMethod::identity;
  if (m == "scaling") return WarpMethod::scaling;
  if (m == "warping") return WarpMethod::warping;
  json_fail(source, path, "expected \"identity\", \"scaling\" or \"warping\", got \"" + m + "\"");
}

AmplitudeOp parse_amplitude(const json& j, const std::string& source, const std::string& path) {
  json_only_keys(j, {"method", "sigma", "knots", "joints"}, source, path);
  AmplitudeOp op;
  if (!j.contains("method")) json_fail(source, path + ".method", "missing");
  op.method = warp_method(j["method"], source, path + ".method");
  if (op.method != WarpMethod::identity) {
    if (!j.contains("sigma")) json_fail(source, path + ".sigma", "missing");
    op.sigma = bounded(j["sigma"], source, path + ".sigma", 0, PolicyLimits::max_amplitude_sigma);
  }
  if (op.method == WarpMethod::warping) {
    if (!j.contains("knots")) json_fail(source, path + ".knots", "missing");
    op.knots = integer(j["knots"], source, path + ".knots", 0, PolicyLimits::max_knots);
  }
  if (j.contains("joints")) {
    const json& js = j["joints"];
    if (!js.is_array()) json_fail(source, path + ".joints", "expected an array of joint names");
    for (std::size_t i = 0; i < js.size(); ++i)
      op.joints.push_back(json_string(js[i], source, fmt::format("{}.joints[{}]", path, i)));
  }
  return op;
}

SpeedOp parse_speed(const json& j, const std::string& source, const std::string& path) {
  json_only_keys(j, {"method", "range", "knots", "ratio"}, source, path);
  SpeedOp op;
  if (!j.contains("method")) json_fail(source, path + ".method", "missing");
  op.method = warp_method(j["method"], source, path + ".method");
  if (op.method == WarpMethod::scaling) {
    const json& r = j.contains("range") ? j["range"] : json();
    if (!r.is_array() || r.size() != 2) json_fail(source, path + ".range", "expected [lo, hi]");
    op.lo = json_number(r[0], source, path + ".range[0]");
    op.hi = json_number(r[1], source, path + ".range[1]");
    if (!(op.lo >= PolicyLimits::min_speed && op.hi >= op.lo && op.hi <= PolicyLimits::max_speed))
      json_fail(source, path + ".range",
                fmt::format("expected {:g} <= lo <= hi <= {:g} (b > 1 is faster)",
                            PolicyLimits::min_speed, PolicyLimits::max_speed));
  } else if (op.method == WarpMethod::warping) {
    if (!j.contains("knots")) json_fail(source, path + ".knots", "missing");
    if (!j.contains("ratio")) json_fail(source, path + ".ratio", "missing");
    op.knots = integer(j["knots"], source, path + ".knots", 0, PolicyLimits::max_knots);
    op.ratio = bounded(j["ratio"], source, path + ".ratio", 1, PolicyLimits::max_speed_ratio);
  }
  return op;
}

// A subject's placements from its scene file, read once per policy however many sub-policies
// name it.
using SubjectCache = std::map<std::string, SubjectPlacements>;

SubjectPlacements read_subject(const std::string& written, const std::string& base_dir,
                               SubjectCache& cache) {
  std::filesystem::path p(written);
  if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
  const auto hit = cache.find(p.string());
  if (hit != cache.end()) return hit->second;
  const sim::Scene scene = sim::read_scene(p.string());
  SubjectPlacements subject;
  subject.scene_path = written;
  for (const sim::SceneSensor& s : scene.sensors)
    subject.sensors.push_back(sim::describe_placement(s.spec.placement, scene.body, s.spec.name));
  cache.emplace(p.string(), subject);
  return subject;
}

PlacementOp parse_placement(const json& j, const std::string& source, const std::string& path,
                            const std::string& base_dir, SubjectCache& subjects) {
  json_only_keys(
      j, {"rotation_deg", "long_axis_deg", "flip", "shift", "swap_presets", "swap_subjects"},
      source, path);
  PlacementOp op;
  op.enabled = true;
  if (j.contains("rotation_deg")) {
    const json& r = j["rotation_deg"];
    if (r.is_array()) {
      if (r.size() != 3)
        json_fail(source, path + ".rotation_deg", "expected a number or 3 numbers");
      for (int k = 0; k < 3; ++k)
        op.rotation_range_rad[k] =
            non_negative(r[k], source, fmt::format("{}.rotation_deg[{}]", path, k)) * kRadPerDeg;
    } else {
      op.rotation_range_rad.setConstant(non_negative(r, source, path + ".rotation_deg") *
                                        kRadPerDeg);
    }
    if (op.rotation_range_rad.maxCoeff() > M_PI + 1e-12)
      json_fail(source, path + ".rotation_deg", "half-widths above 180 degrees");
  }
  if (j.contains("long_axis_deg")) {
    op.long_axis_range_rad =
        non_negative(j["long_axis_deg"], source, path + ".long_axis_deg") * kRadPerDeg;
    if (op.long_axis_range_rad > M_PI + 1e-12)
      json_fail(source, path + ".long_axis_deg", "half-width above 180 degrees");
  }
  if (j.contains("flip")) op.flip = json_boolean(j["flip"], source, path + ".flip");
  if (j.contains("shift")) op.shift = json_boolean(j["shift"], source, path + ".shift");
  if (j.contains("swap_presets")) {
    const json& s = j["swap_presets"];
    if (!s.is_array())
      json_fail(source, path + ".swap_presets", "expected an array of preset names");
    for (std::size_t i = 0; i < s.size(); ++i) {
      const std::string p = json_string(s[i], source, fmt::format("{}.swap_presets[{}]", path, i));
      try {
        (void)sim::placement_preset(p);
      } catch (const Error& e) {
        json_fail(source, fmt::format("{}.swap_presets[{}]", path, i), e.what());
      }
      op.swap_presets.push_back(p);
    }
  }
  if (j.contains("swap_subjects")) {
    const json& s = j["swap_subjects"];
    if (!s.is_array())
      json_fail(source, path + ".swap_subjects",
                "expected an array of scene files (imukit.scene/1)");
    for (std::size_t i = 0; i < s.size(); ++i) {
      const std::string where = fmt::format("{}.swap_subjects[{}]", path, i);
      const std::string file = json_string(s[i], source, where);
      try {
        op.swap_subjects.push_back(read_subject(file, base_dir, subjects));
      } catch (const Error& e) {
        json_fail(source, where, e.what());
      }
    }
  }
  return op;
}

HardwareOp parse_hardware(const json& j, const std::string& source, const std::string& path,
                          const std::string& base_dir) {
  json_only_keys(j,
                 {"accel_noise", "accel_bias", "gyro_noise", "gyro_bias", "profile", "scale_spread",
                  "misalignment_spread_deg"},
                 source, path);
  HardwareOp op;
  if (j.contains("profile")) {
    for (const char* k : {"accel_noise", "accel_bias", "gyro_noise", "gyro_bias"})
      if (j.contains(k)) json_fail(source, path + "." + k, "give either ranges or a profile");
    op.kind = HardwareOp::Kind::profile;
    op.profile_path = json_string(j["profile"], source, path + ".profile");
    std::filesystem::path p(op.profile_path);
    if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
    op.profile = read_profile(p.string());
    if (j.contains("scale_spread"))
      op.scale_spread = bounded(j["scale_spread"], source, path + ".scale_spread", 0,
                                PolicyLimits::max_scale_spread);
    if (j.contains("misalignment_spread_deg"))
      op.misalignment_spread_rad =
          bounded(j["misalignment_spread_deg"], source, path + ".misalignment_spread_deg", 0,
                  PolicyLimits::max_misalignment_spread_deg, "deg") *
          kRadPerDeg;
    return op;
  }
  for (const char* k : {"scale_spread", "misalignment_spread_deg"})
    if (j.contains(k)) json_fail(source, path + "." + k, "only with a profile");
  op.kind = HardwareOp::Kind::ranges;
  const auto range = [&](const char* key, double max, const char* unit) {
    return j.contains(key) ? bounded(j[key], source, path + "." + key, 0, max, unit) : 0.0;
  };
  op.accel_noise = range("accel_noise", PolicyLimits::max_accel, "m/s^2");
  op.accel_bias = range("accel_bias", PolicyLimits::max_accel, "m/s^2");
  op.gyro_noise = range("gyro_noise", PolicyLimits::max_gyro, "rad/s");
  op.gyro_bias = range("gyro_bias", PolicyLimits::max_gyro, "rad/s");
  return op;
}

json amplitude_json(const AmplitudeOp& op) {
  json j{{"method", std::string(to_string(op.method))}};
  if (op.method != WarpMethod::identity) j["sigma"] = op.sigma;
  if (op.method == WarpMethod::warping) j["knots"] = op.knots;
  if (!op.joints.empty()) j["joints"] = op.joints;
  return j;
}

json speed_json(const SpeedOp& op) {
  json j{{"method", std::string(to_string(op.method))}};
  if (op.method == WarpMethod::scaling) j["range"] = {op.lo, op.hi};
  if (op.method == WarpMethod::warping) {
    j["knots"] = op.knots;
    j["ratio"] = op.ratio;
  }
  return j;
}

json placement_json(const PlacementOp& op) {
  json j = json::object();
  j["rotation_deg"] = {op.rotation_range_rad.x() / kRadPerDeg,
                       op.rotation_range_rad.y() / kRadPerDeg,
                       op.rotation_range_rad.z() / kRadPerDeg};
  if (op.long_axis_range_rad > 0.0) j["long_axis_deg"] = op.long_axis_range_rad / kRadPerDeg;
  if (op.flip) j["flip"] = true;
  if (op.shift) j["shift"] = true;
  if (!op.swap_presets.empty()) j["swap_presets"] = op.swap_presets;
  for (const SubjectPlacements& subject : op.swap_subjects)
    j["swap_subjects"].push_back(subject.scene_path);
  return j;
}

json hardware_json(const HardwareOp& op) {
  json j = json::object();
  if (op.kind == HardwareOp::Kind::profile) {
    j["profile"] = op.profile_path;
    if (op.scale_spread > 0.0) j["scale_spread"] = op.scale_spread;
    if (op.misalignment_spread_rad > 0.0)
      j["misalignment_spread_deg"] = op.misalignment_spread_rad / kRadPerDeg;
  } else {
    j["accel_noise"] = op.accel_noise;
    j["accel_bias"] = op.accel_bias;
    j["gyro_noise"] = op.gyro_noise;
    j["gyro_bias"] = op.gyro_bias;
  }
  return j;
}

bool uniform_probabilities(const Policy& p) {
  for (double q : p.probabilities)
    if (q != p.probabilities.front()) return false;
  return true;
}

std::vector<double> uniform(std::size_t n) {
  return std::vector<double>(n, n == 0 ? 0.0 : 1.0 / static_cast<double>(n));
}

Policy parse_policy_impl(std::string_view text, const std::string& source,
                         const std::string& base_dir) {
  const json root = parse_json_text<json>(text, source);
  json_only_keys(root,
                 {"schema", "name", "description", "builtin", "sub_policies", "probabilities",
                  "stda_rotation_deg"},
                 source, "$");
  if (!root.contains("schema") || root["schema"] != std::string(kPolicySchema))
    json_fail(source, "schema", "expected \"" + std::string(kPolicySchema) + "\"");
  Policy policy;
  SubjectCache subjects;
  bool per_sub_probability = false;
  if (root.contains("builtin") == root.contains("sub_policies"))
    json_fail(source, "$", "give either \"builtin\" or \"sub_policies\"");
  if (root.contains("builtin")) {
    const std::string name = json_string(root["builtin"], source, "builtin");
    try {
      policy = builtin_policy(name);
    } catch (const Error& e) {
      json_fail(source, "builtin", e.what());
    }
  } else {
    const json& subs = root["sub_policies"];
    if (!subs.is_array() || subs.empty())
      json_fail(source, "sub_policies", "expected a non-empty array of sub-policies");
    if (subs.size() > 100000) json_fail(source, "sub_policies", "more than 100000 sub-policies");
    bool any_probability = false;
    for (std::size_t i = 0; i < subs.size(); ++i) {
      const std::string path = fmt::format("sub_policies[{}]", i);
      const json& s = subs[i];
      json_only_keys(s, {"amplitude", "speed", "placement", "hardware", "probability", "name"},
                     source, path);
      SubPolicy sp;
      if (s.contains("amplitude"))
        sp.amplitude = parse_amplitude(s["amplitude"], source, path + ".amplitude");
      if (s.contains("speed")) sp.speed = parse_speed(s["speed"], source, path + ".speed");
      if (s.contains("placement"))
        sp.placement =
            parse_placement(s["placement"], source, path + ".placement", base_dir, subjects);
      if (s.contains("hardware"))
        sp.hardware = parse_hardware(s["hardware"], source, path + ".hardware", base_dir);
      if (i > 0 && s.contains("probability") != any_probability)
        json_fail(source, path + ".probability", "give a probability for every sub-policy or none");
      any_probability = s.contains("probability");
      if (any_probability)
        policy.probabilities.push_back(
            non_negative(s["probability"], source, path + ".probability"));
      policy.sub_policies.push_back(std::move(sp));
    }
    per_sub_probability = any_probability;
    if (!any_probability) policy.probabilities = uniform(policy.sub_policies.size());
  }
  if (root.contains("name")) policy.name = json_string(root["name"], source, "name");
  if (root.contains("probabilities")) {
    if (per_sub_probability)
      json_fail(source, "probabilities", "given twice (also per sub-policy)");
    const json& p = root["probabilities"];
    if (!p.is_array() || p.size() != policy.sub_policies.size()) {
      json_fail(source, "probabilities",
                fmt::format("expected an array of {} numbers", policy.sub_policies.size()));
    }
    policy.probabilities.clear();
    for (std::size_t i = 0; i < p.size(); ++i)
      policy.probabilities.push_back(
          non_negative(p[i], source, fmt::format("probabilities[{}]", i)));
  }
  // Given probabilities are normalised to sum 1; the uniform default stays exactly 1/n.
  if (per_sub_probability || root.contains("probabilities")) {
    double sum = 0.0;
    for (double q : policy.probabilities) sum += q;
    if (!(sum > 0.0) || !std::isfinite(sum))
      json_fail(source, "probabilities", "must not all be 0 and must sum to a finite number");
    for (double& q : policy.probabilities) q /= sum;
  }
  if (root.contains("stda_rotation_deg")) {
    const double r = non_negative(root["stda_rotation_deg"], source, "stda_rotation_deg");
    if (r > 180.0) json_fail(source, "stda_rotation_deg", "half-width above 180 degrees");
    policy.stda_rotation_rad = r * kRadPerDeg;
  }
  return policy;
}

}  // namespace

std::string_view to_string(WarpMethod method) {
  switch (method) {
    case WarpMethod::identity:
      return "identity";
    case WarpMethod::scaling:
      return "scaling";
    case WarpMethod::warping:
      return "warping";
  }
  return "identity";
}

bool SubPolicy::is_identity() const {
  return amplitude.method == WarpMethod::identity && speed.method == WarpMethod::identity &&
         !placement.enabled && hardware.kind == HardwareOp::Kind::identity;
}

std::string SubPolicy::describe() const {
  std::string out = "amplitude=";
  switch (amplitude.method) {
    case WarpMethod::identity:
      out += "identity";
      break;
    case WarpMethod::scaling:
      out += fmt::format("scaling(sigma={:g})", amplitude.sigma);
      break;
    case WarpMethod::warping:
      out += fmt::format("warping(sigma={:g},K={})", amplitude.sigma, amplitude.knots);
      break;
  }
  out += " speed=";
  switch (speed.method) {
    case WarpMethod::identity:
      out += "identity";
      break;
    case WarpMethod::scaling:
      out += fmt::format("scaling([{:g},{:g}])", speed.lo, speed.hi);
      break;
    case WarpMethod::warping:
      out += fmt::format("warping(K={},r={:g})", speed.knots, speed.ratio);
      break;
  }
  out += " placement=";
  if (!placement.enabled) {
    out += "identity";
  } else {
    out += fmt::format("rotation({:g},{:g},{:g}deg", placement.rotation_range_rad.x() / kRadPerDeg,
                       placement.rotation_range_rad.y() / kRadPerDeg,
                       placement.rotation_range_rad.z() / kRadPerDeg);
    if (placement.long_axis_range_rad > 0.0)
      out += fmt::format(",long_axis={:g}deg", placement.long_axis_range_rad / kRadPerDeg);
    if (placement.flip) out += ",flip";
    if (placement.shift) out += ",shift";
    if (!placement.swap_presets.empty())
      out += fmt::format(",swap{}", placement.swap_presets.size());
    if (!placement.swap_subjects.empty())
      out += fmt::format(",subjects{}", placement.swap_subjects.size());
    out += ")";
  }
  out += " hardware=";
  switch (hardware.kind) {
    case HardwareOp::Kind::identity:
      out += "identity";
      break;
    case HardwareOp::Kind::ranges:
      out += fmt::format("ranges(accel_noise={:g},accel_bias={:g},gyro_noise={:g},gyro_bias={:g})",
                         hardware.accel_noise, hardware.accel_bias, hardware.gyro_noise,
                         hardware.gyro_bias);
      break;
    case HardwareOp::Kind::profile:
      out += "profile(" + hardware.profile_path + ")";
      break;
  }
  return out;
}

void Policy::validate() const {
  if (sub_policies.empty()) throw Error("policy " + name + ": no sub-policies");
  if (probabilities.size() != sub_policies.size()) {
    throw Error(fmt::format("policy {}: {} probabilities for {} sub-policies", name,
                            probabilities.size(), sub_policies.size()));
  }
  double sum = 0.0;
  for (double q : probabilities) {
    if (!(std::isfinite(q) && q >= 0.0))
      throw Error(fmt::format("policy {}: probability {} is not a finite number >= 0", name, q));
    sum += q;
  }
  if (!(sum > 0.0 && std::isfinite(sum)))
    throw Error("policy " + name +
                ": probabilities must not all be 0 and must sum to a finite number");
  for (std::size_t i = 0; i < sub_policies.size(); ++i) {
    const SubPolicy& s = sub_policies[i];
    const auto bad = [&](const std::string& what) {
      throw Error(fmt::format("policy {}: sub-policy {}: {}", name, i, what));
    };
    using L = PolicyLimits;
    const auto in = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
    if (!in(s.amplitude.sigma, 0, L::max_amplitude_sigma))
      bad(fmt::format("amplitude sigma outside [0, {:g}]", L::max_amplitude_sigma));
    // The parser's bounds (0 to 1000 knots), which a policy built in C++ skipped: INT_MAX
    // knots overflowed knots + 1 (review, 2026-11-27).
    if (!(s.amplitude.knots >= 0 && s.amplitude.knots <= L::max_knots && s.speed.knots >= 0 &&
          s.speed.knots <= L::max_knots))
      bad(fmt::format("knot count outside [0, {}]", L::max_knots));
    if (!(in(s.speed.lo, L::min_speed, L::max_speed) && in(s.speed.hi, s.speed.lo, L::max_speed)))
      bad(fmt::format("speed range outside {:g} <= lo <= hi <= {:g}", L::min_speed, L::max_speed));
    if (!in(s.speed.ratio, 1, L::max_speed_ratio))
      bad(fmt::format("speed ratio outside [1, {:g}]", L::max_speed_ratio));
    if (!(in(s.hardware.accel_noise, 0, L::max_accel) &&
          in(s.hardware.accel_bias, 0, L::max_accel) && in(s.hardware.gyro_noise, 0, L::max_gyro) &&
          in(s.hardware.gyro_bias, 0, L::max_gyro) &&
          in(s.hardware.scale_spread, 0, L::max_scale_spread) &&
          in(s.hardware.misalignment_spread_rad, 0, L::max_misalignment_spread_deg * kRadPerDeg)))
      bad("hardware ranges outside the limits of augment::PolicyLimits");
    // Each component: minCoeff and maxCoeff may pass over a NaN.
    const Eigen::Vector3d& r = s.placement.rotation_range_rad;
    if (!(in(r[0], 0, M_PI + 1e-12) && in(r[1], 0, M_PI + 1e-12) && in(r[2], 0, M_PI + 1e-12) &&
          in(s.placement.long_axis_range_rad, 0, M_PI + 1e-12)))
      bad("placement half-widths outside [0, 180] degrees");
    if (s.hardware.kind == HardwareOp::Kind::profile && !s.hardware.profile) bad("profile missing");
  }
}

std::vector<AmplitudeOp> paper_amplitude_options() {
  std::vector<AmplitudeOp> v(1);
  for (double s : {0.1, 0.2, 0.4, 0.6}) v.push_back({WarpMethod::scaling, s, 2, {}});
  for (double s : {0.2, 0.4})
    for (int k : {2, 4}) v.push_back({WarpMethod::warping, s, k, {}});
  return v;
}

std::vector<SpeedOp> paper_speed_options() {
  std::vector<SpeedOp> v(1);
  for (auto [lo, hi] : {std::pair{0.7, 0.9}, {1.1, 1.3}, {0.75, 1.5}, {0.5, 2.0}})
    v.push_back({WarpMethod::scaling, lo, hi, 2, 1.0});
  for (int k : {2, 4})
    for (double r : {1.5, 2.0}) v.push_back({WarpMethod::warping, 1.0, 1.0, k, r});
  return v;
}

std::vector<PlacementOp> paper_placement_options() {
  std::vector<PlacementOp> v(2);
  v[1].enabled = true;
  v[1].rotation_range_rad.setConstant(25.0 * kRadPerDeg);
  return v;
}

std::vector<HardwareOp> paper_hardware_options(bool paper_numbers) {
  std::vector<HardwareOp> v(1);
  for (double s : {0.05, 0.1, 0.15, 0.2}) {
    HardwareOp h;
    h.kind = HardwareOp::Kind::ranges;
    h.accel_noise = s;
    if (paper_numbers) {
      // The paper's shared numbers: m/s^2 and rad/s alike (seed-summary defect 6).
      h.accel_bias = 1.0;
      h.gyro_noise = s;
      h.gyro_bias = 1.0;
    } else {
      // A consumer MEMS gyroscope's white noise is ~0.01 deg/s/sqrt(Hz) (0.1 deg/s per sample at
      // 100 Hz) against ~150 ug/sqrt(Hz) for its accelerometer: a tenth of the accelerometer's
      // number in rad/s is generous but plausible; turn-on biases of +-50 mg and +-3 deg/s.
      h.accel_bias = 0.5;
      h.gyro_noise = s / 10.0;
      h.gyro_bias = 0.05;
    }
    v.push_back(h);
  }
  return v;
}

std::vector<std::string> builtin_policy_names() { return {"imukit", "paper"}; }

Policy builtin_policy(std::string_view name) {
  if (name != "imukit" && name != "paper")
    throw Error(fmt::format("unknown built-in policy '{}' (known: imukit, paper)", name));
  Policy p;
  p.name = std::string(name);
  const auto amp = paper_amplitude_options();
  const auto spd = paper_speed_options();
  const auto plc = paper_placement_options();
  const auto hw = paper_hardware_options(name == "paper");
  for (const auto& a : amp)
    for (const auto& s : spd)
      for (const auto& pl : plc)
        for (const auto& h : hw) p.sub_policies.push_back({a, s, pl, h});
  p.probabilities = uniform(p.sub_policies.size());
  return p;
}

Policy parse_policy(std::string_view text, const std::string& source, const std::string& base_dir) {
  try {
    return parse_policy_impl(text, source, base_dir);
  } catch (const json::exception& e) {
    throw Error(InputLocation{source, std::nullopt, std::nullopt, std::nullopt},
                std::string("invalid JSON: ") + e.what());
  }
}

Policy read_policy(const std::string& name_or_path) {
  for (const std::string& b : builtin_policy_names())
    if (name_or_path == b) return builtin_policy(b);
  std::string text;
  try {
    text = read_regular_file(name_or_path, kMaxJsonBytes, "policy");
  } catch (const IoError& e) {
    throw IoError(std::string(e.what()) + " (or name a built-in policy: imukit, paper)");
  }
  Policy p =
      parse_policy(text, name_or_path, std::filesystem::path(name_or_path).parent_path().string());
  if (p.name.empty()) p.name = std::filesystem::path(name_or_path).stem().string();
  return p;
}

std::string format_policy(const Policy& policy) {
  json root{{"schema", std::string(kPolicySchema)}, {"name", policy.name}};
  bool builtin = false;
  for (const std::string& b : builtin_policy_names()) {
    if (policy.sub_policies == builtin_policy(b).sub_policies) {
      root["builtin"] = b;
      if (!uniform_probabilities(policy)) root["probabilities"] = policy.probabilities;
      builtin = true;
      break;
    }
  }
  if (!builtin) {
    json subs = json::array();
    const bool uniform_p = uniform_probabilities(policy);
    for (std::size_t i = 0; i < policy.sub_policies.size(); ++i) {
      const SubPolicy& s = policy.sub_policies[i];
      json j = json::object();
      if (s.amplitude.method != WarpMethod::identity || !s.amplitude.joints.empty())
        j["amplitude"] = amplitude_json(s.amplitude);
      if (s.speed.method != WarpMethod::identity) j["speed"] = speed_json(s.speed);
      if (s.placement.enabled) j["placement"] = placement_json(s.placement);
      if (s.hardware.kind != HardwareOp::Kind::identity) j["hardware"] = hardware_json(s.hardware);
      if (!uniform_p) j["probability"] = policy.probabilities[i];
      subs.push_back(std::move(j));
    }
    root["sub_policies"] = std::move(subs);
  }
  if (policy.stda_rotation_rad != M_PI)
    root["stda_rotation_deg"] = policy.stda_rotation_rad / kRadPerDeg;
  return root.dump(2) + "\n";
}

std::size_t sample_sub_policy(const Policy& policy, Rng& rng) {
  const double u = rng.uniform();
  double sum = 0.0;
  for (double q : policy.probabilities) sum += q;
  double acc = 0.0;
  const double target = u * sum;
  for (std::size_t i = 0; i < policy.probabilities.size(); ++i) {
    acc += policy.probabilities[i];
    if (target < acc) return i;
  }
  // Rounding left target at the total: the last sub-policy with a non-zero probability.
  for (std::size_t i = policy.probabilities.size(); i-- > 0;)
    if (policy.probabilities[i] > 0.0) return i;
  return 0;
}

std::vector<StdaSpec> stda_counterparts(const SubPolicy& sub, const Policy& policy, bool normalized,
                                        double rate_hz) {
  std::vector<StdaSpec> out;
  if (sub.amplitude.method != WarpMethod::identity) {
    StdaSpec s;
    s.method = sub.amplitude.method == WarpMethod::scaling ? StdaMethod::magnitude_scaling
                                                           : StdaMethod::magnitude_warping;
    s.sigma = sub.amplitude.sigma;
    s.knots = sub.amplitude.knots;
    out.push_back(s);
  }
  if (sub.speed.method != WarpMethod::identity) {
    StdaSpec s;
    s.method = sub.speed.method == WarpMethod::scaling ? StdaMethod::time_scaling
                                                       : StdaMethod::time_warping;
    s.lo = sub.speed.lo;
    s.hi = sub.speed.hi;
    s.knots = sub.speed.knots;
    s.ratio = sub.speed.ratio;
    out.push_back(s);
  }
  if (sub.placement.enabled) {
    StdaSpec s;
    s.method = StdaMethod::rotation;
    for (double& a : s.max_angle_rad) a = policy.stda_rotation_rad;
    out.push_back(s);
  }
  if (sub.hardware.kind != HardwareOp::Kind::identity) {
    StdaSpec s;
    s.method = StdaMethod::jittering;
    if (sub.hardware.kind == HardwareOp::Kind::ranges) {
      s.jitter_sigma[0] = sub.hardware.accel_noise;
      s.jitter_sigma[1] = normalized ? sub.hardware.accel_noise : sub.hardware.gyro_noise;
      s.jitter_sigma[2] = normalized ? sub.hardware.accel_noise : 0.0;
      s.jitter_sigma[3] = normalized ? sub.hardware.accel_noise : 0.0;
    } else if (sub.hardware.profile) {
      // The device's white noise per sample at the data's rate (what PPDA's noise generator
      // draws at), else at its stated rate (100 Hz if none).
      const HardwareModel m = to_hardware_model(*sub.hardware.profile);
      const auto sigma = [rate_hz](const TriadModel& t) {
        const double rate = rate_hz > 0.0 ? rate_hz : t.rate_hz > 0.0 ? t.rate_hz : 100.0;
        return discrete_white_noise_sigma(t.noise_density.norm() / std::sqrt(3.0), rate);
      };
      s.jitter_sigma[0] = sigma(m.accelerometer);
      s.jitter_sigma[1] = sigma(m.gyroscope);
      s.jitter_sigma[2] = sigma(m.magnetometer);
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace imukit::augment
