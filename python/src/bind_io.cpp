// Series, recordings (MCAP, EuRoC CSV) and device profiles.
#include <memory>

#include "common.hpp"
#include "imukit/capture/recording_mcap.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/profile.hpp"

namespace imukit::python {
namespace {

using SeriesPtr = std::shared_ptr<ImuSeries>;

constexpr const char* kAxes[] = {"x", "y", "z"};

// Copies a (n, 3) float array into a 3 x n channel (the Series owns its samples).
void set_triad(Eigen::Matrix3Xd& channel, py::handle obj, py::ssize_t n, const char* what) {
  if (obj.is_none()) {
    channel.resize(3, 0);
    return;
  }
  const auto a = read_f64(obj, what);
  const auto m = map_triad(a, n, what);
  require_finite(a.data(), n, 3, std::string("Series: ") + what, kAxes,
                 "; a Series holds finite samples");
  channel = m;
}

// A Series' samples are finite: NaN or infinity were taken silently and came out of every
// computation on them (found in review, 2026-11-26; DESIGN.md: never a silent NaN).
SeriesPtr make_series(py::handle t, py::handle accel, py::handle gyro, py::handle mag,
                      py::handle temperature) {
  auto s = std::make_shared<ImuSeries>();
  const auto times = read_times(t, "t");
  s->t.assign(times.data(), times.data() + times.size());
  const py::ssize_t n = times.size();
  set_triad(s->accel, accel, n, "accel");
  set_triad(s->gyro, gyro, n, "gyro");
  set_triad(s->mag, mag, n, "mag");
  if (!temperature.is_none()) {
    const auto temp = read_f64(temperature, "temperature");
    if (temp.ndim() != 1 || temp.shape(0) != n) {
      throw py::value_error("temperature: expected shape (" + std::to_string(n) + ",), got " +
                            shape_string(temp));
    }
    constexpr const char* kColumn[] = {"temperature"};
    require_finite(temp.data(), n, 1, "Series: temperature", kColumn,
                   "; a Series holds finite samples");
    s->temperature_c = Eigen::Map<const Eigen::VectorXd>(temp.data(), n);
  }
  s->validate();
  return s;
}

// A channel of a Series as a (n, 3) view, None when absent. A Series without samples cannot
// tell an absent channel from an empty one (core's ImuSeries: has_accel() is cols() > 0), so
// all its channels are empty (0, 3) arrays: found in review, a 0-length Series built with accel
// and gyro showed them as None.
py::object channel_view(const py::object& self, const Eigen::Matrix3Xd ImuSeries::*channel) {
  const ImuSeries& s = self.cast<const ImuSeries&>();
  if (s.size() == 0) return read_only(py::array_t<double>(std::vector<py::ssize_t>{0, 3}));
  return read_only(triad_view(s.*channel, self));
}

// accel and gyro as one (n, 6) array, channels ax ay az gx gy gz (the dataset order of
// DESIGN.md), in the dtype asked for: a new array, since the channels are stored apart.
py::array stacked(const ImuSeries& s, py::handle dtype_obj) {
  const py::dtype dtype = py::dtype::from_args(py::reinterpret_borrow<py::object>(dtype_obj));
  if (s.size() != 0 && (!s.has_accel() || !s.has_gyro())) {
    throw Error("Series.channels: needs both accelerometer and gyroscope");
  }
  const auto n = static_cast<py::ssize_t>(s.size());
  auto fill = [&](auto* out) {
    for (py::ssize_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        out[6 * i + k] = static_cast<std::remove_pointer_t<decltype(out)>>(s.accel(k, i));
        out[6 * i + 3 + k] = static_cast<std::remove_pointer_t<decltype(out)>>(s.gyro(k, i));
      }
    }
  };
  if (dtype.is(py::dtype::of<float>())) {
    py::array_t<float> out({n, py::ssize_t{6}});
    fill(out.mutable_data());
    return out;
  }
  if (dtype.is(py::dtype::of<double>())) {
    py::array_t<double> out({n, py::ssize_t{6}});
    fill(out.mutable_data());
    return out;
  }
  throw py::type_error("Series.channels: dtype must be float32 or float64, got " +
                       py::str(py::handle(dtype)).cast<std::string>());
}

struct RecordingHandle {
  capture::RecordingRead read;
};

py::dict streams_of(const std::shared_ptr<RecordingHandle>& h) {
  py::dict out;
  for (auto& [name, series] : h->read.recording.streams) {
    // Aliasing shared_ptr: the Series keeps the whole recording alive, nothing is copied.
    out[py::str(name)] = SeriesPtr(h, &series);
  }
  return out;
}

// A profile argument: a Profile, a dict in the file's layout or a file name. With rate_hz, the
// rules that depend on the rate the model runs at are checked as read_scene checks a sensor's
// hardware, naming the profile's key (accelerometer.limits.bandwidth).
DeviceProfile profile_from(py::handle obj, std::optional<double> rate_hz) {
  if (py::isinstance<py::str>(obj)) {
    const auto path = obj.cast<std::string>();
    return rate_hz ? read_profile_for_rate(path, *rate_hz) : read_profile(path);
  }
  std::string text, source;
  if (py::isinstance<DeviceProfile>(obj)) {
    if (!rate_hz) return obj.cast<DeviceProfile>();
    text = format_profile(obj.cast<const DeviceProfile&>());
    source = "<Profile>";
  } else if (py::isinstance<py::dict>(obj)) {
    text = py::module_::import("json").attr("dumps")(obj).cast<std::string>();
    source = "<dict>";
  } else {
    throw py::type_error("expected an imukit.Profile, a profile dict or a file name");
  }
  try {
    const DeviceProfile p = parse_profile(text, source);
    if (rate_hz) parse_inline_profile(text, text, "", source, rate_hz);
    return p;
  } catch (const Error& e) {
    // A line and column in a serialisation would point nowhere the caller can see: the error
    // names the dict (or Profile) and the JSON path only ("<dict>: clock.error_ppm: ...").
    throw Error(InputLocation{source, {}, {}, {}}, e.reason());
  }
}

}  // namespace

