// Allan-family deviations and the noise-model fit on NumPy arrays.
#include <memory>
#include <vector>

#include "common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/imu_series.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/hwmodel/allan.hpp"
#include "imukit/hwmodel/characterize.hpp"
#include "imukit/hwmodel/noise_fit.hpp"

namespace imukit::python {
namespace {

using hwmodel::AllanResult;
using hwmodel::DeviationCurve;
using hwmodel::NoiseFit;

// A curve of a result; the arrays are views that keep the whole result alive.
struct CurveHandle {
  std::shared_ptr<const AllanResult> result;
  const DeviationCurve* curve;
};

py::object curve_of(const std::shared_ptr<AllanResult>& r, hwmodel::Deviation d) {
  const DeviationCurve& c = r->curve(d);
  if (!c.computed) return py::none();
  return py::cast(CurveHandle{r, &c});
}

std::vector<double> row(const Eigen::MatrixXd& m, Eigen::Index axis) {
  std::vector<double> out(static_cast<std::size_t>(m.cols()));
  for (Eigen::Index k = 0; k < m.cols(); ++k) out[static_cast<std::size_t>(k)] = m(axis, k);
  return out;
}

hwmodel::NoiseFitOptions fit_options(std::optional<std::vector<std::string>> terms,
                                     double confidence, double tau_min_s, double tau_max_s) {
  hwmodel::NoiseFitOptions o;
  if (terms) {
    o.terms.fill(false);
    for (const std::string& t : *terms) {
      bool known = false;
      for (int k = 0; k < hwmodel::kNoiseTerms; ++k) {
        if (t == hwmodel::noise_term_name(k)) o.terms[static_cast<std::size_t>(k)] = known = true;
      }
      if (!known) throw Error("noise fit: unknown term '" + t + "' (terms are Q, N, B, K, R)");
    }
  }
  o.confidence = confidence;
  o.tau_min_s = tau_min_s;
  o.tau_max_s = tau_max_s;
  return o;
}

// (n, axes) or (n,) samples, read in place when float64 and C-contiguous: that memory is the
// axes x n column-major matrix allan_deviation takes, one column per sample.
std::shared_ptr<AllanResult> allan(py::handle samples_obj, py::handle t_obj,
                                   std::optional<double> rate_hz, int points_per_decade,
                                   int64_t max_factor, std::optional<std::vector<int64_t>> factors,
                                   bool allan_dev, bool modified, bool hadamard, double confidence,
                                   std::optional<int> alpha, unsigned threads) {
  const auto x = read_f64(samples_obj, "samples");
  if (x.ndim() != 1 && x.ndim() != 2) {
    throw py::value_error("samples: expected shape (n,) or (n, axes), got " + shape_string(x));
  }
  const py::ssize_t n = x.shape(0);
  const py::ssize_t axes = x.ndim() == 2 ? x.shape(1) : 1;
  std::vector<TimeNs> uniform;
  std::span<const TimeNs> t;
  py::array_t<int64_t, py::array::c_style> times;
  if (!t_obj.is_none()) {
    if (rate_hz) throw py::value_error("allan_deviation: give t or rate_hz, not both");
    times = read_times(t_obj, "t");
    if (times.shape(0) != n) {
      throw py::value_error("t: " + std::to_string(times.shape(0)) + " times for " +
                            std::to_string(n) + " samples");
    }
    t = std::span<const TimeNs>(times.data(), static_cast<std::size_t>(n));
  } else {
    if (!rate_hz || !(*rate_hz > 0.0 && std::isfinite(*rate_hz))) {
      throw py::value_error(
          "allan_deviation: give the sample times t (int64 ns) or a positive rate_hz");
    }
    // Before the times are made: at 1e-10 Hz they overflowed int64 (found in review).
    check_rate(*rate_hz, "allan_deviation: rate_hz");
    uniform.resize(static_cast<std::size_t>(n));
    for (py::ssize_t i = 0; i < n; ++i)
      uniform[static_cast<std::size_t>(i)] = sample_time(0, i, *rate_hz);
    t = uniform;
  }
  hwmodel::AllanOptions o;
  o.points_per_decade = points_per_decade;
  o.max_factor = max_factor;
  if (factors) o.factors = *factors;
  o.allan = allan_dev;
  o.modified = modified;
  o.hadamard = hadamard;
  o.confidence = confidence;
  // The noise types the confidence intervals know (hwmodel/allan.hpp); others were clamped
  // while DeviationCurve.alpha reported the value given (found in review, 2026-11-27).
  if (alpha && *alpha != 2 && *alpha != 0 && *alpha != -1 && *alpha != -2) {
    throw Error("allan_deviation: alpha must be 2, 0, -1 or -2 (or None: estimated), got " +
                std::to_string(*alpha));
  }
  o.alpha = alpha;
  o.threads = threads;
  const Eigen::Map<const Eigen::MatrixXd> matrix(x.data(), axes, n);
  py::gil_scoped_release release;
  return std::make_shared<AllanResult>(hwmodel::allan_deviation(t, matrix, o));
}

// Read-only views (fit reads this memory) that keep the Python owner alive.
template <class Scalar>
py::object read_only_view(const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& m,
                          py::handle owner) {
  return read_only(matrix_view(m, owner));
}
template <class T>
py::object read_only_view(const std::vector<T>& v, py::handle owner) {
  return read_only(vector_view(v, owner));
}

template <class Member>
auto curve_member(Member DeviationCurve::*member) {
  return [member](py::object self) {
    return read_only_view(self.cast<const CurveHandle&>().curve->*member, self);
  };
}

template <class Member>
auto result_member(Member AllanResult::*member) {
  return [member](py::object self) {
    return read_only_view(self.cast<const AllanResult&>().*member, self);
  };
}

py::dict fit_dict(const NoiseFit& f) {
  py::dict d;
  for (int k = 0; k < hwmodel::kNoiseTerms; ++k)
    d[hwmodel::noise_term_name(k)] = f.value[static_cast<std::size_t>(k)];
  return d;
}

}  // namespace

void bind_hwmodel(py::module_& m) {
  py::class_<CurveHandle>(m, "DeviationCurve", R"doc(
One deviation over the tau grid; arrays are (axes, taus) read-only views of the result:
deviation, lower, upper (confidence interval), edf (equivalent degrees of freedom), alpha (noise
type the interval assumed), terms (squared differences per estimate). AllanResult.fit reads this
memory: change a copy (np.array(curve.deviation)).)doc")
      .def_property_readonly("deviation", curve_member(&DeviationCurve::deviation))
      .def_property_readonly("lower", curve_member(&DeviationCurve::lower))
      .def_property_readonly("upper", curve_member(&DeviationCurve::upper))
      .def_property_readonly("edf", curve_member(&DeviationCurve::edf))
      .def_property_readonly("alpha", curve_member(&DeviationCurve::alpha))
      .def_property_readonly("terms", curve_member(&DeviationCurve::terms));

  py::class_<AllanResult, std::shared_ptr<AllanResult>>(m, "AllanResult", R"doc(
Result of allan_deviation: tau_s and factors (read-only views: fit reads them), tau0_s, uniform, sample count n, and the
curves allan, modified, hadamard (DeviationCurve, or None when not computed).
fit(axis, ...) fits the noise model to one axis' Allan deviation (generalised least squares,
as `imukit characterize` does).)doc")
      .def_property_readonly("tau_s", result_member(&AllanResult::tau_s))
      .def_property_readonly("factors", result_member(&AllanResult::factors))
      .def_property_readonly("tau0_s", [](const AllanResult& r) { return r.tau0_s; })
      .def_property_readonly("uniform", [](const AllanResult& r) { return r.uniform; })
      .def_property_readonly("n", [](const AllanResult& r) { return r.sampling.samples; })
      .def_property_readonly("allan",
                             [](const std::shared_ptr<AllanResult>& r) {
                               return curve_of(r, hwmodel::Deviation::kAllan);
                             })
      .def_property_readonly("modified",
                             [](const std::shared_ptr<AllanResult>& r) {
                               return curve_of(r, hwmodel::Deviation::kModifiedAllan);
                             })
      .def_property_readonly("hadamard",
                             [](const std::shared_ptr<AllanResult>& r) {
                               return curve_of(r, hwmodel::Deviation::kHadamard);
                             })
      .def(
          "fit",
          [](const AllanResult& r, py::handle axis_obj,
             std::optional<std::vector<std::string>> terms, double confidence, double tau_min_s,
             double tau_max_s) {
            if (!r.allan.computed)
              throw Error("AllanResult.fit: the Allan deviation was not computed (allan=False)");
            // Through index_argument: True was axis 1 (found in review, 2026-11-27).
            const py::int_ a = index_argument(axis_obj, "AllanResult.fit: axis");
            if (a < py::int_(0) || a >= py::int_(r.allan.deviation.rows())) {
              throw py::index_error("AllanResult.fit: axis " + py::repr(a).cast<std::string>() +
                                    " out of range");
            }
            const auto axis = a.cast<Eigen::Index>();
            const auto o = fit_options(terms, confidence, tau_min_s, tau_max_s);
            const std::vector<double> dev = row(r.allan.deviation, axis);
            py::gil_scoped_release release;
            return hwmodel::fit_noise_model_gls(r.tau_s, dev, r.factors, r.sampling.samples, o);
          },
          py::arg("axis") = 0, py::kw_only(), py::arg("terms") = py::none(),
          py::arg("confidence") = 0.95, py::arg("tau_min_s") = 0.0, py::arg("tau_max_s") = 1e300);

