// Identification (sim/identify.hpp, docs/identification.md): placement, hardware, timing and the
// segment correction fitted to a real IMU; the fitted motion; fidelity.
#include <algorithm>
#include <memory>

#include "common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/body.hpp"
#include "imukit/sim/identify.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "imukit/sim/simulator.hpp"

namespace imukit::python {
namespace {

// The result with the body it refers to (for joint names and fitted_motion).
struct IdentifyHandle {
  sim::IdentifyResult result;
  sim::Body body;
  sim::FittedSceneClock imu_clock;  // the fitted motion's default grid (fitted_scene_clock)
  // The gravity the fit used: write_scene's default, as the command writes the fitted scene
  // with it (found in review, 2026-11-27: 9.80665 was written after a fit at 9.81).
  Eigen::Vector3d gravity_world = kStandardGravityWorld;
};

// A gravity magnitude (m/s^2), pointing down, within sim::GravityLimits as the command's
// --gravity takes it: 0 ran identify, and NaN or 0 wrote scenes read_scene refuses (found in
// review, 2026-11-27). NaN is named here: check_gravity's norm of it read as 0.
Eigen::Vector3d gravity_down(py::handle g, const std::string& what) {
  const double v = number_argument(g, what);
  if (!std::isfinite(v))
    throw Error(what + ": expected a finite number, got " + py::repr(g).cast<std::string>());
  const Eigen::Vector3d down(0.0, 0.0, -std::abs(v));
  sim::check_gravity(down, what);
  return down;
}

py::array_t<double> numpy_vector(const Eigen::VectorXd& v) {
  py::array_t<double> out(v.size());
  for (Eigen::Index i = 0; i < v.size(); ++i) out.mutable_at(i) = v[i];
  return out;
}

// (n, 3) copy of a 3 x n matrix.
py::array_t<double> triad(const Eigen::Matrix3Xd& m) {
  py::array_t<double> out({static_cast<py::ssize_t>(m.cols()), py::ssize_t{3}});
  std::copy(m.data(), m.data() + m.size(), out.mutable_data());
  return out;
}

py::dict fidelity_dict(const sim::Fidelity& f) {
  py::dict d, a, g;
  a["rmse"] = numpy_vector(f.accel.rmse);
  a["correlation"] = numpy_vector(f.accel.correlation);
  g["rmse"] = numpy_vector(f.gyro.rmse);
  g["correlation"] = numpy_vector(f.gyro.correlation);
  d["accel"] = a;
  d["gyro"] = g;
  d["samples"] = f.samples;
  return d;
}

// estimate= / fix=: a list of parameter names (a str alone was iterated per character, found
// in review).
void apply_names(py::handle names, bool value, sim::IdentifyOptions& o, const char* what) {
  for (const std::string& n : string_list(names, std::string("identify: ") + what)) {
    bool* flag = n == "rotation"      ? &o.rotation
                 : n == "position"    ? &o.position
                 : n == "accel_bias"  ? &o.accel_bias
                 : n == "gyro_bias"   ? &o.gyro_bias
                 : n == "accel_scale" ? &o.accel_scale
                 : n == "gyro_scale"  ? &o.gyro_scale
                 : n == "time_offset" ? &o.time_offset
                 : n == "clock_rate"  ? &o.clock_rate
                                      : nullptr;
    if (flag == nullptr) {
      throw Error(std::string("identify: ") + what + " '" + n +
                  "' is not one of rotation, position, accel_bias, gyro_bias, accel_scale, "
                  "gyro_scale, time_offset, clock_rate");
    }
    *flag = value;
  }
}

std::shared_ptr<IdentifyHandle> run_identify(
    const sim::Body& body, sim::MotionSource& motion, const ImuSeries& imu,
    std::optional<std::string> joint, std::optional<std::string> init, py::handle position_m,
    py::handle q_joint_sensor, bool rotation_from_data, py::handle estimate, py::handle fix,
    const std::string& correction, double knot_spacing_s, double twist_prior_rad,
    double tilt_prior_rad, double smoothness, double max_clock_rate,
    std::optional<int64_t> motion_start_ns, std::optional<double> time_offset_s,
    double max_time_offset_s, py::handle gravity, py::handle invalid_motion, int threads,
    double function_tolerance, double accel_bias_prior, double gyro_bias_prior, py::handle segments,
    double segment_prior) {
  sim::IdentifyOptions o;
  // The command's --segments and --segment-prior (missing here until review, 2026-11-27).
  for (const std::string& name : string_list(segments, "identify: segments"))
    o.segments.push_back(body.index_of(name));
  o.segment_prior = segment_prior;
  if (init) {
    o.init = sim::preset_placement(*init, body);
    o.joint = o.init.joint;
  }
  if (joint) {
    const int j = body.index_of(*joint);
    if (init && j != o.joint) {
      throw Error("identify: preset '" + *init + "' sits on '" +
                  body.joint(static_cast<std::size_t>(o.joint)).name + "', not on joint '" +
                  *joint + "'");
    }
    o.joint = j;
  }
  if (o.joint < 0) throw Error("identify: name the sensor's joint (joint=) or a preset (init=)");
  // Lists and integer arrays too, as Scene.add_sensor takes them (found in review: identify
  // refused both).
  if (!position_m.is_none()) o.init.p_joint_sensor = vector3(position_m, "position_m");
  if (!q_joint_sensor.is_none()) {
    const std::vector<double> q = numbers(q_joint_sensor, 4, "q_joint_sensor (w, x, y, z)");
    const Eigen::Quaterniond r(q[0], q[1], q[2], q[3]);
    if (!(std::abs(r.norm() - 1.0) <= 1e-6))
      throw Error("identify: q_joint_sensor is not a unit quaternion");
    o.init.q_joint_sensor = r.normalized();
  }
  o.init_rotation_from_data = rotation_from_data;
  // A name in both lists was fixed here and estimated by the command (found in review,
  // 2026-11-27): refused in both.
  {
    const std::vector<std::string> fixed = string_list(fix, "identify: fix");
    for (const std::string& n : string_list(estimate, "identify: estimate"))
      if (std::find(fixed.begin(), fixed.end(), n) != fixed.end())
        throw Error("identify: '" + n + "' is both in fix and in estimate");
  }
  apply_names(estimate, true, o, "estimate");
  apply_names(fix, false, o, "fix");
  o.correction = sim::parse_segment_correction(correction);
  o.correction_knot_spacing_s = knot_spacing_s;
  o.twist_prior_rad = twist_prior_rad;
  o.tilt_prior_rad = tilt_prior_rad;
  o.correction_smoothness_radps2 = smoothness;
  o.max_clock_rate = max_clock_rate;
  if (imu.size() == 0) throw Error("identify: the IMU series is empty");
  o.motion_start_ns = motion_start_ns.value_or(imu.t.front());
  if (time_offset_s) {
    if (!std::isfinite(*time_offset_s)) throw Error("identify: time_offset_s must be finite");
    o.coarse_time_offset = false;
    o.time_offset_init_s = *time_offset_s;
  }
  o.max_time_offset_s = max_time_offset_s;
  if (!gravity.is_none()) o.gravity_world = gravity_down(gravity, "identify: gravity");
  if (!invalid_motion.is_none()) {
    // (start_ns, end_ns) pairs, converted here: pybind11's cast named std::pair<long, long>.
    const std::string what = "identify: invalid_motion";
    if (py::isinstance<py::str>(invalid_motion) || !py::isinstance<py::iterable>(invalid_motion)) {
      throw py::type_error(what + ": expected a list of (start_ns, end_ns) pairs, got " +
                           type_name(invalid_motion));
    }
    for (py::handle h : invalid_motion) {
      const std::string at = what + "[" + std::to_string(o.invalid_motion.size()) + "]";
      if (py::isinstance<py::str>(h) || !py::isinstance<py::iterable>(h) || py::len(h) != 2) {
        throw py::type_error(at + ": expected a (start_ns, end_ns) pair of ints, got " +
                             py::repr(h).cast<std::string>());
      }
      const py::tuple pair(py::reinterpret_borrow<py::object>(h));
      o.invalid_motion.emplace_back(int64_argument(pair[0], at + "[0]"),
                                    int64_argument(pair[1], at + "[1]"));
    }
  }
  o.threads = threads;
  o.function_tolerance = function_tolerance;
  o.accel_bias_prior_mps2 = accel_bias_prior;
  o.gyro_bias_prior_radps = gyro_bias_prior;
  auto h = std::make_shared<IdentifyHandle>();
  h->body = body;
  {
    py::gil_scoped_release release;
    h->result = sim::identify(body, motion, imu, o);
  }
  h->imu_clock = sim::fitted_scene_clock(imu.t);
  h->gravity_world = o.gravity_world;
  return h;
}

}  // namespace

void bind_identify(py::module_& m) {
  using H = IdentifyHandle;
  py::class_<H, std::shared_ptr<H>>(m, "IdentifyResult", R"doc(
What imukit.identify found (docs/identification.md): placement (joint, position_m,
q_joint_sensor w x y z), biases and scale errors, timing (time_offset_s, clock_rate: motion time
= t - motion_start + time_offset_s + clock_rate (t - t_ref_ns)), the segment correction, the
per-axis fidelity before and after (dicts: accel/gyro -> rmse, correlation), the samples used
and the model's signals before and after ((n, 3) arrays). to_json() is imukit.placement/1;
fitted_motion(motion) bakes the fit into a Motion on the IMU's clock.)doc")
      .def_property_readonly(
          "joint",
          [](const H& h) {
            return h.body.joint(static_cast<std::size_t>(h.result.placement.joint)).name;
          })
      .def_property_readonly(
          "position_m", [](const H& h) { return numpy_vector(h.result.placement.p_joint_sensor); })
      .def_property_readonly("q_joint_sensor",
                             [](const H& h) {
                               const Eigen::Quaterniond& q = h.result.placement.q_joint_sensor;
                               return numpy_vector(Eigen::Vector4d(q.w(), q.x(), q.y(), q.z()));
                             })
      .def_property_readonly("accel_bias",
                             [](const H& h) { return numpy_vector(h.result.accel_bias); })
      .def_property_readonly("gyro_bias",
                             [](const H& h) { return numpy_vector(h.result.gyro_bias); })
      .def_property_readonly("accel_scale",
                             [](const H& h) { return numpy_vector(h.result.accel_scale); })
      .def_property_readonly("gyro_scale",
                             [](const H& h) { return numpy_vector(h.result.gyro_scale); })
      .def_property_readonly("time_offset_s", [](const H& h) { return h.result.time_offset_s; })
      .def_property_readonly("coarse_time_offset_s",
                             [](const H& h) { return h.result.coarse_time_offset_s; })
      .def_property_readonly("clock_rate", [](const H& h) { return h.result.clock_rate; })
      .def_property_readonly("coarse_clock_rate",
                             [](const H& h) { return h.result.coarse_clock_rate; })
      .def_property_readonly("t_ref_ns", [](const H& h) { return h.result.t_ref_ns; })
      .def_property_readonly("motion_start_ns", [](const H& h) { return h.result.motion_start_ns; })
      .def_property_readonly(
          "correction",
          [](const H& h) {
            const sim::CorrectionSpline& c = h.result.correction;
            py::dict d;
            d["kind"] = c.dims == 0 ? "none" : c.dims == 1 ? "twist" : "rotation";
            d["axes_joint"] =
                numpy_vector(Eigen::Map<const Eigen::VectorXd>(c.axes.data(), 3 * c.dims))
                    .attr("reshape")(c.dims, 3);
            d["t0_ns"] = c.t0_ns;
            d["knot_spacing_s"] = c.knot_spacing_s;
            Eigen::MatrixXd ct = c.control.transpose();  // (knots, dims)
            py::array_t<double> ctrl({ct.rows(), ct.cols()});
            for (Eigen::Index i = 0; i < ct.rows(); ++i)
              for (Eigen::Index k = 0; k < ct.cols(); ++k) ctrl.mutable_at(i, k) = ct(i, k);
            d["control_rad"] = ctrl;
            return d;
          })
      .def_property_readonly(
          "correction_angles",
          [](const H& h) {
            const Eigen::MatrixXd& a = h.result.correction_angles;
            py::array_t<double> out({a.cols(), a.rows()});
            for (Eigen::Index i = 0; i < a.cols(); ++i)
              for (Eigen::Index k = 0; k < a.rows(); ++k) out.mutable_at(i, k) = a(k, i);
            return out;
          },
          "(samples used, dims) correction angles at the samples used, rad")
      .def_property_readonly("fidelity_before",
                             [](const H& h) { return fidelity_dict(h.result.fidelity_before); })
      .def_property_readonly("fidelity_after",
                             [](const H& h) { return fidelity_dict(h.result.fidelity_after); })
      .def_property_readonly("rms_before",
                             [](const H& h) {
                               return py::make_tuple(h.result.rms_before.accel,
                                                     h.result.rms_before.gyro);
                             })
      .def_property_readonly("rms_after",
                             [](const H& h) {
                               return py::make_tuple(h.result.rms_after.accel,
                                                     h.result.rms_after.gyro);
                             })
      .def_property_readonly(
          "t",
          [](const H& h) { return py::array_t<int64_t>(h.result.t.size(), h.result.t.data()); })
      .def_property_readonly("accel", [](const H& h) { return triad(h.result.accel); })
      .def_property_readonly("gyro", [](const H& h) { return triad(h.result.gyro); })
      .def_property_readonly("accel_before",
                             [](const H& h) { return triad(h.result.accel_before); })
      .def_property_readonly("gyro_before", [](const H& h) { return triad(h.result.gyro_before); })
      .def_property_readonly("accel_after", [](const H& h) { return triad(h.result.accel_after); })
      .def_property_readonly("gyro_after", [](const H& h) { return triad(h.result.gyro_after); })
      .def_property_readonly("parameters",
                             [](const H& h) {
                               py::list out;
                               for (const sim::ParameterEstimate& e : h.result.parameters) {
                                 py::dict d;
                                 d["name"] = e.name;
                                 d["unit"] = e.unit;
                                 d["value"] = e.value;
                                 d["std_error"] = e.std_error;
                                 d["estimated"] = e.estimated;
                                 d["observable"] = e.observable;
                                 out.append(d);
                               }
                               return out;
                             })
      .def_property_readonly("unobservable", [](const H& h) { return h.result.unobservable; })
      .def_property_readonly("warnings", [](const H& h) { return h.result.warnings; })
      .def_property_readonly("samples_used", [](const H& h) { return h.result.samples_used; })
      .def_property_readonly("samples_excluded",
                             [](const H& h) { return h.result.samples_excluded; })
      .def_property_readonly("iterations", [](const H& h) { return h.result.iterations; })
      .def_property_readonly("converged", [](const H& h) { return h.result.converged; })
      .def_property_readonly("seconds", [](const H& h) { return h.result.seconds; })
      .def_property_readonly("solver_summary", [](const H& h) { return h.result.solver_summary; })
      .def(
          "to_json", [](const H& h) { return sim::placement_json(h.result, h.body); },
          "The result as imukit.placement/1 JSON text.")
      .def(
          "fitted_motion",
          [](const H& h, sim::MotionSource& motion, std::optional<int64_t> first_ns,
             std::optional<int64_t> frames, std::optional<double> rate_hz) {
            std::shared_ptr<sim::Motion> out;
            {
              py::gil_scoped_release release;
              out = std::make_shared<sim::Motion>(sim::fitted_motion(
                  h.body, motion, h.result, first_ns.value_or(h.imu_clock.first_ns),
                  frames.value_or(h.imu_clock.frames), rate_hz.value_or(h.imu_clock.rate_hz)));
            }
            return out;
          },
          py::arg("motion"), py::arg("first_ns") = py::none(), py::arg("frames") = py::none(),
          py::arg("rate_hz") = py::none(),
          "The fit baked into a Motion (the motion given to identify): frame k at IMU time "
          "first_ns + k / rate_hz (default: the IMU's first sample, its sample count and rate), "
          "time offset, clock rate and segment correction applied.")
      .def(
          "write_scene",
          [](const H& h, const std::string& dir, sim::MotionSource& motion,
             std::optional<std::string> sensor_name, py::handle gravity) {
            const Eigen::Vector3d g =
                gravity.is_none() ? h.gravity_world : gravity_down(gravity, "write_scene: gravity");
            const std::string name = sensor_name.value_or(
                h.body.joint(static_cast<std::size_t>(h.result.placement.joint)).name);
            py::gil_scoped_release release;
            const sim::Motion fitted =
                sim::fitted_motion(h.body, motion, h.result, h.imu_clock.first_ns,
                                   h.imu_clock.frames, h.imu_clock.rate_hz);
            sim::write_fitted_scene(dir, h.body, fitted, h.result, name, g);
          },
          py::arg("dir"), py::arg("motion"), py::arg("sensor_name") = py::none(),
          py::arg("gravity") = py::none(),
          "Writes dir/scene.json, motion.csv (the fitted motion on the IMU's clock, "
          "fitted_scene_clock: scene sample k = IMU sample k unless samples are missing) and "
          "placement.json (docs/formats.md, \"Fitted scenes\"); "
          "imukit.read_scene(dir + '/scene.json') and Augmenter load it. gravity: m/s^2 in "
          "[0.1, 100] (default the gravity identify fitted with).");

  m.def("identify", &run_identify, py::arg("body"), py::arg("motion"), py::arg("imu"),
        py::arg("joint") = py::none(), py::kw_only(), py::arg("init") = py::none(),
        py::arg("position_m") = py::none(), py::arg("q_joint_sensor") = py::none(),
        py::arg("rotation_from_data") = true, py::arg("estimate") = py::tuple(),
        py::arg("fix") = py::tuple(), py::arg("correction") = "none",
        py::arg("knot_spacing_s") = 0.3, py::arg("twist_prior_rad") = 1.5,
        py::arg("tilt_prior_rad") = 0.1, py::arg("correction_smoothness_radps2") = 30.0,
        py::arg("max_clock_rate") = 2e-4, py::arg("motion_start_ns") = py::none(),
        py::arg("time_offset_s") = py::none(), py::arg("max_time_offset_s") = 1.0,
        py::arg("gravity") = py::none(), py::arg("invalid_motion") = py::none(),
        py::arg("threads") = 1, py::arg("function_tolerance") = 1e-12,
        py::arg("accel_bias_prior_mps2") = 0.0, py::arg("gyro_bias_prior_radps") = 0.0,
        py::arg("segments") = py::tuple(), py::arg("segment_prior") = 0.05, R"doc(
Fits a sensor's placement, biases (scale errors, clock rate with estimate=[...]), the time offset
and optionally a smooth correction of the sensor segment's rotation (correction="twist" or
"rotation") so that the simulator reproduces a real IMU (imukit.Series with accel and gyro).
joint: the segment carrying the sensor ("right_forearm"); init: a placement preset to start
from (imukit.placement_presets(); gives the joint too); position_m, q_joint_sensor: the initial
placement, over the preset's (the rotation is found from the data unless
rotation_from_data=False);
motion_start_ns: IMU time of motion frame 0 (default the first IMU sample); time_offset_s:
search only within +-0.25 s of it and start from the peak (from it when nothing correlates there); *_bias_prior_*: 1-sigma Gaussian priors on the biases
(0: none); segments: joints on the sensor's chain whose offset from their parent (the parent
segment's length) is fitted, with a Gaussian prior of relative width segment_prior (default 0.05;
`imukit identify --segments`). A name in both estimate and fix is refused. Returns an IdentifyResult; raises imukit.Error for
unusable input. gravity: m/s^2 in [0.1, 100] (default 9.80665). The GIL is released while it
runs; threads evaluate the Jacobian in parallel (default 1, as `imukit identify --threads`; 0 is
1 here, not all cores).)doc");

  m.def(
      "fidelity",
      [](py::handle ma, py::handle mg, py::handle sa, py::handle sg) {
        const auto a = read_f64(ma, "measured_accel");
        // The first argument gives n; its own shape error names it (found in review: 1-d
        // arrays were "simulated_gyro: expected shape (0, 3), got (5,)").
        if (a.ndim() != 2 || a.shape(1) != 3) {
          throw py::value_error("measured_accel: expected shape (n, 3), got " + shape_string(a));
        }
        const auto n = a.shape(0);
        const auto g = read_f64(mg, "measured_gyro");
        const auto x = read_f64(sa, "simulated_accel");
        const auto y = read_f64(sg, "simulated_gyro");
        return fidelity_dict(
            sim::fidelity(map_triad(a, n, "measured_accel"), map_triad(g, n, "measured_gyro"),
                          map_triad(x, n, "simulated_accel"), map_triad(y, n, "simulated_gyro")));
      },
      py::arg("measured_accel"), py::arg("measured_gyro"), py::arg("simulated_accel"),
      py::arg("simulated_gyro"),
      "Per-axis RMSE and Pearson correlation of simulated against measured (n, 3) signals: "
      "{'accel': {'rmse', 'correlation'}, 'gyro': {...}, 'samples'} (NaN correlation for a "
      "constant axis).");
}

}  // namespace imukit::python
