// augment/: STDA on (N, T, C) arrays in place, policies and sub-policies, PPDA batches of a
// scene's windows over the C++ thread pool, windowing and datasets; and the seeded Rng.
#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <type_traits>

#include "common.hpp"
#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/augment/ppda.hpp"
#include "imukit/augment/stda.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::python {

// bind_sim.cpp's scene handle, shared here through its accessors: the scene and the lock to
// hold while reading it with the GIL released.
const sim::Scene& scene_of(py::handle scene);
std::mutex& scene_mutex(py::handle scene);

namespace {

using augment::BatchShape;
using augment::ChannelLayout;
using augment::Policy;
using augment::StdaSpec;
using augment::SubPolicy;

constexpr uint64_t kMaxU64 = std::numeric_limits<uint64_t>::max();

// An int seed makes a fresh Rng(seed) (any uint64, as imukit.Rng takes; a NumPy integer too,
// True not); an imukit.Rng is used (and advanced) in place.
Rng& rng_argument(py::handle obj, std::optional<Rng>& storage) {
  if (py::isinstance<Rng>(obj)) return obj.cast<Rng&>();
  if (!is_index(obj)) {
    throw py::type_error("rng: expected an int seed or an imukit.Rng, got " + type_name(obj));
  }
  storage.emplace(uint_argument(obj, "rng", kMaxU64));
  return *storage;
}

constexpr std::pair<augment::ChannelKind, const char*> kKindNames[] = {
    {augment::ChannelKind::accelerometer, "accelerometer"},
    {augment::ChannelKind::gyroscope, "gyroscope"},
    {augment::ChannelKind::magnetometer, "magnetometer"},
    {augment::ChannelKind::other, "other"}};

// layout: None (sensors of 6 channels ax ay az gx gy gz when C % 6 == 0, else C channels of
// kind other), a ChannelLayout, or a list of sensor names (ChannelLayout.imu).
ChannelLayout layout_argument(py::handle obj, std::size_t channels) {
  if (obj.is_none()) {
    if (channels % 6 == 0) {
      std::vector<std::string> names;
      for (std::size_t s = 0; s < channels / 6; ++s) names.push_back("sensor" + std::to_string(s));
      return ChannelLayout::imu(names);
    }
    ChannelLayout other;
    other.kinds.assign(channels, augment::ChannelKind::other);
    return other;
  }
  if (py::isinstance<ChannelLayout>(obj)) return obj.cast<ChannelLayout>();
  if (py::isinstance<py::str>(obj) || !py::isinstance<py::iterable>(obj)) {
    throw py::type_error(
        "layout: expected a list of sensor names or an imukit.ChannelLayout, got " +
        type_name(obj));
  }
  return ChannelLayout::imu(string_list(obj, "layout"));
}

// Rotation turns each sensor's 3-axis blocks: with none it returned x unchanged (found in
// review, 2026-11-26: a (2, 20, 3) batch, whose default layout has no sensors).
void require_triads(const StdaSpec& spec, const ChannelLayout& layout, py::handle layout_obj,
                    const char* caller) {
  if (spec.method != augment::StdaMethod::rotation || !layout.sensors.empty()) return;
  const std::string channels = std::to_string(layout.kinds.size()) + " channels";
  throw Error(std::string(caller) + ": rotation turns sensors' 3-axis blocks, and the layout " +
              (layout_obj.is_none()
                   ? "has none: the default layout of " + channels +
                         " (not sensors of 6, ax ay az gx gy gz); name the blocks with "
                         "layout=imukit.ChannelLayout(kinds, sensors)"
                   : "given has none (" + channels + ", no sensors)"));
}

// ChannelLayout(kinds, sensors): a kind name per channel and, per sensor, the first channel of
// each of its 3-axis blocks (an accelerometer-only watch: ["accelerometer"] * 3, {"watch": [0]}).
ChannelLayout make_layout(py::handle kinds_obj, py::handle sensors_obj) {
  ChannelLayout l;
  for (const std::string& k : string_list(kinds_obj, "ChannelLayout: kinds")) {
    const auto* it = std::find_if(std::begin(kKindNames), std::end(kKindNames),
                                  [&](const auto& p) { return k == p.second; });
    if (it == std::end(kKindNames)) {
      throw Error("ChannelLayout: kinds[" + std::to_string(l.kinds.size()) + "] is '" + k +
                  "', not one of accelerometer, gyroscope, magnetometer, other");
    }
    l.kinds.push_back(it->first);
  }
  if (sensors_obj.is_none()) return l;
  if (!py::isinstance<py::dict>(sensors_obj)) {
    throw py::type_error(
        "ChannelLayout: sensors: expected a dict name -> [first channel, ...], got " +
        type_name(sensors_obj));
  }
  for (auto [name_obj, triads_obj] : sensors_obj.cast<py::dict>()) {
    if (!py::isinstance<py::str>(name_obj)) {
      throw py::type_error("ChannelLayout: sensors: expected str names, got " +
                           type_name(name_obj));
    }
    augment::SensorChannels s{name_obj.cast<std::string>(), {}};
    const std::string what = "ChannelLayout: sensors['" + s.name + "']";
    if (!py::isinstance<py::iterable>(triads_obj) || py::isinstance<py::str>(triads_obj)) {
      throw py::type_error(what + ": expected a list of first channels, got " +
                           type_name(triads_obj));
    }
    for (py::handle first : triads_obj) {
      const std::string at = what + "[" + std::to_string(s.triads.size()) + "]";
      const auto c = static_cast<std::size_t>(uint_argument(first, at, kMaxU64));
      if (c + 3 > l.kinds.size()) {
        throw Error(at + ": a 3-axis block at channel " + std::to_string(c) + " is outside the " +
                    std::to_string(l.kinds.size()) + " channels");
      }
      // One block is one quantity's x, y, z: rotation turns them together.
      if (l.kinds[c + 1] != l.kinds[c] || l.kinds[c + 2] != l.kinds[c]) {
        throw Error(at + ": channels " + std::to_string(c) + " to " + std::to_string(c + 2) +
                    " are not of one kind");
      }
      s.triads.push_back(c);
    }
    l.sensors.push_back(std::move(s));
  }
  return l;
}

// dst[...] = src by numpy.copyto (any strides), without casting.
void copy_into(const py::array& dst, const py::array& src) {
  py::module_::import("numpy").attr("copyto")(dst, src, py::arg("casting") = "no");
}

// A writable C-contiguous float32/float64 (N, T, C) array.
BatchShape batch_shape(const py::array& a, const char* what) {
  if (a.ndim() != 3) {
    throw py::value_error(std::string(what) +
                          ": expected shape (windows, samples, channels), got " + shape_string(a));
  }
  return {static_cast<std::size_t>(a.shape(0)), static_cast<std::size_t>(a.shape(1)),
          static_cast<std::size_t>(a.shape(2))};
}

void require_writable_batch(const py::array& a, const char* what) {
  if (!is_c_contiguous(a)) throw py::value_error(std::string(what) + ": must be C-contiguous");
  if (!a.writeable()) throw py::value_error(std::string(what) + ": is read-only");
}

// The target of an in-place method: `out` itself when given (x is copied into it unless it is
// x), else a new array of x's dtype and shape holding a copy of x. The C++ code then works on
// the target's memory directly.
py::array target_for(const py::array& x_in, py::handle out_obj, const char* what) {
  const py::array x = native_float(x_in, what);
  if (out_obj.is(x_in) && !x.is(x_in)) {
    throw py::type_error(std::string(what) + ": an array of dtype " + dtype_name(x_in) +
                         " (another byte order) cannot be augmented in place; leave out=None");
  }
  batch_shape(x, what);
  if (out_obj.is_none()) {
    py::array out(x.dtype(), std::vector<py::ssize_t>(x.shape(), x.shape() + x.ndim()));
    copy_into(out, x);
    return out;
  }
  py::array out = as_array(out_obj, "out");
  // By value (has_type): an unpickled float32 was "dtype float32 differs from the input's
  // float32" (found in review, 2026-11-27).
  if (!(is_f32(out) && is_f32(x)) && !(is_f64(out) && is_f64(x))) {
    throw py::type_error("out: dtype " + dtype_name(out) + " differs from the input's " +
                         dtype_name(x));
  }
  if (shape_string(out) != shape_string(x)) {
    throw py::value_error("out: shape " + shape_string(out) + " differs from the input's " +
                          shape_string(x));
  }
  require_writable_batch(out, "out");
  if (out.data() != x.data()) {
    copy_into(out, x);
  }
  return out;
}

// The keyword parameters each STDA method reads (augment/stda.hpp, StdaSpec).
std::vector<std::string_view> parameters_of(augment::StdaMethod method) {
  using augment::StdaMethod;
  switch (method) {
    case StdaMethod::identity:
      return {};
    case StdaMethod::magnitude_scaling:
      return {"sigma", "per_channel"};
    case StdaMethod::magnitude_warping:
      return {"sigma", "knots", "per_channel"};
    case StdaMethod::time_scaling:
      return {"lo", "hi"};
    case StdaMethod::time_warping:
      return {"knots", "ratio"};
    case StdaMethod::rotation:
      return {"max_angle_rad"};
    case StdaMethod::jittering:
      return {"jitter_sigma"};
  }
  return {};
}

bool known_parameter(const std::string& key) {
  for (const char* k :
       {"sigma", "knots", "per_channel", "lo", "hi", "ratio", "max_angle_rad", "jitter_sigma"})
    if (key == k) return true;
  return false;
}

std::string unused_parameter_message(augment::StdaMethod method, const std::string& key,
                                     const std::vector<std::string_view>& takes) {
  std::string list;
  for (const std::string_view t : takes) list += (list.empty() ? "" : ", ") + std::string(t);
  std::string message = "stda: " + std::string(augment::to_string(method)) + " does not use '" +
                        key + "' (it takes " + (list.empty() ? "no parameters" : list) + ")";
  if (method == augment::StdaMethod::jittering && key == "sigma")
    message += "; its noise is jitter_sigma=[accelerometer, gyroscope, magnetometer, other]";
  return message;
}

// A StdaSpec, or a method name with its parameters as keywords, each converted here so that a
// wrong type names the parameter (found in review: sigma="0.1" was "Unable to cast ... to C++
// type 'double'").
StdaSpec spec_from(py::handle obj, const py::kwargs& params) {
  StdaSpec s;
  if (py::isinstance<StdaSpec>(obj)) {
    if (params.size() != 0)
      throw py::type_error("stda: parameters go into the StdaSpec, not beside it");
    return obj.cast<StdaSpec>();
  }
  if (!py::isinstance<py::str>(obj)) {
    throw py::type_error("stda: spec: expected an imukit.StdaSpec or a method name, got " +
                         type_name(obj));
  }
  s.method = augment::parse_stda_method(obj.cast<std::string>());
  const std::vector<std::string_view> takes = parameters_of(s.method);
  for (auto [key_obj, value] : params) {
    const auto key = key_obj.cast<std::string>();
    const std::string what = "stda: " + key;
    // A parameter the method does not use was taken and ignored: stda(x, "jittering", seed,
    // sigma=0.2) added no noise at all (found in review, 2026-11-27).
    if (known_parameter(key) && std::find(takes.begin(), takes.end(), key) == takes.end())
      throw py::type_error(unused_parameter_message(s.method, key, takes));
    if (key == "sigma") {
      s.sigma = number_argument(value, what);
    } else if (key == "knots") {
      // Beyond int's range is refused as such, not wrapped; StdaSpec::validate bounds it.
      s.knots = static_cast<int>(uint_argument(value, what, std::numeric_limits<int>::max()));
    } else if (key == "per_channel") {
      if (!PyBool_Check(value.ptr()))
        throw py::type_error(what + ": expected a bool, got " + type_name(value));
      s.per_channel = value.cast<bool>();
    } else if (key == "lo") {
      s.lo = number_argument(value, what);
    } else if (key == "hi") {
      s.hi = number_argument(value, what);
    } else if (key == "ratio") {
      s.ratio = number_argument(value, what);
    } else if (key == "max_angle_rad") {
      const std::vector<double> a = numbers(value, 3, what.c_str());
      std::copy(a.begin(), a.end(), s.max_angle_rad);
    } else if (key == "jitter_sigma") {
      const std::vector<double> j = numbers(value, 4, what.c_str());
      std::copy(j.begin(), j.end(), s.jitter_sigma);
    } else {
      throw py::type_error(
          "stda: unknown parameter '" + key +
          "' (sigma, knots, per_channel, lo, hi, ratio, max_angle_rad, jitter_sigma)");
    }
  }
  return s;
}

// What stda(..., return_draws=True) returns: the drawn parameters with the method that drew
// them, which replay_stda checks (found in review, 2026-11-26: a bare array carried no method,
// and the binding gave it the spec's, so draws of another method were replayed).
struct DrawsHandle {
  augment::StdaDraws draws;
  std::size_t windows = 0;
};

// Read-only: replay_stda reads this memory, and a value written through the view changed what
// it replayed (found in review, 2026-11-27), as a Series' views once did.
py::array draws_values(const py::object& self) {
  const auto& h = self.cast<const DrawsHandle&>();
  const auto per = static_cast<py::ssize_t>(h.draws.per_window);
  return read_only(view_of(h.draws.values.data(), {static_cast<py::ssize_t>(h.windows), per},
                           {per * static_cast<py::ssize_t>(sizeof(double)), sizeof(double)}, self));
}

template <class T>
void run_stda(const StdaSpec& spec, const ChannelLayout& layout, py::array& target,
              const BatchShape& shape, Rng& rng, augment::StdaDraws* draws) {
  const std::span<T> data(static_cast<T*>(target.mutable_data()), shape.size());
  py::gil_scoped_release release;
  augment::apply_stda(spec, layout, data, shape, rng, draws);
}

py::object stda(py::handle x_obj, py::handle spec_obj, py::handle rng_obj, py::handle layout_obj,
                py::handle out_obj, bool return_draws, const py::kwargs& params) {
  const py::array x = as_array(x_obj, "x");
  const StdaSpec spec = spec_from(spec_obj, params);
  std::optional<Rng> storage;
  Rng& rng = rng_argument(rng_obj, storage);
  const BatchShape shape = batch_shape(x, "x");
  const ChannelLayout layout = layout_argument(layout_obj, shape.channels);
  require_triads(spec, layout, layout_obj, "stda");
  py::array target = target_for(x, out_obj, "x");
  auto draws = std::make_shared<DrawsHandle>();
  draws->windows = shape.windows;
  augment::StdaDraws* log = return_draws ? &draws->draws : nullptr;
  // The element type from the target's dtype by value; anything else is refused, not taken for
  // double (found in review, 2026-11-27: an unpickled float32 ran as double, heap corruption).
  if (is_f32(target)) {
    run_stda<float>(spec, layout, target, shape, rng, log);
  } else if (is_f64(target)) {
    run_stda<double>(spec, layout, target, shape, rng, log);
  } else {
    throw py::type_error("x: expected float32 or float64, got " + dtype_name(target));
  }
  if (!return_draws) return target;
  return py::make_tuple(target, draws);
}

py::array replay(py::handle x_obj, const StdaSpec& spec, py::handle draws_obj,
                 py::handle layout_obj, py::handle out_obj) {
  const py::array x = as_array(x_obj, "x");
  if (!py::isinstance<DrawsHandle>(draws_obj)) {
    throw py::type_error(
        "replay_stda: draws: expected the imukit.StdaDraws of stda(..., return_draws=True) or "
        "imukit.StdaDraws(method, values), got " +
        type_name(draws_obj));
  }
  const DrawsHandle& d = draws_obj.cast<const DrawsHandle&>();
  if (d.draws.method != spec.method) {
    throw Error("replay_stda: the draws are of " + std::string(augment::to_string(d.draws.method)) +
                ", the spec is " + spec.describe());
  }
  const BatchShape shape = batch_shape(x, "x");
  if (d.windows != shape.windows) {
    throw Error("replay_stda: the draws are for " + std::to_string(d.windows) + " windows x " +
                std::to_string(d.draws.per_window) + " draws, x has " +
                std::to_string(shape.windows) + " windows");
  }
  const ChannelLayout layout = layout_argument(layout_obj, shape.channels);
  require_triads(spec, layout, layout_obj, "replay_stda");
  py::array target = target_for(x, out_obj, "x");
  if (is_f32(target)) {
    const std::span<float> data(static_cast<float*>(target.mutable_data()), shape.size());
    py::gil_scoped_release release;
    augment::replay_stda(spec, layout, data, shape, d.draws);
  } else if (!is_f64(target)) {
    throw py::type_error("x: expected float32 or float64, got " + dtype_name(target));
  } else {
    const std::span<double> data(static_cast<double*>(target.mutable_data()), shape.size());
    py::gil_scoped_release release;
    augment::replay_stda(spec, layout, data, shape, d.draws);
  }
  return target;
}

// A sub-policy in the policy file's layout ({"amplitude": {...}, "speed": ...}).
SubPolicy sub_policy_from_dict(const py::dict& d, const std::string& base_dir) {
  py::dict root;
  root["schema"] = std::string(augment::kPolicySchema);
  root["name"] = "python";
  py::list subs;
  subs.append(d);
  root["sub_policies"] = subs;
  const std::string text = py::module_::import("json").attr("dumps")(root).cast<std::string>();
  return augment::parse_policy(text, "<sub-policy dict>", base_dir).sub_policies.front();
}

// The augmenter with the scene it was built from, and a lock: apply() reuses per-augmenter
// workspaces, and the GIL is released while it runs.
struct AugmenterHandle {
  py::object scene;  // kept alive: the augmenter was built from it
  std::unique_ptr<augment::PpdaAugmenter> augmenter;
  std::mutex mutex;
};

// sub: a SubPolicy, a dict in the policy layout, an index into `policy`, or a description
// string equal to one of `policy`'s sub-policies' describe().
// The index of the one sub-policy of `policy` whose describe() is `description`. describe()
// leaves out what it cannot print briefly (amplitude joints, swapped presets and subjects,
// profile spreads) and rounds numbers, so two sub-policies can share a description: that is an
// error naming both, not the first of them (review, 2026-11-27).
std::size_t sub_policy_described(const Policy& policy, const std::string& description,
                                 const std::string& who) {
  std::vector<std::size_t> found;
  for (std::size_t i = 0; i < policy.sub_policies.size(); ++i)
    if (policy.sub_policies[i].describe() == description) found.push_back(i);
  if (found.empty())
    throw Error(who + "no sub-policy of policy '" + policy.name + "' is described as '" +
                description + "'");
  if (found.size() > 1) {
    std::string indices;
    for (const std::size_t i : found) indices += (indices.empty() ? "" : ", ") + std::to_string(i);
    throw Error(who + "sub-policies " + indices + " of policy '" + policy.name +
                "' are all described as '" + description + "': give the index");
  }
  return found[0];
}

// Augmenter.apply's too_short=: None, or a writable C-contiguous bool array of one flag per
// window, which apply fills (augment::PpdaAugmenter::apply).
std::span<uint8_t> too_short_flags(py::handle obj, py::ssize_t n) {
  if (obj.is_none()) return {};
  const py::array a = as_array(obj, "too_short");
  if (!is_bool(a)) throw py::type_error("too_short: expected a bool array, got " + dtype_name(a));
  if (a.ndim() != 1 || a.shape(0) != n) {
    throw py::value_error("too_short: expected shape (" + std::to_string(n) + ",), got " +
                          shape_string(a));
  }
  require_writable_batch(a, "too_short");
  static_assert(sizeof(bool) == sizeof(uint8_t));
  return {static_cast<uint8_t*>(const_cast<void*>(a.data())), static_cast<std::size_t>(n)};
}

py::array ppda_apply(AugmenterHandle& h, py::handle sub, py::handle starts_obj, py::handle rng_obj,
                     const Policy* policy, py::handle out_obj, unsigned threads,
                     py::handle too_short_obj) {
  augment::PpdaAugmenter& a = *h.augmenter;
  const auto starts_arr = read_int64(starts_obj, "starts", "sample indices");
  const std::span<const int64_t> starts(starts_arr.data(),
                                        static_cast<std::size_t>(starts_arr.size()));
  const auto n = static_cast<py::ssize_t>(starts.size());
  const auto window = static_cast<py::ssize_t>(a.window());
  const auto channels = static_cast<py::ssize_t>(a.channels());
  py::array out;
  if (out_obj.is_none()) {
    out = py::array_t<float>({n, window, channels});
  } else {
    out = as_array(out_obj, "out");
    if (!is_f32(out)) throw py::type_error("out: PPDA writes float32, got " + dtype_name(out));
    if (out.ndim() != 3 || out.shape(0) != n || out.shape(1) != window ||
        out.shape(2) != channels) {
      throw py::value_error("out: expected shape (" + std::to_string(n) + ", " +
                            std::to_string(window) + ", " + std::to_string(channels) + "), got " +
                            shape_string(out));
    }
    require_writable_batch(out, "out");
  }
  const std::span<float> data(static_cast<float*>(out.mutable_data()),
                              static_cast<std::size_t>(n * window * channels));
  const std::span<uint8_t> too_short = too_short_flags(too_short_obj, n);
  std::optional<Rng> storage;
  Rng& rng = rng_argument(rng_obj, storage);
  std::optional<SubPolicy> chosen;
  std::optional<std::size_t> index;
  if (py::isinstance<SubPolicy>(sub)) {
    chosen = sub.cast<SubPolicy>();
  } else if (py::isinstance<py::dict>(sub)) {
    chosen = sub_policy_from_dict(sub.cast<py::dict>(), ".");
  } else if (is_index(sub) || py::isinstance<py::str>(sub)) {
    if (policy == nullptr)
      throw py::value_error("Augmenter.apply: a sub-policy index or description needs policy=");
    if (is_index(sub)) {
      // operator.index: a NumPy integer too (found in review, 2026-11-26: np.int64(2) refused)
      const std::size_t n = policy->sub_policies.size();  // at least 1 (parse_policy)
      const py::int_ i = index_argument(sub, "Augmenter.apply: sub");
      if (i < py::int_(0) || i >= py::int_(n)) {
        throw py::index_error("Augmenter.apply: sub: " + py::repr(i).cast<std::string>() +
                              " is not a sub-policy index of policy '" + policy->name + "' (0 to " +
                              std::to_string(n - 1) + ")");
      }
      index = i.cast<std::size_t>();
    } else {
      index = sub_policy_described(*policy, sub.cast<std::string>(), "Augmenter.apply: ");
    }
  } else {
    throw py::type_error(
        "Augmenter.apply: sub must be a SubPolicy, a dict, an index or a description, got " +
        type_name(sub));
  }
  {
    py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(h.mutex);
    a.apply(index ? policy->sub_policies[*index] : *chosen, starts, rng, data, threads, nullptr,
            too_short);
    if (out_obj.is_none()) {
      // A new array has no rows "as they were": a flagged window's are NaN (found in review,
      // 2026-11-26: they held whatever the allocation did).
      const auto rows = static_cast<std::size_t>(window * channels);
      for (std::size_t k = 0; k < too_short.size(); ++k) {
        if (too_short[k] != 0) {
          std::fill_n(data.begin() + static_cast<std::ptrdiff_t>(k * rows), rows,
                      std::numeric_limits<float>::quiet_NaN());
        }
      }
    }
  }
  return out;
}

// Python's DatasetOptions: the C++ defaults, except threads = 0 (all cores) as everywhere in the
// package; the output does not depend on it.
augment::DatasetOptions python_dataset_options() {
  augment::DatasetOptions o;
  o.threads = 0;
  return o;
}

// Sets o's fields named by the keywords through the bound properties (their type checks and
// conversions); a name that is not a field raises TypeError naming `caller`.
void set_dataset_fields(augment::DatasetOptions& o, const py::kwargs& fields, const char* caller) {
  const py::object self = py::cast(&o, py::return_value_policy::reference);
  const py::object type = py::type::of(self);
  const py::object property = py::module_::import("builtins").attr("property");
  for (auto [key, value] : fields) {
    const auto name = key.cast<std::string>();
    if (!py::hasattr(type, name.c_str()) || !py::isinstance(type.attr(name.c_str()), property))
      throw py::type_error(std::string(caller) + ": unexpected keyword argument '" + name +
                           "' (not a DatasetOptions field)");
    py::setattr(self, name.c_str(), value);
  }
}

// Seconds per call of `call`, `repeats` times, measured inside C++ (python/bench/overhead.py
// compares them with the same call made from Python).
template <class Call>
std::vector<double> time_calls(int repeats, Call&& call) {
  std::vector<double> seconds;
  py::gil_scoped_release release;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    call();
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return seconds;
}

// Class labels: int64, each a class index >= 0 or -1 (kNoLabel) for none; below -1 was taken
// and written as a class (found in review, 2026-11-26).
py::array_t<int64_t, py::array::c_style> read_labels(py::handle obj) {
  auto a = read_int64(obj, "labels", "class labels");
  const int64_t* v = a.data();
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (v[i] < augment::kNoLabel) {
      throw Error("labels[" + std::to_string(i) + "] is " + std::to_string(v[i]) +
                  "; a label is a class index >= 0, or -1 for none");
    }
  }
  return a;
}