  m.def("allan_deviation", &allan, py::arg("samples"), py::arg("t") = py::none(), py::kw_only(),
        py::arg("rate_hz") = py::none(), py::arg("points_per_decade") = 10,
        py::arg("max_factor") = 0, py::arg("factors") = py::none(), py::arg("allan") = true,
        py::arg("modified") = true, py::arg("hadamard") = true,
        py::arg("confidence") = 0.6826894921370859, py::arg("alpha") = py::none(),
        py::arg("threads") = 0, R"doc(
Overlapping Allan, modified Allan and Hadamard deviations of samples ((n,) or (n, axes) rates;
float64 C-contiguous is read in place, float32 is converted) taken at times t (int64 ns) or at
rate_hz. alpha: the noise type the confidence intervals assume, 2 (white phase), 0 (white
frequency), -1 (flicker frequency) or -2 (random walk), or None to estimate it per point. The
GIL is released and the axes are shared among `threads` threads (0: all cores).)doc");

  py::class_<NoiseFit>(m, "NoiseFit", R"doc(
Noise-model coefficients Q (quantisation), N (white noise density), B (bias instability),
K (rate random walk), R (rate ramp): value, sigma, lower, upper and active as dicts by term
name; chi2_per_dof, points, covariance_inflation, note.)doc")
      .def_property_readonly("value", &fit_dict)
      .def_property_readonly("sigma",
                             [](const NoiseFit& f) {
                               NoiseFit g = f;
                               g.value = f.sigma;
                               return fit_dict(g);
                             })
      .def_property_readonly("lower",
                             [](const NoiseFit& f) {
                               NoiseFit g = f;
                               g.value = f.lower;
                               return fit_dict(g);
                             })
      .def_property_readonly("upper",
                             [](const NoiseFit& f) {
                               NoiseFit g = f;
                               g.value = f.upper;
                               return fit_dict(g);
                             })
      .def_property_readonly("active",
                             [](const NoiseFit& f) {
                               py::dict d;
                               for (int k = 0; k < hwmodel::kNoiseTerms; ++k)
                                 d[hwmodel::noise_term_name(k)] =
                                     f.active[static_cast<std::size_t>(k)];
                               return d;
                             })
      .def_readonly("chi2_per_dof", &NoiseFit::chi2_per_dof)
      .def_readonly("points", &NoiseFit::points)
      .def_readonly("covariance_inflation", &NoiseFit::covariance_inflation)
      .def_readonly("note", &NoiseFit::note,
                    "why selected terms were not fitted (a curve too short), or ''")
      .def("__getitem__",
           [](const NoiseFit& f, const std::string& term) {
             for (int k = 0; k < hwmodel::kNoiseTerms; ++k) {
               if (term == hwmodel::noise_term_name(k)) return f.value[static_cast<std::size_t>(k)];
             }
             throw py::key_error(term);
           })
      .def("__repr__", [](const NoiseFit& f) {
        std::string s = "<imukit.NoiseFit";
        for (int k = 0; k < hwmodel::kNoiseTerms; ++k) {
          s += std::string(" ") + hwmodel::noise_term_name(k) + "=" +
               std::to_string(f.value[static_cast<std::size_t>(k)]);
        }
        return s + ">";
      });

