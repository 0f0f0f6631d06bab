// Body motion from 3D keypoints (sim/keypoints.hpp, docs/keypoints.md).
#include "common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/sim/keypoints.hpp"

namespace imukit::python {
namespace {

using sim::Body;

// A topology argument: a built-in name, a JSON file name, or a dict in the JSON layout.
sim::KeypointTopology topology_argument(py::handle obj) {
  if (py::isinstance<py::str>(obj)) return sim::load_keypoint_topology(obj.cast<std::string>());
  if (py::isinstance<py::dict>(obj)) {
    const std::string text = py::module_::import("json").attr("dumps")(obj).cast<std::string>();
    return sim::parse_keypoint_topology(text, "<topology dict>");
  }
  throw py::type_error("topology: expected a name (kinect_v1_20, h36m_17), a JSON file or a dict");
}

py::object topology_dict(const sim::KeypointTopology& t) {
  return py::module_::import("json").attr("loads")(sim::keypoint_topology_json(t));
}

py::array_t<double> matrix(const Eigen::Matrix3d& m) {
  py::array_t<double> out({py::ssize_t{3}, py::ssize_t{3}});
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.mutable_at(r, c) = m(r, c);
  }
  return out;
}

py::tuple xyz_tuple(const Eigen::Vector3d& v) { return py::make_tuple(v.x(), v.y(), v.z()); }

py::tuple motion_from_keypoints(py::handle keypoints, py::handle topology, py::handle rate_hz,
                                py::handle times, double output_rate_hz, double cutoff_hz,
                                py::handle up, const Body* body, bool fix_swaps,
                                bool drop_frozen_frames, double max_bone_deviation,
                                double jump_speed_mps, double twist_min_angle_deg,
                                double twist_full_angle_deg) {
  const sim::KeypointTopology topo = topology_argument(topology);
  const auto a = read_f64(keypoints, "keypoints");
  if (a.ndim() != 3 || a.shape(2) != 3) {
    throw py::value_error("keypoints: expected shape (frames, keypoints, 3), got " +
                          shape_string(a));
  }
  sim::Keypoints k;
  k.keypoints = static_cast<std::size_t>(a.shape(1));
  k.positions = Eigen::Map<const Eigen::Matrix3Xd>(a.data(), 3, a.shape(0) * a.shape(1));
  if (rate_hz.is_none() == times.is_none())
    throw py::value_error("motion_from_keypoints: give exactly one of rate_hz= and times=");
  if (!times.is_none()) {
    const auto t = read_f64(times, "times");
    if (t.ndim() != 1 || t.shape(0) != a.shape(0))
      throw py::value_error("times: expected shape (" + std::to_string(a.shape(0)) + ",), got " +
                            shape_string(t));
    k.t_s.assign(t.data(), t.data() + t.shape(0));
  } else {
    k.rate_hz = number_argument(rate_hz, "motion_from_keypoints: rate_hz");
  }
  sim::KeypointMotionOptions o;
  o.rate_hz = output_rate_hz;
  o.cutoff_hz = cutoff_hz;
  if (!up.is_none()) {
    const auto u = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(up);
    if (!u || u.ndim() != 1 || u.shape(0) != 3) throw py::value_error("up: expected 3 numbers");
    o.up = Eigen::Vector3d(u.at(0), u.at(1), u.at(2));
  }
  if (body != nullptr) o.body = *body;
  o.fix_swaps = fix_swaps;
  o.drop_frozen_frames = drop_frozen_frames;
  o.max_bone_deviation = max_bone_deviation;
  o.jump_speed_mps = jump_speed_mps;
  o.twist_min_angle_deg = twist_min_angle_deg;
  o.twist_full_angle_deg = twist_full_angle_deg;
  std::shared_ptr<sim::KeypointMotion> r;
  {
    py::gil_scoped_release release;
    r = std::make_shared<sim::KeypointMotion>(sim::motion_from_keypoints(k, topo, o));
  }
  py::dict info;
  info["warnings"] = r->warnings;
  info["start_s"] = r->start_s;
  info["R_world_input"] = matrix(r->R_world_input);
  info["origin_input"] = xyz_tuple(r->origin_input);
  info["up_input"] = xyz_tuple(r->up_input);
  info["up_source"] = r->up_source;
  info["input_rate_hz"] = r->input_rate_hz;
  info["missing_frames"] = r->missing_frames;
  info["frozen_frames"] = r->frozen_frames;
  info["swapped_frames"] = r->swapped_frames;
  info["outlier_frames"] = r->outlier_frames;
  info["jump_frames"] = r->jump_frames;
  info["flagged_frames"] = r->flagged_frames;
  info["invalid_motion_ns"] = r->invalid_motion;
  py::list segs;
  for (const sim::SegmentReport& s : r->segments) {
    py::dict d;
    d["joint"] = s.joint;
    d["length_m"] = s.length_m;
    d["length_iqr_m"] = s.length_iqr_m;
    d["twist_observed"] = s.twist_observed;
    segs.append(d);
  }
  info["segments"] = segs;
  return py::make_tuple(std::make_shared<Body>(std::move(r->body)),
                        std::make_shared<sim::Motion>(std::move(r->motion)), info);
}

}  // namespace

