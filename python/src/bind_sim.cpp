// Bodies, motions, placement presets and scenes; simulation into Series.
#include <algorithm>
#include <limits>
#include <memory>
#include <mutex>

#include "common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/scene.hpp"

namespace imukit::python {

DeviceProfile profile_argument(py::handle obj, std::optional<double> rate_hz);  // bind_io.cpp

namespace {

using sim::Body;
using sim::MotionSource;

// A scene and the lock that serialises the Python threads using it. Code that reads the scene
// with the GIL released (simulate, Augmenter(scene), generate_dataset(scene)) holds the lock;
// code that changes it (add_sensor, the setters) holds the lock and the GIL, so a reader
// holding either one sees no half-made change (found in review, 2026-11-26: Augmenter(scene)
// read scene.sensors while add_sensor appended to it, and crashed).
struct SceneHandle {
  sim::Scene scene;
  std::mutex mutex;
};

// h's lock, waited for with the GIL released (its holder may simulate for minutes, and every
// other Python thread would stall behind the GIL meanwhile), then the GIL again: the caller
// holds both. Nobody waits for the lock while holding the GIL, so the two cannot deadlock.
std::unique_lock<std::mutex> lock_for_change(SceneHandle& h) {
  py::gil_scoped_release release;
  return std::unique_lock<std::mutex>(h.mutex);
}

std::shared_ptr<ImuSeries> series_for(const sim::SensorSpec& spec, int64_t n) {
  auto s = std::make_shared<ImuSeries>(
      ImuSeries::with_channels(static_cast<std::size_t>(n), spec.outputs.accelerometer,
                               spec.outputs.gyroscope, spec.outputs.magnetometer));
  s->t.clear();
  return s;
}

void append(ImuSeries& s, const sim::SensorBlock& b) {
  const auto at = static_cast<Eigen::Index>(s.t.size());
  const auto k = static_cast<Eigen::Index>(b.t.size());
  s.t.insert(s.t.end(), b.t.begin(), b.t.end());
  // The channels were sized from the plan's sample count; grow if a source gives more.
  auto put = [&](Eigen::Matrix3Xd& dst, const Eigen::Matrix3Xd& src) {
    if (src.cols() == 0) return;
    if (dst.cols() < at + k) dst.conservativeResize(3, std::max(at + k, 2 * dst.cols()));
    dst.middleCols(at, k) = src;
  };
  put(s.accel, b.specific_force);
  put(s.gyro, b.angular_rate);
  put(s.mag, b.magnetic_field);
}

void finish(ImuSeries& s) {
  const auto n = static_cast<Eigen::Index>(s.t.size());
  if (s.accel.cols() != 0 && s.accel.cols() != n) s.accel.conservativeResize(3, n);
  if (s.gyro.cols() != 0 && s.gyro.cols() != n) s.gyro.conservativeResize(3, n);
  if (s.mag.cols() != 0 && s.mag.cols() != n) s.mag.conservativeResize(3, n);
}

// The scene run into one Series per sensor (and "<name>.truth" with ground truth): the hardware
// model, noise seeds and chunking are run_scene's, so the arrays equal `imukit simulate`'s CSV
// values bit for bit.
py::dict simulate(SceneHandle& h, const py::object& seed_obj) {
  const bool reseed = !seed_obj.is_none();
  const uint64_t seed = reseed ? seed_argument(seed_obj, "Scene.simulate: seed") : 0;
  std::vector<std::shared_ptr<ImuSeries>> measured, truth;
  std::vector<std::string> names;
  {
    py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(h.mutex);
    // seed= is for this run only: a copy of the scene runs with it (found in review,
    // 2026-11-26: it replaced the scene's seed for every later run and for generate_dataset).
    std::unique_ptr<sim::Scene> reseeded;
    if (reseed) {
      reseeded = std::make_unique<sim::Scene>(h.scene);
      reseeded->seed = seed;
    }
    sim::Scene& scene = reseeded ? *reseeded : h.scene;
    if (scene.sensors.empty()) throw Error("Scene.simulate: the scene has no sensors (add_sensor)");
    require_simulatable(*scene.motion, "Scene.simulate");
    if (!scene.frames && !scene.motion->frame_count())
      throw Error("Scene.simulate: an endless motion needs frames=N");
    // The frames run_scene simulates (the motion's, capped by the limit): sized from the limit
    // alone, a short motion under frames=5e7 allocated 382 MiB (found in review, 2026-11-27).
    const int64_t frames = sim::frames_to_simulate(*scene.motion, scene.frames, "Scene.simulate");
    const double rate = sim::scene_rate_hz(scene);
    std::vector<sim::SensorSpec> specs;
    for (const sim::SceneSensor& s : scene.sensors) {
      if (s.hardware) validate_hardware_model(*s.hardware, rate);
      specs.push_back(s.spec);
      names.push_back(s.spec.name);
    }
    const int64_t n = sim::sample_count(scene.motion->rate_hz(), frames, rate);
    for (const sim::SensorSpec& spec : specs) {
      measured.push_back(series_for(spec, n));
      truth.push_back(scene.ground_truth ? series_for(spec, n) : nullptr);
    }
    sim::run_scene(scene, [&](std::size_t s, const sim::SensorBlock& m, const sim::SensorBlock* t) {
      append(*measured[s], m);
      if (t != nullptr && truth[s]) append(*truth[s], *t);
    });
    for (std::size_t s = 0; s < specs.size(); ++s) {
      finish(*measured[s]);
      if (truth[s]) finish(*truth[s]);
    }
  }
  py::dict out;
  for (std::size_t s = 0; s < measured.size(); ++s) {
    const std::string& name = names[s];
    out[py::str(name)] = measured[s];
    if (truth[s]) out[py::str(name + ".truth")] = truth[s];
  }
  return out;
}

// A magnitude (down) or a world vector. Not finite is refused here: check_gravity's stable
// norm of a NaN vector is 0, and the message said "|g| = 0 m/s^2" (found in review).
Eigen::Vector3d gravity_argument(py::handle g) {
  const Eigen::Vector3d v =
      py::isinstance<py::iterable>(g)
          ? vector3(g, "gravity")
          : Eigen::Vector3d(0.0, 0.0, -std::abs(number_argument(g, "Scene: gravity")));
  if (!v.allFinite()) {
    throw Error("Scene: gravity: expected finite numbers, got " + py::str(g).cast<std::string>());
  }
  return v;
}

// frames= (a limit, None for the motion's count) through index_argument: True was 1 frame
// (found in review, 2026-11-27).
std::optional<int64_t> frames_argument(py::handle obj, const std::string& what) {
  if (obj.is_none()) return std::nullopt;
  return static_cast<int64_t>(uint_argument(obj, what, std::numeric_limits<int64_t>::max()));
}

std::shared_ptr<SceneHandle> make_scene(const Body& body, std::shared_ptr<MotionSource> motion,
                                        py::handle frames_obj, const std::string& method,
                                        double rate_hz, py::handle gravity, const py::object& seed,
                                        bool ground_truth, int64_t chunk_frames,
                                        py::handle magnetic_field, bool anti_alias) {
  auto h = std::make_shared<SceneHandle>();
  sim::Scene& s = h->scene;
  if (motion->joint_count() != body.size()) {
    throw Error("Scene: the motion has " + std::to_string(motion->joint_count()) +
                " joints, the body " + std::to_string(body.size()));
  }
  s.body = body;
  s.motion = std::move(motion);
  const std::optional<int64_t> frames = frames_argument(frames_obj, "Scene: frames");
  s.frames = frames ? frames : s.motion->frame_count();
  s.options.method = sim::parse_derivative_method(method);
  if (rate_hz != 0.0) sim::check_rate(rate_hz, "Scene: rate_hz");
  s.options.rate_hz = rate_hz;
  s.options.anti_alias = anti_alias;
  if (!gravity.is_none()) {
    s.options.gravity_world = gravity_argument(gravity);
    sim::check_gravity(s.options.gravity_world, "Scene: gravity");
  }
  if (!magnetic_field.is_none()) {
    s.options.magnetic_field_world = vector3(magnetic_field, "magnetic_field");
    // Tesla, as in scene files (the Earth's field is 25-65 uT).
    if (!(s.options.magnetic_field_world.norm() <= 1e-2)) {
      throw Error(
          "Scene: magnetic_field is in T (the Earth's field is 25e-6 to 65e-6 T), got a field of " +
          std::to_string(s.options.magnetic_field_world.norm()) + " T");
    }
  }
  // The simulator's own limit (2..7 passed here and failed at simulate(); review, 2026-11-27).
  sim::check_chunk_frames(static_cast<double>(chunk_frames), "Scene: chunk_frames");
  s.options.chunk_frames = chunk_frames;
  s.seed = seed_argument(seed, "Scene: seed");
  s.ground_truth = ground_truth;
  return h;
}

void add_sensor(SceneHandle& h, std::optional<std::string> name, std::optional<std::string> preset,
                std::optional<std::string> joint, py::handle position_m, py::handle q_joint_sensor,
                py::handle hardware, bool accelerometer, bool gyroscope, bool magnetometer) {
  sim::SceneSensor s;
  const sim::Body& body = h.scene.body;
  if (preset.has_value() == joint.has_value()) {
    throw Error(
        "Scene.add_sensor: give either preset= or joint= (with position_m, q_joint_sensor)");
  }
  if (preset) {
    if (!position_m.is_none() || !q_joint_sensor.is_none()) {
      throw Error("Scene.add_sensor: position_m and q_joint_sensor go with joint=, not preset=");
    }
    s = sim::preset_sensor(*preset, body, name.value_or(*preset));
  } else {
    if (!name) throw Error("Scene.add_sensor: a sensor on joint= needs a name");
    s.spec.name = *name;
    s.spec.placement.joint = body.index_of(*joint);
    if (!position_m.is_none()) s.spec.placement.p_joint_sensor = vector3(position_m, "position_m");
    if (!q_joint_sensor.is_none()) {
      const std::vector<double> q = numbers(q_joint_sensor, 4, "q_joint_sensor (w, x, y, z)");
      Eigen::Quaterniond r(q[0], q[1], q[2], q[3]);
      const double norm = r.norm();
      if (!(std::abs(norm - 1.0) <= 1e-6)) {
        throw Error("Scene.add_sensor: q_joint_sensor is not a unit quaternion (norm " +
                    std::to_string(norm) + ")");
      }
      r.coeffs() /= norm;
      s.spec.placement.q_joint_sensor = r;
    }
  }
  if (!accelerometer && !gyroscope && !magnetometer)
    throw Error("Scene.add_sensor: ask for at least one of accelerometer, gyroscope, magnetometer");
  s.spec.outputs.accelerometer = accelerometer;
  s.spec.outputs.gyroscope = gyroscope;
  s.spec.outputs.magnetometer = magnetometer;
  if (!hardware.is_none()) {
    // Checked at the scene's rate in the profile's terms (its file, line and key), as
    // read_scene does: the model's check in simulate() named "accelerometer.bandwidth_hz", a
    // key no profile has (found in review, 2026-11-26).
    s.hardware = to_hardware_model(profile_argument(hardware, sim::scene_rate_hz(h.scene)));
    // The gyroscope's g-sensitivity needs the true specific force (as the scene reader does).
    if (!s.hardware->gyroscope.g_sensitivity.isZero() && gyroscope)
      s.spec.outputs.accelerometer = true;
  }
  const auto lock = lock_for_change(h);
  for (const sim::SceneSensor& other : h.scene.sensors) {
    if (other.spec.name == s.spec.name)
      throw Error("Scene.add_sensor: duplicate sensor name '" + s.spec.name + "'");
  }
  h.scene.sensors.push_back(std::move(s));
}

std::shared_ptr<sim::Motion> motion_from_arrays(py::handle rotations_obj,
                                                py::handle translation_obj, double rate_hz,
                                                const Body* body) {
  const auto rot = read_f64(rotations_obj, "rotations_wxyz");
  if (rot.ndim() != 3 || rot.shape(2) != 4) {
    throw py::value_error("rotations_wxyz: expected shape (frames, joints, 4), got " +
                          shape_string(rot));
  }
  const py::ssize_t frames = rot.shape(0), joints = rot.shape(1);
  if (body != nullptr && static_cast<std::size_t>(joints) != body->size()) {
    throw Error("Motion.from_arrays: " + std::to_string(joints) + " joints, the body has " +
                std::to_string(body->size()));
  }
  sim::check_rate(rate_hz, "Motion.from_arrays: rate_hz");
  std::optional<py::array_t<double, py::array::c_style>> tr;
  if (!translation_obj.is_none()) {
    tr = read_f64(translation_obj, "root_translation");
    if (tr->ndim() != 2 || tr->shape(0) != frames || tr->shape(1) != 3) {
      throw py::value_error("root_translation: expected shape (" + std::to_string(frames) +
                            ", 3), got " + shape_string(*tr));
    }
  }
  // The copy and the checks run with the GIL released (60,000 frames of 21 joints held it for
  // 83 ms, found in review); the warnings are raised after.
  std::shared_ptr<sim::Motion> m;
  std::vector<std::string> warnings;
  {
    const double* q = rot.data();
    const double* t = tr ? tr->data() : nullptr;
    py::gil_scoped_release release;
    m = std::make_shared<sim::Motion>(rate_hz, static_cast<std::size_t>(joints), frames);
    for (py::ssize_t f = 0; f < frames; ++f) {
      for (py::ssize_t j = 0; j < joints; ++j) {
        const double* p = q + 4 * (f * joints + j);
        m->rotation(f, static_cast<std::size_t>(j)) = Eigen::Quaterniond(p[0], p[1], p[2], p[3]);
      }
      if (t != nullptr) m->root_translation(f) = Eigen::Vector3d(t + 3 * f);  // else zero
    }
    warnings = m->validate_and_normalize(body);
  }
  for (const std::string& w : warnings) PyErr_WarnEx(PyExc_RuntimeWarning, w.c_str(), 1);
  return m;
}

py::dict preset_dict(const sim::PlacementPreset& p) {
  py::dict d;
  d["name"] = p.name;
  d["description"] = p.description;
  d["joint"] = p.joint;
  d["segment"] = sim::segment_name(p.joint);
  d["along"] = p.along;
  d["anterior_m"] = p.anterior_m;
  d["normal_m"] = p.normal_m;
  d["position_range_m"] =
      std::vector<double>(p.position_range_m.data(), p.position_range_m.data() + 3);
  d["rotation_range_rad"] =
      std::vector<double>(p.rotation_range_rad.data(), p.rotation_range_rad.data() + 3);
  return d;
}

}  // namespace

// For bind_augment: the scene inside an imukit.Scene, and its lock (SceneHandle), which a
// reader holds while it reads with the GIL released.
const sim::Scene& scene_of(py::handle scene) {
  if (!py::isinstance<SceneHandle>(scene)) throw py::type_error("expected an imukit.Scene");
  return scene.cast<const SceneHandle&>().scene;
}
std::mutex& scene_mutex(py::handle scene) {
  if (!py::isinstance<SceneHandle>(scene)) throw py::type_error("expected an imukit.Scene");
  return scene.cast<SceneHandle&>().mutex;
}

void bind_sim(py::module_& m) {
  py::class_<Body, std::shared_ptr<Body>>(m, "Body",
                                          "A skeleton: joints with offsets from their parents (m).")
      .def_static(
          "default_humanoid",
          [](double h) { return std::make_shared<Body>(Body::default_humanoid(h)); },
          py::arg("height_m") = 1.75, "The 21-joint T-pose humanoid of the given stature.")
      .def_static(
          "from_arrays",
          [](const std::vector<std::string>& names, const std::vector<int>& parents,
             py::handle offsets) {
            const auto o = read_f64(offsets, "offsets");
            if (o.ndim() != 2 || o.shape(1) != 3 ||
                static_cast<std::size_t>(o.shape(0)) != names.size()) {
              throw py::value_error("offsets: expected shape (" + std::to_string(names.size()) +
                                    ", 3), got " + shape_string(o));
            }
            return std::make_shared<Body>(sim::body_from_joints(
                names, parents, Eigen::Map<const Eigen::Matrix3Xd>(o.data(), 3, o.shape(0)),
                "Body.from_arrays"));
          },
          py::arg("names"), py::arg("parents"), py::arg("offsets"),
          "A body from joint names, parent indices (-1 for the root, parents before children) and "
          "offsets (joints, 3) from each parent in the parent's frame at the neutral pose (m).")
      .def("__len__", &Body::size)
      .def_property_readonly("joint_names",
                             [](const Body& b) {
                               std::vector<std::string> out;
                               for (const sim::Joint& j : b.joints()) out.push_back(j.name);
                               return out;
                             })
      .def_property_readonly("parents",
                             [](const Body& b) {
                               std::vector<int> out;
                               for (const sim::Joint& j : b.joints()) out.push_back(j.parent);
                               return out;
                             })
      .def_property_readonly(
          "offsets",
          [](const Body& b) {
            py::array_t<double> out({static_cast<py::ssize_t>(b.size()), py::ssize_t{3}});
            for (std::size_t i = 0; i < b.size(); ++i) {
              for (int k = 0; k < 3; ++k) out.mutable_at(i, k) = b.joint(i).offset_parent_joint(k);
            }
            return out;
          },
          "(joints, 3) offsets from each joint's parent in the parent's frame, m (a copy)")
      .def("index_of", &Body::index_of, py::arg("name"))
      .def("__repr__",
           [](const Body& b) { return "<imukit.Body " + std::to_string(b.size()) + " joints>"; });

  py::class_<MotionSource, std::shared_ptr<MotionSource>>(m, "MotionSource",
                                                          "Body motion at a constant frame rate.")
      .def_property_readonly("rate_hz", &MotionSource::rate_hz)
      .def_property_readonly("joint_count", &MotionSource::joint_count)
      .def_property_readonly("frame_count", &MotionSource::frame_count,
                             "None for an endless source");

  py::class_<sim::Motion, MotionSource, std::shared_ptr<sim::Motion>>(m, "Motion", R"doc(
In-memory motion (from BVH, joint-quaternion CSV or arrays). Motion.from_arrays(rotations_wxyz
(frames, joints, 4), root_translation (frames, 3) or None, rate_hz, body=None) copies and
renormalises the quaternions (w first).)doc")
      .def_static(
          "from_arrays",
          [](py::handle r, py::handle t, double rate, const Body* body) {
            return motion_from_arrays(r, t, rate, body);
          },
          py::arg("rotations_wxyz"), py::arg("root_translation") = py::none(), py::arg("rate_hz"),
          py::arg("body") = nullptr)
      .def(
          "rotations_wxyz",
          [](const sim::Motion& mo) {
            const auto frames = static_cast<py::ssize_t>(mo.frames());
            const auto joints = static_cast<py::ssize_t>(mo.joint_count());
            py::array_t<double> out({frames, joints, py::ssize_t{4}});
            double* p = out.mutable_data();
            for (py::ssize_t f = 0; f < frames; ++f) {
              for (py::ssize_t j = 0; j < joints; ++j, p += 4) {
                const Eigen::Quaterniond& q = mo.rotation(f, static_cast<std::size_t>(j));
                p[0] = q.w(), p[1] = q.x(), p[2] = q.y(), p[3] = q.z();
              }
            }
            return out;
          },
          "(frames, joints, 4) rotations, w x y z (a copy: Eigen stores x y z w)")
      .def(
          "root_translation",
          [](const sim::Motion& mo) {
            py::array_t<double> out({static_cast<py::ssize_t>(mo.frames()), py::ssize_t{3}});
            for (int64_t f = 0; f < mo.frames(); ++f) {
              for (int k = 0; k < 3; ++k) out.mutable_at(f, k) = mo.root_translation(f)(k);
            }
            return out;
          },
          "(frames, 3) root position in the world, m (a copy)");

  py::class_<sim::ProceduralMotion, MotionSource, std::shared_ptr<sim::ProceduralMotion>>(
      m, "ProceduralMotion", R"doc(
A deterministic smooth motion (sums of sinusoids per joint, integer phases): every frame depends
on its absolute index only. frames=None makes it endless (give Scene(frames=N)). amplitude_rad
is in [0, 10] (as in a scene file), translation_amplitude_m finite and >= 0; others are an
imukit.Error.)doc")
      .def(py::init([](std::size_t joints, double rate_hz, py::handle frames,
                       const py::object& seed, double amplitude_rad, int harmonics,
                       int64_t period_s, double translation_amplitude_m, int64_t start_frame) {
             sim::ProceduralMotionOptions o;
             o.rate_hz = rate_hz;
             o.frames = frames_argument(frames, "ProceduralMotion: frames");
             o.seed = seed_argument(seed, "ProceduralMotion: seed");
             o.amplitude_rad = amplitude_rad;
             o.harmonics = harmonics;
             o.period_s = period_s;
             o.translation_amplitude_m = translation_amplitude_m;
             o.start_frame = start_frame;
             return std::make_shared<sim::ProceduralMotion>(joints, o);
           }),
           py::arg("joints"), py::arg("rate_hz") = 100.0, py::arg("frames") = py::none(),
           py::arg("seed") = 1, py::arg("amplitude_rad") = 0.1, py::arg("harmonics") = 3,
           py::arg("period_s") = 60, py::arg("translation_amplitude_m") = 0.05,
           py::arg("start_frame") = 0);

  m.def(
      "read_bvh",
      [](const std::string& path, double scale, const std::string& up) {
        sim::BvhOptions o;
        o.scale = scale;
        if (up != "y" && up != "z") throw Error("read_bvh: up must be \"y\" or \"z\"");
        o.up = up == "z" ? sim::UpAxis::z : sim::UpAxis::y;
        std::shared_ptr<sim::BvhData> d;
        {
          py::gil_scoped_release release;
          d = std::make_shared<sim::BvhData>(sim::read_bvh(path, o));
        }
        return py::make_tuple(std::make_shared<Body>(std::move(d->body)),
                              std::make_shared<sim::Motion>(std::move(d->motion)), d->warnings);
      },
      py::arg("path"), py::arg("scale") = 1.0, py::arg("up") = "y",
      "Reads a BVH file: (Body, Motion, warnings). scale: 1 m, 0.01 cm, 0.056444 CMU units.");
  m.def(
      "read_quaternion_csv",
      [](const std::string& path, const Body& body, std::optional<double> rate_hz) {
        std::vector<std::string> warnings;
        std::shared_ptr<sim::Motion> mo;
        {
          py::gil_scoped_release release;
          mo = std::make_shared<sim::Motion>(
              sim::read_quaternion_csv(path, body, rate_hz, &warnings));
        }
        for (const std::string& w : warnings) PyErr_WarnEx(PyExc_RuntimeWarning, w.c_str(), 1);
        return mo;
      },
      py::arg("path"), py::arg("body"), py::arg("rate_hz") = py::none());
  m.def(
      "placement_presets",
      [] {
        py::list out;
        for (const sim::PlacementPreset& p : sim::placement_presets()) out.append(preset_dict(p));
        return out;
      },
      "The wearable placement presets (name, segment, description, plausible ranges).");

  py::class_<SceneHandle, std::shared_ptr<SceneHandle>>(m, "Scene", R"doc(
Body + motion + sensors (placement and hardware) + settings, as in an imukit.scene/1 file.

Scene(body, motion, frames=None, method="fd", rate_hz=0 (the motion's), gravity=None (a
magnitude or a world vector; default 9.80665 down), seed=0 (an int from 0 to 2^63 - 1, as
`imukit simulate --seed` and a scene file take), ground_truth=False, chunk_frames=4096
(motion frames streamed at a time, which bounds the memory: a whole number in [8, 1e7], as a
scene file's simulation.chunk_frames takes), magnetic_field=None (world vector,
T; default the mid-latitude Earth field), anti_alias=True (band-limit the motion to the
sensor's Nyquist frequency where its frames come faster than the samples, as a scene file's
simulation.anti_alias)),
then add_sensor(...) per sensor (magnetometer=True adds Series.mag); or read_scene(path) /
parse_scene(text).
simulate(seed=None) -> {name: Series} (and "<name>.truth" with ground_truth): the same
numbers as `imukit simulate` for the same scene and seed; seed= is for that run only (scene.seed
stays). A hardware profile is checked at the scene's rate when its sensor is added.)doc")
      .def(py::init(&make_scene), py::arg("body"), py::arg("motion"), py::kw_only(),
           py::arg("frames") = py::none(), py::arg("method") = "fd", py::arg("rate_hz") = 0.0,
           py::arg("gravity") = py::none(), py::arg("seed") = 0, py::arg("ground_truth") = false,
           py::arg("chunk_frames") = 4096, py::arg("magnetic_field") = py::none(),
           py::arg("anti_alias") = true)
      .def("add_sensor", &add_sensor, py::arg("name") = py::none(), py::kw_only(),
           py::arg("preset") = py::none(), py::arg("joint") = py::none(),
           py::arg("position_m") = py::none(), py::arg("q_joint_sensor") = py::none(),
           py::arg("hardware") = py::none(), py::arg("accelerometer") = true,
           py::arg("gyroscope") = true, py::arg("magnetometer") = false,
           "A sensor from a placement preset, or on a joint at position_m (joint frame) with "
           "q_joint_sensor (w, x, y, z); hardware: a Profile, a profile dict or a file name.")
      .def("simulate", &simulate, py::arg("seed") = py::none())
      .def_property(
          "seed", [](const SceneHandle& h) { return h.scene.seed; },
          [](SceneHandle& h, const py::object& s) {
            const uint64_t seed = seed_argument(s, "Scene.seed");
            const auto lock = lock_for_change(h);
            h.scene.seed = seed;
          })
      .def_property(
          "ground_truth", [](const SceneHandle& h) { return h.scene.ground_truth; },
          [](SceneHandle& h, bool g) {
            const auto lock = lock_for_change(h);
            h.scene.ground_truth = g;
          })
      .def_property(
          "method",
          [](const SceneHandle& h) { return std::string(sim::to_string(h.scene.options.method)); },
          [](SceneHandle& h, const std::string& s) {
            const sim::DerivativeMethod method = sim::parse_derivative_method(s);
            const auto lock = lock_for_change(h);
            h.scene.options.method = method;
          })
      .def_property(
          "anti_alias", [](const SceneHandle& h) { return h.scene.options.anti_alias; },
          [](SceneHandle& h, bool a) {
            const auto lock = lock_for_change(h);
            h.scene.options.anti_alias = a;
          })
      .def_property_readonly("rate_hz",
                             [](const SceneHandle& h) { return sim::scene_rate_hz(h.scene); })
      .def_property_readonly("gravity_world",
                             [](const SceneHandle& h) {
                               const Eigen::Vector3d& g = h.scene.options.gravity_world;
                               return py::make_tuple(g.x(), g.y(), g.z());
                             })
      .def_property_readonly("sensors",
                             [](const SceneHandle& h) {
                               std::vector<std::string> out;
                               for (const sim::SceneSensor& s : h.scene.sensors)
                                 out.push_back(s.spec.name);
                               return out;
                             })
      .def_property_readonly(
          "body", [](const SceneHandle& h) { return std::make_shared<Body>(h.scene.body); })
      .def_property_readonly("motion", [](const SceneHandle& h) { return h.scene.motion; })
      .def_property_readonly("warnings", [](const SceneHandle& h) { return h.scene.warnings; });
  m.def(
      "read_scene",
      [](const std::string& path) {
        auto h = std::make_shared<SceneHandle>();
        py::gil_scoped_release release;
        h->scene = sim::read_scene(path);
        return h;
      },
      py::arg("path"));
  m.def(
      "parse_scene",
      [](const std::string& text, const std::string& source_name, const std::string& base_dir) {
        auto h = std::make_shared<SceneHandle>();
        py::gil_scoped_release release;  // it reads the motion files the scene names
        h->scene = sim::parse_scene(text, source_name, base_dir);
        return h;
      },
      py::arg("text"), py::arg("source_name") = "<string>", py::arg("base_dir") = ".");
}

}  // namespace imukit::python