  m.def(
      "fit_noise_model",
      [](std::vector<double> tau, std::vector<double> adev, std::vector<double> edf,
         std::optional<std::vector<std::string>> terms, double confidence, double tau_min_s,
         double tau_max_s) {
        const auto o = fit_options(terms, confidence, tau_min_s, tau_max_s);
        py::gil_scoped_release release;
        return hwmodel::fit_noise_model(tau, adev, edf, o);
      },
      py::arg("tau_s"), py::arg("adev"), py::arg("edf"), py::kw_only(),
      py::arg("terms") = py::none(), py::arg("confidence") = 0.95, py::arg("tau_min_s") = 0.0,
      py::arg("tau_max_s") = 1e300,
      "Weighted fit of a curve whose raw data are not at hand (estimates treated as independent).");
  m.def(
      "fit_noise_model_gls",
      [](std::vector<double> tau, std::vector<double> adev, std::vector<int64_t> factors, int64_t n,
         std::optional<std::vector<std::string>> terms, double confidence, double tau_min_s,
         double tau_max_s) {
        const auto o = fit_options(terms, confidence, tau_min_s, tau_max_s);
        py::gil_scoped_release release;
        return hwmodel::fit_noise_model_gls(tau, adev, factors, n, o);
      },
      py::arg("tau_s"), py::arg("adev"), py::arg("factors"), py::arg("n"), py::kw_only(),
      py::arg("terms") = py::none(), py::arg("confidence") = 0.95, py::arg("tau_min_s") = 0.0,
      py::arg("tau_max_s") = 1e300,
      "Generalised least squares on an overlapping ADEV of n samples at `factors`.");
  m.def(
      "characterize",
      [](const ImuSeries& series, int points_per_decade, double fit_tau_min_s) {
        const hwmodel::TriadNoiseOptions o{points_per_decade, fit_tau_min_s};
        DeviceProfile p;
        py::gil_scoped_release release;
        if (series.has_accel()) {
          p.accelerometer = SensorProfile{};
          p.accelerometer->noise =
              hwmodel::noise_estimate(hwmodel::characterize_triad(series.t, series.accel, o));
        }
        if (series.has_gyro()) {
          p.gyroscope = GyroscopeProfile{};
          p.gyroscope->noise =
              hwmodel::noise_estimate(hwmodel::characterize_triad(series.t, series.gyro, o));
        }
        if (series.size() == 0) throw Error("characterize: the series holds no samples");
        if (!p.accelerometer && !p.gyroscope)
          throw Error("characterize: the series holds neither accelerometer nor gyroscope samples");
        return p;
      },
      py::arg("series"), py::kw_only(), py::arg("points_per_decade") = 10,
      py::arg("fit_tau_min_s") = 0.0, R"doc(
The noise sections of a device profile from a static recording, as `imukit characterize` writes
them for one input: per accelerometer and gyroscope the overlapping Allan deviation, the GLS
noise-model fit (N, B, K with 1-sigma) and the curve. Returns an imukit.Profile (write(path)
writes the file; to_dict() the sections).)doc");
  m.def(
      "model_allan_variance",
      [](std::array<double, hwmodel::kNoiseTerms> c, double tau) {
        return hwmodel::model_allan_variance(c, tau);
      },
      py::arg("coefficients"), py::arg("tau_s"),
      "AVAR(tau) of the model with coefficients (Q, N, B, K, R).");
}

}  // namespace imukit::python