void bind_keypoints(py::module_& m) {
  m.def("motion_from_keypoints", &motion_from_keypoints, py::arg("keypoints"), py::arg("topology"),
        py::arg("rate_hz") = py::none(), py::arg("times") = py::none(), py::kw_only(),
        py::arg("output_rate_hz") = 100.0, py::arg("cutoff_hz") = 3.0, py::arg("up") = py::none(),
        py::arg("body") = nullptr, py::arg("fix_swaps") = true,
        py::arg("drop_frozen_frames") = true, py::arg("max_bone_deviation") = 0.3,
        py::arg("jump_speed_mps") = 4.0, py::arg("twist_min_angle_deg") = 10.0,
        py::arg("twist_full_angle_deg") = 25.0, R"doc(
Body motion from 3D keypoints (docs/keypoints.md): keypoints (frames, J, 3) in metres (NaN =
missing) in any fixed right-handed frame, the topology (a name: kinect_v1_20, h36m_17; a JSON file;
or a dict), and the frame times: rate_hz= or times= (s). Returns (Body, Motion, info): the motion
at output_rate_hz, smoothed with gain 1/2 at cutoff_hz; info holds the warnings (naming input
frames), the world frame (R_world_input, origin_input, up_input, up_source), the repaired frames,
invalid_motion_ns (filled stretches, for identification) and per-segment lengths and the fraction
of frames whose twist was observed. up: the up direction in the input frame (e.g. minus the IMU's
gravity at rest, mapped to the camera); body: offsets to use (per-subject, see average_bodies).)doc");
  m.def(
      "keypoint_topology", [](py::handle t) { return topology_dict(topology_argument(t)); },
      py::arg("topology"), "A topology (name, JSON file or dict) as a dict in the JSON layout.");
  m.def("keypoint_topology_names", &sim::keypoint_topology_names);
  m.def(
      "average_bodies",
      [](const std::vector<std::shared_ptr<Body>>& bodies) {
        std::vector<Body> b;
        for (const auto& p : bodies) b.push_back(*p);
        return std::make_shared<Body>(sim::average_bodies(b));
      },
      py::arg("bodies"), "The joint-wise median offsets of bodies with the same joints.");
  m.def(
      "world_poses",
      [](const Body& body, const sim::Motion& motion) {
        // Forward kinematics and the copies run with the GIL released (60,000 frames held it
        // for 134 ms, found in review); only the arrays are allocated with it.
        const auto F = static_cast<py::ssize_t>(motion.frames());
        const auto J = static_cast<py::ssize_t>(body.size());
        py::array_t<double> p({F, J, py::ssize_t{3}});
        py::array_t<double> q({F, J, py::ssize_t{4}});
        double* pd = p.mutable_data();
        double* qd = q.mutable_data();
        {
          py::gil_scoped_release release;
          const sim::WorldPoses w = sim::world_poses(body, motion);
          // w.joints is the body's joint count J (world_poses checks the motion's against it).
          std::copy(w.positions.data(), w.positions.data() + w.positions.size(), pd);
          for (const Eigen::Quaterniond& r : w.rotations) {
            *qd++ = r.w(), *qd++ = r.x(), *qd++ = r.y(), *qd++ = r.z();
          }
        }
        return py::make_tuple(p, q);
      },
      py::arg("body"), py::arg("motion"),
      "World positions (frames, joints, 3) and rotations R_world_joint (frames, joints, 4; w x y "
      "z) "
      "by forward kinematics.");
  m.def(
      "read_keypoints",
      [](const std::string& path, py::handle topology, std::optional<double> rate_hz) {
        const sim::KeypointTopology topo = topology_argument(topology);
        sim::Keypoints k;
        {
          py::gil_scoped_release release;
          k = sim::read_keypoints(path, topo, rate_hz);
        }
        const auto F = static_cast<py::ssize_t>(k.frames());
        py::array_t<double> p({F, static_cast<py::ssize_t>(k.keypoints), py::ssize_t{3}});
        std::copy(k.positions.data(), k.positions.data() + k.positions.size(), p.mutable_data());
        std::vector<double> t = k.t_s;
        if (t.empty()) {
          for (py::ssize_t f = 0; f < F; ++f) t.push_back(static_cast<double>(f) / k.rate_hz);
        }
        return py::make_tuple(p, py::array_t<double>(static_cast<py::ssize_t>(t.size()), t.data()));
      },
      py::arg("path"), py::arg("topology"), py::arg("rate_hz") = py::none(),
      "A keypoint CSV or .npy file (docs/formats.md): (positions (frames, J, 3), times (frames,) "
      "s).");
}

}  // namespace imukit::python