std::vector<int64_t> labels_argument(py::handle obj) {
  if (obj.is_none()) return {};
  const auto a = read_labels(obj);
  return {a.data(), a.data() + a.size()};
}

}  // namespace

void bind_augment(py::module_& m) {
  py::class_<Rng>(m, "Rng", R"doc(
imukit's portable seeded generator (xoshiro256++): the same seed gives the same draws on every
platform. Rng(seed, stream=0); child(i) is an independent generator for index i.)doc")
      .def(py::init([](py::handle seed, py::handle stream) {
             return Rng(uint_argument(seed, "Rng: seed", kMaxU64),
                        uint_argument(stream, "Rng: stream", kMaxU64));
           }),
           py::arg("seed"), py::arg("stream") = 0)
      .def(
          "child",
          [](const Rng& r, py::handle index) {
            // Not pybind11's caster: it took True as index 1 (found in review, 2026-11-27).
            return r.child(uint_argument(index, "Rng.child: index", kMaxU64));
          },
          py::arg("index"))
      .def("next_u64", &Rng::next_u64)
      .def("uniform", py::overload_cast<>(&Rng::uniform))
      .def("normal", py::overload_cast<>(&Rng::normal))
      .def_property_readonly("seed", &Rng::seed)
      .def_property_readonly("stream", &Rng::stream);

  py::class_<ChannelLayout>(m, "ChannelLayout", R"doc(
Channel kinds and the sensors' 3-axis blocks of an (N, T, C) batch. ChannelLayout.imu(names):
per sensor ax ay az gx gy gz (the dataset layout). ChannelLayout(kinds, sensors=None): kinds
names each channel's quantity ("accelerometer", "gyroscope", "magnetometer", "other"; it
selects the jitter sigma), sensors maps a name to the first channel of each of its 3-axis
blocks, which rotation turns together: ChannelLayout(["accelerometer"] * 3, {"watch": [0]}) is
an accelerometer-only watch.)doc")
      .def(py::init(&make_layout), py::arg("kinds"), py::arg("sensors") = py::none())
      .def_static(
          "imu",
          [](py::handle names) {
            return ChannelLayout::imu(string_list(names, "ChannelLayout.imu: sensor_names"));
          },
          py::arg("sensor_names"))
      .def_property_readonly("channels", [](const ChannelLayout& l) { return l.kinds.size(); })
      .def_property_readonly("kinds",
                             [](const ChannelLayout& l) {
                               std::vector<std::string> out;
                               for (augment::ChannelKind k : l.kinds) {
                                 for (const auto& [kind, name] : kKindNames)
                                   if (k == kind) out.push_back(name);
                               }
                               return out;
                             })
      .def_property_readonly("sensors", [](const ChannelLayout& l) {
        std::vector<std::string> out;
        for (const auto& s : l.sensors) out.push_back(s.name);
        return out;
      });

  py::class_<DrawsHandle, std::shared_ptr<DrawsHandle>>(m, "StdaDraws", R"doc(
The parameters an STDA method drew (stda(..., return_draws=True)) with the method that drew
them: values (windows, per_window) float64 (a view), method, windows, per_window; np.asarray
and indexing go to values. replay_stda checks the method and the window count.
StdaDraws(method, values) rebuilds one from saved values.)doc")
      .def(py::init([](const std::string& method, py::handle values_obj) {
             const auto v = read_f64(values_obj, "StdaDraws: values");
             if (v.ndim() != 2) {
               throw py::value_error(
                   "StdaDraws: values: expected shape (windows, per_window), got " +
                   shape_string(v));
             }
             // Draws are finite: a NaN or infinity replayed into NaN or inf windows without a word
             // (found in review, 2026-11-27).
             for (py::ssize_t i = 0; i < v.size(); ++i) {
               const double x = v.data()[i];
               if (std::isfinite(x)) continue;
               const char* shown = std::isnan(x) ? "nan" : x > 0 ? "inf" : "-inf";
               throw Error("StdaDraws: values[" + std::to_string(i / v.shape(1)) + ", " +
                           std::to_string(i % v.shape(1)) + "] is " + shown +
                           "; draws are finite numbers");
             }
             auto h = std::make_shared<DrawsHandle>();
             h->draws.method = augment::parse_stda_method(method);
             h->draws.per_window = static_cast<std::size_t>(v.shape(1));
             h->draws.values.assign(v.data(), v.data() + v.size());
             h->windows = static_cast<std::size_t>(v.shape(0));
             return h;
           }),
           py::arg("method"), py::arg("values"))
      .def_property_readonly(
          "method",
          [](const DrawsHandle& h) { return std::string(augment::to_string(h.draws.method)); })
      .def_property_readonly("values", &draws_values)
      .def_property_readonly("windows", [](const DrawsHandle& h) { return h.windows; })
      .def_property_readonly("per_window", [](const DrawsHandle& h) { return h.draws.per_window; })
      .def_property_readonly(
          "shape",
          [](const DrawsHandle& h) { return py::make_tuple(h.windows, h.draws.per_window); })
      .def("__len__", [](const DrawsHandle& h) { return h.windows; })
      .def("__getitem__",
           [](const py::object& self, const py::object& key) -> py::object {
             return draws_values(self).attr("__getitem__")(key);
           })
      .def(
          "__array__",
          [](const py::object& self, const py::object& dtype, const py::object&) {
            const py::array v = draws_values(self);
            return dtype.is_none() ? v : py::array(v.attr("astype")(dtype));
          },
          py::arg("dtype") = py::none(), py::arg("copy") = py::none())
      .def("__repr__", [](const DrawsHandle& h) {
        return "<imukit.StdaDraws " + std::string(augment::to_string(h.draws.method)) + ": " +
               std::to_string(h.windows) + " windows x " + std::to_string(h.draws.per_window) + ">";
      });

  py::class_<StdaSpec>(m, "StdaSpec", R"doc(
One STDA method with its parameters: StdaSpec(method, sigma=0, knots=2, per_channel=False,
lo=1, hi=1, ratio=1, max_angle_rad=(pi, pi, pi), jitter_sigma=(accel, gyro, mag, other)).
Methods: identity, magnitude_scaling, magnitude_warping, time_scaling, time_warping, rotation,
jittering.)doc")
      .def(py::init([](const std::string& method, const py::kwargs& params) {
             StdaSpec s = spec_from(py::str(method), params);
             s.validate();
             return s;
           }),
           py::arg("method"))
      .def_property_readonly(
          "method", [](const StdaSpec& s) { return std::string(augment::to_string(s.method)); })
      .def_readonly("sigma", &StdaSpec::sigma)
      .def_readonly("knots", &StdaSpec::knots)
      .def_readonly("per_channel", &StdaSpec::per_channel)
      .def_readonly("lo", &StdaSpec::lo)
      .def_readonly("hi", &StdaSpec::hi)
      .def_readonly("ratio", &StdaSpec::ratio)
      .def("describe", &StdaSpec::describe)
      .def("__repr__", [](const StdaSpec& s) { return "<imukit.StdaSpec " + s.describe() + ">"; });

  m.def("stda", &stda, py::arg("x"), py::arg("spec"), py::arg("rng"), py::kw_only(),
        py::arg("layout") = py::none(), py::arg("out") = py::none(),
        py::arg("return_draws") = false, R"doc(
Applies an STDA method to every window of x, an (N, T, C) float32 or float64 batch.
spec: a StdaSpec, or a method name with its parameters as keywords (stda(x, "jittering",
seed, jitter_sigma=(0.05, 0.01, 0, 0))). rng: an int seed or an imukit.Rng (advanced in place).
layout: sensor names or a ChannelLayout (default: sensors of 6 channels when C % 6 == 0).
The C++ code works directly on the output's memory: out=None returns a new array (a copy of x,
augmented), out=x augments x in place, out=other (same dtype and shape, C-contiguous) fills it.
return_draws=True also returns the drawn parameters (an imukit.StdaDraws: (N, per_window)
float64 values and the method) for replay_stda. rotation needs sensors' 3-axis blocks in the
layout (an error otherwise).)doc");
  m.def("replay_stda", &replay, py::arg("x"), py::arg("spec"), py::arg("draws"), py::kw_only(),
        py::arg("layout") = py::none(), py::arg("out") = py::none(),
        "Applies spec with the parameters drawn before (the StdaDraws of stda(..., "
        "return_draws=True), of the same method and window count): bit-identical.");

  py::class_<SubPolicy>(m, "SubPolicy", R"doc(
One PPDA sub-policy: an option for each of movement amplitude, movement speed, sensor
placement and hardware. SubPolicy.from_dict(d) reads the policy file's layout.)doc")
      .def_static("from_dict", &sub_policy_from_dict, py::arg("d"), py::arg("base_dir") = ".")
      .def("describe", &SubPolicy::describe)
      .def_property_readonly("is_identity", &SubPolicy::is_identity)
      .def("__eq__", [](const SubPolicy& a, const SubPolicy& b) { return a == b; })
      .def("__repr__",
           [](const SubPolicy& s) { return "<imukit.SubPolicy " + s.describe() + ">"; });

  py::class_<Policy>(m, "Policy", R"doc(
A list of sub-policies with sampling probabilities: read_policy("imukit" | "paper" | FILE).
len(policy), policy[i] (SubPolicy), describe() (one string per sub-policy), probabilities,
sample(rng) (an index drawn with the probabilities), stda_counterparts(i, normalized=False,
rate_hz=0) (see augment/policy.hpp: jittering last, a profile's sigmas at rate_hz).)doc")
      .def_readonly("name", &Policy::name)
      .def("__len__", [](const Policy& p) { return p.sub_policies.size(); })
      .def("__getitem__",
           [](const Policy& p, py::handle index) {
             // Through index_argument: Policy[True] was sub-policy 1 (found in review,
             // 2026-11-27).
             py::int_ i = index_argument(index, "Policy: index");
             const py::int_ n(p.sub_policies.size());
             if (i < py::int_(0))
               i = py::reinterpret_steal<py::int_>(PyNumber_Add(i.ptr(), n.ptr()));
             if (i < py::int_(0) || i >= n) throw py::index_error("sub-policy index out of range");
             return p.sub_policies[i.cast<std::size_t>()];
           })
      .def_property_readonly("sub_policies", [](const Policy& p) { return p.sub_policies; })
      .def_property_readonly(
          "probabilities",
          [](const Policy& p) { return adopt(std::vector<double>(p.probabilities)); })
      .def("describe",
           [](const Policy& p) {
             std::vector<std::string> out;
             for (const SubPolicy& s : p.sub_policies) out.push_back(s.describe());
             return out;
           })
      .def(
          "index",
          [](const Policy& p, const std::string& description) {
            return sub_policy_described(p, description, "");
          },
          py::arg("description"))
      .def(
          "sample",
          [](const Policy& p, py::handle rng_obj) {
            std::optional<Rng> storage;
            return augment::sample_sub_policy(p, rng_argument(rng_obj, storage));
          },
          py::arg("rng"))
      .def(
          "stda_counterparts",
          [](const Policy& p, std::size_t i, bool normalized, double rate_hz) {
            if (i >= p.sub_policies.size()) throw py::index_error("sub-policy index out of range");
            return augment::stda_counterparts(p.sub_policies[i], p, normalized, rate_hz);
          },
          py::arg("index"), py::arg("normalized") = false, py::arg("rate_hz") = 0.0)
      .def("to_json", &augment::format_policy);
  m.def("read_policy", &augment::read_policy, py::arg("name_or_path"),
        py::call_guard<py::gil_scoped_release>(),
        "A built-in policy (\"imukit\", \"paper\") or a policy JSON file.");
  m.def("parse_policy", &augment::parse_policy, py::arg("text"),
        py::arg("source_name") = "<string>", py::arg("base_dir") = ".",
        py::call_guard<py::gil_scoped_release>());
  m.def("builtin_policy_names", &augment::builtin_policy_names);

  py::class_<AugmenterHandle, std::shared_ptr<AugmenterHandle>>(m, "Augmenter", R"doc(
PPDA on a scene: Augmenter(scene, window=100, method="spline") compiles the scene once; then
apply(sub, starts, rng, policy=None, out=None, threads=0, too_short=None) simulates the windows
starting at `starts` (sample indices, e.g. window_starts(stride)) under one sub-policy and
returns an (N, window, 6 x sensors) float32 array (channels ax ay az gx gy gz per sensor). sub:
a SubPolicy, a dict in the policy layout, or an index / description of a sub-policy of `policy`.
A window sped up beyond what the scene's motion can give raises imukit.Error; with too_short (a
bool array of N) it is flagged there and its rows of out left as they were (NaN without out). The windows are
spread over `threads` C++ threads (0: all cores) with the GIL released; the result does not
depend on the thread count.)doc")
      .def(py::init([](py::handle scene, py::handle window, const std::string& method) {
             augment::PpdaOptions o;
             o.window = window_argument(window, "Augmenter: window");
             o.method = sim::parse_derivative_method(method);
             auto h = std::make_shared<AugmenterHandle>();
             const sim::Scene& s = scene_of(scene);
             std::mutex& scene_lock = scene_mutex(scene);
             h->scene = py::reinterpret_borrow<py::object>(scene);
             py::gil_scoped_release release;
             // Taken after the GIL is let go (add_sensor holds the lock and wants the GIL).
             const std::lock_guard<std::mutex> lock(scene_lock);
             h->augmenter = std::make_unique<augment::PpdaAugmenter>(s, o);
             return h;
           }),
           py::arg("scene"), py::arg("window") = 100, py::arg("method") = "spline")
      .def_property_readonly("window",
                             [](const AugmenterHandle& h) { return h.augmenter->window(); })
      .def_property_readonly("channels",
                             [](const AugmenterHandle& h) { return h.augmenter->channels(); })
      .def_property_readonly("layout",
                             [](const AugmenterHandle& h) { return h.augmenter->layout(); })
      .def_property_readonly("sensor_names",
                             [](const AugmenterHandle& h) { return h.augmenter->sensor_names(); })
      .def_property_readonly("rate_hz",
                             [](const AugmenterHandle& h) { return h.augmenter->rate_hz(); })
      .def_property_readonly("sample_count",
                             [](const AugmenterHandle& h) { return h.augmenter->sample_count(); })
      .def(
          "window_starts",
          [](const AugmenterHandle& h, py::handle stride) {
            return adopt(h.augmenter->window_starts(
                stride_argument(stride, "Augmenter.window_starts: stride")));
          },
          py::arg("stride"))
      .def(
          "apply",
          [](AugmenterHandle& h, py::handle sub, py::handle starts, py::handle rng,
             const Policy* policy, py::handle out, unsigned threads, py::handle too_short) {
            return ppda_apply(h, sub, starts, rng, policy, out, threads, too_short);
          },
          py::arg("sub"), py::arg("starts"), py::arg("rng"), py::kw_only(),
          py::arg("policy") = nullptr, py::arg("out") = py::none(), py::arg("threads") = 0,
          py::arg("too_short") = py::none());

  // The same work as Augmenter.apply / stda(out=x), looped and timed in C++ (no Python between
  // calls): the baseline of the call-overhead benchmark.
  py::module_ bench =
      m.def_submodule("_bench", "C++-side timing loops for python/bench/overhead.py");
  bench.def(
      "ppda_seconds", [](AugmenterHandle& h, const Policy& policy, std::size_t k,
                         py::handle starts_obj, uint64_t seed, unsigned threads, int repeats) {
        const auto starts_arr = read_int64(starts_obj, "starts", "sample indices");
        const std::span<const int64_t> starts(starts_arr.data(),
                                              static_cast<std::size_t>(starts_arr.size()));
        std::vector<float> out(starts.size() * h.augmenter->window() * h.augmenter->channels());
        return time_calls(repeats, [&] {
          Rng rng(seed);
          const std::lock_guard<std::mutex> lock(h.mutex);
          h.augmenter->apply(policy, k, starts, rng, out, threads);
        });
      });
  bench.def("stda_seconds", [](py::array x, const StdaSpec& spec, uint64_t seed, int repeats) {
    require_writable_batch(x, "x");
    if (!is_f32(x)) throw py::type_error("x: float32 expected");
    const BatchShape shape = batch_shape(x, "x");
    const ChannelLayout layout = layout_argument(py::none(), shape.channels);
    const std::span<float> data(static_cast<float*>(x.mutable_data()), shape.size());
    return time_calls(repeats, [&] {
      Rng rng(seed);
      augment::apply_stda(spec, layout, data, shape, rng);
    });
  });

  m.def(
      "window_starts",
      [](std::size_t samples, py::handle window, py::handle stride) {
        return adopt(augment::window_starts(samples,
                                            window_argument(window, "window_starts: window"),
                                            stride_argument(stride, "window_starts: stride")));
      },
      py::arg("samples"), py::arg("window"), py::arg("stride"),
      "Window starts 0, stride, ... while a window fits.");
  m.def(
      "window_labels",
      [](py::handle labels, py::handle starts, py::handle window_obj) {
        const std::size_t window = window_argument(window_obj, "window_labels: window");
        const auto l = read_labels(labels);
        const auto s = read_int64(starts, "starts", "sample indices");
        return adopt(augment::window_labels({l.data(), static_cast<std::size_t>(l.size())},
                                            {s.data(), static_cast<std::size_t>(s.size())},
                                            window));
      },
      py::arg("labels"), py::arg("starts"), py::arg("window"),
      "The majority label of each window (int64).");
  m.def(
      "extract_windows",
      [](const std::vector<std::shared_ptr<ImuSeries>>& streams, py::handle starts_obj,
         py::handle window_obj) {
        // The command's range (--window): 0 gave (N, 0, 6), 2^64 - 1 read out of range (found in
        // review, 2026-11-27).
        const std::size_t window = window_argument(window_obj, "extract_windows: window");
        const auto s = read_int64(starts_obj, "starts", "sample indices");
        std::vector<const ImuSeries*> ptrs;
        for (const auto& p : streams) ptrs.push_back(p.get());
        std::vector<float> x;
        {
          py::gil_scoped_release release;
          x = augment::extract_windows(ptrs, {s.data(), static_cast<std::size_t>(s.size())},
                                       window);
        }
        const auto n = static_cast<py::ssize_t>(s.size());
        const auto c = static_cast<py::ssize_t>(6 * streams.size());
        return adopt(std::move(x))
            .attr("reshape")(py::make_tuple(n, static_cast<py::ssize_t>(window), c));
      },
      py::arg("streams"), py::arg("starts"), py::arg("window"),
      "Recorded Series (each with accel and gyro, same length) as an (N, window, 6 x streams) "
      "float32 batch.");

  py::class_<augment::Dataset, std::shared_ptr<augment::Dataset>>(m, "Dataset", R"doc(
What `imukit augment` writes: X (N, T, C) float32, y (N,) int64 labels (-1 = none), sub_policy
(N,) int64 (-1 = none), info (dict). Arrays are views of the dataset's memory.
write(dir) writes X.npy, y.npy, sub_policy.npy and dataset.json.)doc")
      .def_property_readonly("X",
                             [](py::object self) {
                               const auto& d = self.cast<const augment::Dataset&>();
                               const auto T = static_cast<py::ssize_t>(d.shape.samples),
                                          C = static_cast<py::ssize_t>(d.shape.channels);
                               return view_of(
                                   d.X.data(), {static_cast<py::ssize_t>(d.shape.windows), T, C},
                                   {static_cast<py::ssize_t>(sizeof(float)) * T * C,
                                    static_cast<py::ssize_t>(sizeof(float)) * C, sizeof(float)},
                                   self);
                             })
      .def_property_readonly(
          "y",
          [](py::object self) { return vector_view(self.cast<const augment::Dataset&>().y, self); })
      .def_property_readonly("sub_policy",
                             [](py::object self) {
                               return vector_view(self.cast<const augment::Dataset&>().sub_policy,
                                                  self);
                             })
      .def_property_readonly("info",
                             [](const augment::Dataset& d) {
                               py::dict i;
                               i["sensors"] = d.info.sensors;
                               i["rate_hz"] = d.info.rate_hz;
                               i["window"] = d.info.window;
                               i["stride"] = d.info.stride;
                               i["mode"] = d.info.mode;
                               i["policy"] = d.info.policy_name;
                               i["seed"] = d.info.seed;
                               i["batch_size"] = d.info.batch_size;
                               i["identity_fraction"] = d.info.identity_fraction;
                               if (d.info.mode == "ppda") {
                                 i["method"] = d.info.method;
                                 i["too_short_windows"] = d.info.too_short_windows;
                               }
                               i["normalized"] = d.info.normalized;
                               i["channel_mean"] = d.info.channel_mean;
                               i["channel_std"] = d.info.channel_std;
                               return i;
                             })
      .def(
          "write",
          [](const augment::Dataset& d, const std::string& dir) {
            py::gil_scoped_release release;
            augment::write_dataset(dir, d.X, d.shape, d.y, d.sub_policy, d.info);
          },
          py::arg("dir"));

  py::class_<augment::DatasetOptions> options(m, "DatasetOptions", R"doc(
The settings of generate_dataset, field by field those of `imukit augment`: window, stride (samples),
count (windows to write; 0: one pass over the base windows), batch_size (windows per sub-policy
draw), seed, threads (0: all cores; the output does not depend on it), normalize (z-score every
channel), identity_fraction (batches left unaugmented), method ("spline" or "fd"; "reference" too)
and max_bytes (the dataset's memory limit; 0: half the physical memory). DatasetOptions(**fields).
The defaults are the command's, except threads: 0 here, 1 in the command. The integers take the
command's ranges (window [2, 1e7], stride and batch_size [1, 1e7], count [0, 1e12], seed
[0, 2^63 - 1], threads [0, 1024]); outside them an imukit.Error, a bool a TypeError.)doc");
  options.def(py::init([](const py::kwargs& fields) {
    augment::DatasetOptions o = python_dataset_options();
    set_dataset_fields(o, fields, "DatasetOptions");
    return o;
  }));
  // The integers through the argument helpers with `imukit augment`'s ranges: pybind11's
  // casters took True as 1, seeds from 2^63 the command refuses, and said "incompatible
  // function arguments" for -1 (found in review, 2026-11-27).
  const auto def_checked = [&options](const char* name, auto member, auto parse) {
    options.def_property(
        name, [member](const augment::DatasetOptions& o) { return o.*member; },
        [member, parse, what = std::string("DatasetOptions: ") + name](augment::DatasetOptions& o,
                                                                       py::handle v) {
          using Field = std::remove_reference_t<decltype(o.*member)>;
          o.*member = static_cast<Field>(parse(v, what));
        });
  };
  const auto at_most = [](uint64_t max, uint64_t min = 0) {
    return [max, min](py::handle v, const std::string& what) {
      return uint_argument(v, what, max, min);
    };
  };
  def_checked("window", &augment::DatasetOptions::window, window_argument);
  def_checked("stride", &augment::DatasetOptions::stride, stride_argument);
  def_checked("count", &augment::DatasetOptions::count, at_most(1'000'000'000'000));
  def_checked("batch_size", &augment::DatasetOptions::batch_size, at_most(10'000'000, 1));
  def_checked("seed", &augment::DatasetOptions::seed, seed_argument);
  def_checked("threads", &augment::DatasetOptions::threads, at_most(1024));
  def_checked("max_bytes", &augment::DatasetOptions::max_bytes,
              at_most(std::numeric_limits<std::size_t>::max()));
  options.def_readwrite("normalize", &augment::DatasetOptions::normalize)
      .def_readwrite("identity_fraction", &augment::DatasetOptions::identity_fraction)
      .def_property(
          "method",
          [](const augment::DatasetOptions& o) { return std::string(sim::to_string(o.method)); },
          [](augment::DatasetOptions& o, const std::string& m) {
            o.method = sim::parse_derivative_method(m);
          });

  m.def(
      "generate_dataset",
      [](py::handle source, const Policy& policy, py::handle labels,
         std::optional<augment::DatasetOptions> options,
         std::optional<std::vector<std::string>> stream_names, const py::kwargs& overrides) {
        augment::DatasetOptions o = options.value_or(python_dataset_options());
        set_dataset_fields(o, overrides, "generate_dataset");
        const std::vector<int64_t> l = labels_argument(labels);
        if (py::isinstance<py::dict>(source)) {
          std::vector<std::string> names;
          std::vector<std::shared_ptr<ImuSeries>> keep;
          std::vector<const ImuSeries*> streams;
          for (auto [k, v] : source.cast<py::dict>()) {
            names.push_back(k.cast<std::string>());
            keep.push_back(v.cast<std::shared_ptr<ImuSeries>>());
            streams.push_back(keep.back().get());
          }
          if (stream_names)
            throw py::value_error("generate_dataset: stream_names go with a list of Series");
          py::gil_scoped_release release;
          return std::make_shared<augment::Dataset>(
              augment::generate_dataset(names, streams, policy, l, o));
        }
        if (py::isinstance<py::list>(source) || py::isinstance<py::tuple>(source)) {
          const auto keep = source.cast<std::vector<std::shared_ptr<ImuSeries>>>();
          std::vector<const ImuSeries*> streams;
          for (const auto& p : keep) streams.push_back(p.get());
          std::vector<std::string> names = stream_names.value_or(std::vector<std::string>{});
          if (names.empty()) {
            for (std::size_t i = 0; i < keep.size(); ++i)
              names.push_back("stream" + std::to_string(i));
          }
          if (names.size() != keep.size())
            throw py::value_error("generate_dataset: one name per stream");
          py::gil_scoped_release release;
          return std::make_shared<augment::Dataset>(
              augment::generate_dataset(names, streams, policy, l, o));
        }
        const sim::Scene& scene = scene_of(source);
        std::mutex& scene_lock = scene_mutex(source);
        const bool scene_seed = !options && !overrides.contains("seed");
        py::gil_scoped_release release;
        const std::lock_guard<std::mutex> lock(scene_lock);  // as in Augmenter(scene)
        // As the command: the scene's seed unless one is given (found in review: 0 here).
        if (scene_seed) o.seed = scene.seed;
        return std::make_shared<augment::Dataset>(augment::generate_dataset(scene, policy, l, o));
      },
      py::arg("source"), py::arg("policy"), py::kw_only(), py::arg("labels") = py::none(),
      py::arg("options") = py::none(), py::arg("stream_names") = py::none(), R"doc(
The dataset `imukit augment` writes, in memory: from a Scene (PPDA: one sub-policy per batch of
batch_size windows) or from recorded Series (a dict name -> Series, or a list with
stream_names; the policy's STDA counterparts). labels: int64 per sample (or None). options: a
DatasetOptions (default: DatasetOptions() with a Scene's own seed, as the command); any of its
fields given as keywords override it (generate_dataset(scene, policy, window=50, seed=8)). The same seed gives the same arrays as the
command, whatever the thread count.)doc");
}

}  // namespace imukit::python