// Used by bind_sim for sensors' hardware (Profile, dict or file name) at the scene's rate.
DeviceProfile profile_argument(py::handle obj, std::optional<double> rate_hz) {
  return profile_from(obj, rate_hz);
}

void bind_io(py::module_& m) {
  py::class_<ImuSeries, SeriesPtr>(m, "Series", R"doc(
One IMU stream in SI units: t (int64 ns), accel (m/s^2), gyro (rad/s), mag (T), each (n, 3)
float64, temperature (n,) degrees C; absent channels are None. The arrays are read-only views
of the Series' own memory (no copy); they keep it alive. To change samples, change a copy
(np.array(s.accel)) and make a new Series: its samples are checked once, when it is made.

Series(t, accel=None, gyro=None, mag=None, temperature=None) copies the given arrays.)doc")
      .def(py::init(&make_series), py::arg("t"), py::arg("accel") = py::none(),
           py::arg("gyro") = py::none(), py::arg("mag") = py::none(),
           py::arg("temperature") = py::none())
      .def("__len__", &ImuSeries::size)
      .def_property_readonly("t",
                             [](py::object self) {
                               return read_only(vector_view(self.cast<const ImuSeries&>().t, self));
                             })
      .def_property_readonly("accel",
                             [](py::object self) { return channel_view(self, &ImuSeries::accel); })
      .def_property_readonly("gyro",
                             [](py::object self) { return channel_view(self, &ImuSeries::gyro); })
      .def_property_readonly("mag",
                             [](py::object self) { return channel_view(self, &ImuSeries::mag); })
      .def_property_readonly(
          "temperature",
          [](py::object self) -> py::object {
            const ImuSeries& s = self.cast<const ImuSeries&>();
            if (!s.has_temperature()) return py::none();
            return read_only(
                view_of(s.temperature_c.data(), {s.temperature_c.size()}, {sizeof(double)}, self));
          })
      .def("channels", &stacked, py::arg("dtype") = py::dtype::of<float>(),
           "accel and gyro as a new (n, 6) array, channels ax ay az gx gy gz (float32 by default)")
      .def("__repr__", [](const ImuSeries& s) {
        std::string channels;
        for (auto [has, name] : {std::pair{s.has_accel(), "accel"},
                                 {s.has_gyro(), "gyro"},
                                 {s.has_mag(), "mag"},
                                 {s.has_temperature(), "temperature"}}) {
          if (has) channels += std::string(channels.empty() ? "" : ", ") + name;
        }
        return "<imukit.Series " + std::to_string(s.size()) + " samples: " + channels + ">";
      });

  m.def(
      "read_euroc_csv",
      [](const std::string& path) {
        py::gil_scoped_release release;
        return std::make_shared<ImuSeries>(read_euroc_csv(path));
      },
      py::arg("path"), "Reads a EuRoC / Kalibr IMU CSV into a Series.");
  m.def(
      "parse_euroc_csv",
      [](const std::string& text, const std::string& source_name) {
        py::gil_scoped_release release;
        return std::make_shared<ImuSeries>(parse_euroc_csv(text, source_name));
      },
      py::arg("text"), py::arg("source_name") = "<string>");
  m.def(
      "write_euroc_csv",
      [](const std::string& path, py::handle t_obj, py::handle accel_obj, py::handle gyro_obj) {
        // The arrays are read in place (float64, C-contiguous) through a core series view.
        const auto t = read_times(t_obj, "t");
        const auto accel = read_f64(accel_obj, "accel");
        const auto gyro = read_f64(gyro_obj, "gyro");
        const py::ssize_t n = t.size();
        const ImuSeriesView view(std::span<const TimeNs>(t.data(), static_cast<std::size_t>(n)),
                                 map_triad(accel, n, "accel"), map_triad(gyro, n, "gyro"),
                                 ImuSeriesView::Map3X(nullptr, 3, 0),
                                 ImuSeriesView::MapX(nullptr, 0));
        // read_euroc_csv refuses NaN and infinity, so the file would not read back (found in
        // review, 2026-11-26): refused before anything is written.
        constexpr const char* kAccel[] = {"a_RS_S_x", "a_RS_S_y", "a_RS_S_z"};
        constexpr const char* kGyro[] = {"w_RS_S_x", "w_RS_S_y", "w_RS_S_z"};
        const std::string why = "; a EuRoC CSV holds finite numbers";
        require_finite(accel.data(), n, 3, "write_euroc_csv: accel", kAccel, why);
        require_finite(gyro.data(), n, 3, "write_euroc_csv: gyro", kGyro, why);
        py::gil_scoped_release release;
        write_euroc_csv(path, view);
      },
      py::arg("path"), py::arg("t"), py::arg("accel"), py::arg("gyro"),
      "Writes t (int64 ns), accel and gyro ((n, 3) float64) as a EuRoC CSV.");

  py::class_<RecordingHandle, std::shared_ptr<RecordingHandle>>(m, "Recording", R"doc(
An MCAP recording read by read_mcap: streams (dict name -> Series, views of the recording's
memory), metadata (dict), events (list of (t_ns, kind, label)), complete (False when the file
was cut short; truncation_note says where).)doc")
      .def_property_readonly("streams", &streams_of)
      .def_property_readonly("metadata",
                             [](const RecordingHandle& h) { return h.read.recording.metadata; })
      .def_property_readonly("events",
                             [](const RecordingHandle& h) {
                               py::list out;
                               for (const Event& e : h.read.recording.events)
                                 out.append(py::make_tuple(e.t, e.kind, e.label));
                               return out;
                             })
      .def_property_readonly("complete",
                             [](const RecordingHandle& h) { return h.read.summary.complete; })
      .def_property_readonly(
          "truncation_note",
          [](const RecordingHandle& h) { return h.read.summary.truncation_note; })
      .def("__repr__", [](const RecordingHandle& h) {
        return "<imukit.Recording " + std::to_string(h.read.recording.streams.size()) + " streams>";
      });
  m.def(
      "read_mcap",
      [](const std::string& path) {
        auto h = std::make_shared<RecordingHandle>();
        {
          py::gil_scoped_release release;
          h->read = capture::read_recording_mcap(path);
        }
        return h;
      },
      py::arg("path"),
      "Reads an imukit MCAP recording (sensor_msgs/Imu topics, events, metadata).");

  py::class_<DeviceProfile>(m, "Profile", R"doc(
A device profile (imukit.profile/1): noise, turn-on bias, calibration and limits per sensor.
read_profile(path) / parse_profile(text); to_json() gives the file's text, to_dict() the parsed
JSON.)doc")
      .def("to_json", &format_profile)
      .def("to_dict",
           [](const DeviceProfile& p) {
             return py::module_::import("json").attr("loads")(format_profile(p));
           })
      .def(
          "write", [](const DeviceProfile& p, const std::string& path) { write_profile(path, p); },
          py::arg("path"), py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("name",
                             [](const DeviceProfile& p) -> py::object {
                               if (!p.device) return py::none();
                               return py::str(p.device->name);
                             })
      .def("__eq__", [](const DeviceProfile& a, const DeviceProfile& b) { return a == b; })
      .def("__repr__", [](const DeviceProfile& p) {
        std::string parts;
        if (p.accelerometer) parts += " accelerometer";
        if (p.gyroscope) parts += " gyroscope";
        if (p.magnetometer) parts += " magnetometer";
        return "<imukit.Profile" + parts + ">";
      });
  m.def("read_profile", &read_profile, py::arg("path"), py::call_guard<py::gil_scoped_release>());
  m.def("parse_profile", &parse_profile, py::arg("text"), py::arg("source_name") = "<string>",
        py::call_guard<py::gil_scoped_release>());
  m.def(
      "profile", [](py::handle p) { return profile_from(p, std::nullopt); }, py::arg("profile"),
      "A Profile from a Profile, a dict in the imukit.profile/1 layout or a file name.");
}

}  // namespace imukit::python
