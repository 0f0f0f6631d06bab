#include "imukit/hwmodel/characterize.hpp"

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"

namespace imukit::hwmodel {

TriadNoise characterize_triad(std::span<const TimeNs> t, const Eigen::Matrix3Xd& x,
                              const TriadNoiseOptions& options) {
  TriadNoise out;
  AllanOptions opt;
  opt.points_per_decade = options.points_per_decade;
  out.allan = allan_deviation(t, x, opt);
  const auto& a = out.allan.allan;
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<double> dev, lo, hi;
    for (Eigen::Index k = 0; k < a.deviation.cols(); ++k) {
      dev.push_back(a.deviation(ax, k));
      lo.push_back(a.lower(ax, k));
      hi.push_back(a.upper(ax, k));
    }
    NoiseFitOptions fo;
    fo.tau_min_s = options.fit_tau_min_s;
    AxisNoise& axis = out.axes[static_cast<std::size_t>(ax)];
    if (std::all_of(dev.begin(), dev.end(), [](double d) { return d == 0.0; })) {
      axis.constant = true;
      continue;
    }
    try {
      axis.fit = fit_noise_model_gls(out.allan.tau_s, dev, out.allan.factors,
                                     static_cast<int64_t>(t.size()), fo);
    } catch (const Error& e) {
      throw Error(std::string("axis ") + "xyz"[ax] + ": " + e.what());
    }
    axis.slopes = read_slopes(out.allan.tau_s, dev, lo, hi);
  }
  return out;
}

NoiseEstimate noise_estimate(const TriadNoise& noise) {
  NoiseEstimate e;
  Eigen::Vector3d n, ns, b, bs, k, ks;
  for (int ax = 0; ax < 3; ++ax) {
    const NoiseFit& f = noise.axes[static_cast<std::size_t>(ax)].fit;
    n(ax) = f.value[kWhite], ns(ax) = f.sigma[kWhite];
    b(ax) = f.value[kBiasInstability], bs(ax) = f.sigma[kBiasInstability];
    k(ax) = f.value[kRandomWalk], ks(ax) = f.sigma[kRandomWalk];
  }
  e.noise_density = n, e.noise_density_sigma = ns;
  e.bias_instability = b, e.bias_instability_sigma = bs;
  e.random_walk = k, e.random_walk_sigma = ks;
  AllanCurve c;
  c.tau_s = noise.allan.tau_s;
  for (int ax = 0; ax < 3; ++ax) {
    for (Eigen::Index q = 0; q < noise.allan.allan.deviation.cols(); ++q)
      c.adev[static_cast<std::size_t>(ax)].push_back(noise.allan.allan.deviation(ax, q));
  }
  e.allan = c;
  return e;
}

Calibration calibration_section(const TriadCalibration& c, bool raw_counts, double residual_rms,
                                double residual_max, int64_t residual_count) {
  Calibration p;
  p.scale = c.forward_scale();
  p.misalignment = c.forward_misalignment();
  p.bias = c.bias;
  p.raw_counts = raw_counts;
  p.residual = CalibrationResidual{residual_rms, residual_max, residual_count};
  return p;
}

DeviceProfile calibration_profile(const CalibrationResult& r, bool raw_counts, bool gyro,
                                  double gravity) {
  DeviceProfile p;
  p.gravity = gravity;
  p.accelerometer = SensorProfile{};
  p.accelerometer->calibration =
      calibration_section(r.accel, raw_counts, r.accel_rms, r.accel_max,
                          static_cast<int64_t>(r.accel_norm_error.size()));
  if (gyro) {
    p.gyroscope = GyroscopeProfile{};
    p.gyroscope->calibration =
        calibration_section(r.gyro, raw_counts, r.gyro_rms_rad, r.gyro_max_rad,
                            static_cast<int64_t>(r.gyro_direction_error_rad.size()));
  }
  return p;
}

}  // namespace imukit::hwmodel
