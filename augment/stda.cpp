// STDA methods on contiguous (N, T, C) batches (augment/stda.hpp).
#include "imukit/augment/stda.hpp"

#include <fmt/core.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "imukit/core/error.hpp"
#include "imukit/core/interpolation.hpp"
#include "imukit/core/units.hpp"

namespace imukit::augment {

ChannelLayout ChannelLayout::imu(const std::vector<std::string>& sensor_names) {
  ChannelLayout layout;
  for (std::size_t s = 0; s < sensor_names.size(); ++s) {
    for (int k = 0; k < 3; ++k) layout.kinds.push_back(ChannelKind::accelerometer);
    for (int k = 0; k < 3; ++k) layout.kinds.push_back(ChannelKind::gyroscope);
    layout.sensors.push_back({sensor_names[s], {6 * s, 6 * s + 3}});
  }
  return layout;
}

void ChannelLayout::validate(std::size_t channels) const {
  if (kinds.size() != channels) {
    throw Error(
        fmt::format("channel layout: {} channel kinds for {} channels", kinds.size(), channels));
  }
  for (const SensorChannels& s : sensors) {
    for (std::size_t first : s.triads) {
      if (first + 3 > channels) {
        throw Error(
            fmt::format("channel layout: sensor {}: 3-axis block at channel {} outside {} "
                        "channels",
                        s.name, first, channels));
      }
    }
  }
}

namespace {

constexpr std::array<std::string_view, 7> kMethodNames = {
    "identity",     "magnitude_scaling", "magnitude_warping", "time_scaling",
    "time_warping", "rotation",          "jittering"};

// The parameters of one method come either from an Rng (and are optionally logged) or from a
// log being replayed; the methods below are written once against this interface.
class DrawSource {
 public:
  DrawSource(Rng* rng, StdaDraws* log, const StdaDraws* replay)
      : rng_(rng), log_(log), replay_(replay) {}
  // N(mean, sigma^2): the logged value is the drawn parameter itself.
  double normal(double mean, double sigma) {
    return take([&] { return mean + sigma * rng_->normal(); });
  }
  double uniform(double lo, double hi) {
    // Rng::uniform needs lo < hi; an empty range still takes its draw, so the number of draws
    // does not depend on the parameters.
    return take([&] {
      const double u = rng_->uniform();
      return lo == hi ? lo : lo + (hi - lo) * u;
    });
  }
  // n standard normals at once (fill_normal is faster than n calls).
  void normals(std::span<double> out) {
    if (replay_ != nullptr) {
      for (double& v : out) v = next_replayed();
    } else {
      rng_->fill_normal(out);
      if (log_ != nullptr) log_->values.insert(log_->values.end(), out.begin(), out.end());
    }
  }

 private:
  template <class F>
  double take(F draw) {
    if (replay_ != nullptr) return next_replayed();
    const double v = draw();
    if (log_ != nullptr) log_->values.push_back(v);
    return v;
  }
  double next_replayed() { return replay_->values[pos_++]; }
  Rng* rng_;
  StdaDraws* log_;
  const StdaDraws* replay_;
  std::size_t pos_ = 0;
};

std::size_t draws_per_window(const StdaSpec& spec, const BatchShape& shape) {
  const std::size_t curves = spec.per_channel ? shape.channels : 1;
  switch (spec.method) {
    case StdaMethod::identity:
      return 0;
    case StdaMethod::magnitude_scaling:
      return curves;
    case StdaMethod::magnitude_warping:
      return curves * static_cast<std::size_t>(spec.knots + 2);
    case StdaMethod::time_scaling:
      return 1;
    case StdaMethod::time_warping:
      return static_cast<std::size_t>(spec.knots + 1);
    case StdaMethod::rotation:
      return 3;
    case StdaMethod::jittering:
      return shape.samples * shape.channels;
  }
  return 0;
}

// out(i, :) = x at fractional sample position pos[i] (linear), for one window (T x C, C order).
template <class T>
void resample_window(T* x, std::size_t samples, std::size_t channels, std::span<const double> pos,
                     std::vector<T>& scratch) {
  scratch.assign(x, x + samples * channels);
  const double last = static_cast<double>(samples - 1);
  for (std::size_t i = 0; i < samples; ++i) {
    const double p = std::clamp(pos[i], 0.0, last);
    std::size_t k = static_cast<std::size_t>(p);
    if (k >= samples - 1) k = samples > 1 ? samples - 2 : 0;
    const double f = samples > 1 ? p - static_cast<double>(k) : 0.0;
    const T* a = scratch.data() + k * channels;
    const T* b = samples > 1 ? a + channels : a;
    T* o = x + i * channels;
    if (f == 0.0) {
      std::copy(a, a + channels, o);
    } else {
      const T wf = static_cast<T>(f);
      for (std::size_t c = 0; c < channels; ++c) o[c] = a[c] + wf * (b[c] - a[c]);
    }
  }
}

template <class T>
void run(const StdaSpec& spec, const ChannelLayout& layout, std::span<T> batch,
         const BatchShape& shape, DrawSource& src) {
  const std::size_t T_ = shape.samples, C = shape.channels;
  std::vector<T> scratch;
  std::vector<double> buf, pos(T_);
  for (std::size_t w = 0; w < shape.windows; ++w) {
    T* x = batch.data() + w * T_ * C;
    switch (spec.method) {
      case StdaMethod::identity:
        break;
      case StdaMethod::magnitude_scaling: {
        if (spec.per_channel) {
          buf.resize(C);
          for (double& a : buf) a = src.normal(1.0, spec.sigma);
          for (std::size_t i = 0; i < T_; ++i)
            for (std::size_t c = 0; c < C; ++c)
              x[i * C + c] = static_cast<T>(x[i * C + c] * buf[c]);
        } else {
          const double a = src.normal(1.0, spec.sigma);
          for (std::size_t i = 0; i < T_ * C; ++i) x[i] = static_cast<T>(x[i] * a);
        }
        break;
      }
      case StdaMethod::magnitude_warping: {
        const std::size_t n = static_cast<std::size_t>(spec.knots + 2);
        const std::size_t curves = spec.per_channel ? C : 1;
        std::vector<std::vector<double>> a(curves);
        std::vector<double> knots(n);
        for (std::size_t k = 0; k < curves; ++k) {
          for (double& v : knots) v = src.normal(1.0, spec.sigma);
          a[k] = warp_curve(knots, T_);
        }
        for (std::size_t i = 0; i < T_; ++i) {
          for (std::size_t c = 0; c < C; ++c) {
            x[i * C + c] = static_cast<T>(x[i * C + c] * a[spec.per_channel ? c : 0][i]);
          }
        }
        break;
      }
      case StdaMethod::time_scaling: {
        const double b = src.uniform(spec.lo, spec.hi);
        const double c = 0.5 * static_cast<double>(T_ - 1);
        for (std::size_t i = 0; i < T_; ++i) pos[i] = c + b * (static_cast<double>(i) - c);
        resample_window(x, T_, C, pos, scratch);
        break;
      }
      case StdaMethod::time_warping: {
        buf.resize(static_cast<std::size_t>(spec.knots + 1));
        for (double& u : buf) u = src.uniform(0.0, 1.0);
        pos = time_warp_positions(buf, spec.ratio, T_);
        resample_window(x, T_, C, pos, scratch);
        break;
      }
      case StdaMethod::rotation: {
        // One rotation for every sensor of the window, as the paper's X'_n = R X_n: a rotation
        // per sensor changed the sensors' orientations relative to each other (found in
        // review, 2026-11-27).
        double ang[3];
        for (int k = 0; k < 3; ++k)
          ang[k] = src.uniform(-spec.max_angle_rad[k], spec.max_angle_rad[k]);
        const Eigen::Matrix3d R = (Eigen::AngleAxisd(ang[0], Eigen::Vector3d::UnitX()) *
                                   Eigen::AngleAxisd(ang[1], Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(ang[2], Eigen::Vector3d::UnitZ()))
                                      .toRotationMatrix();
        for (const SensorChannels& s : layout.sensors) {
          for (std::size_t first : s.triads) {
            for (std::size_t i = 0; i < T_; ++i) {
              T* v = x + i * C + first;
              const Eigen::Vector3d r = R * Eigen::Vector3d(v[0], v[1], v[2]);
              v[0] = static_cast<T>(r.x());
              v[1] = static_cast<T>(r.y());
              v[2] = static_cast<T>(r.z());
            }
          }
        }
        break;
      }
      case StdaMethod::jittering: {
        buf.resize(T_ * C);
        src.normals(buf);
        std::vector<double> sig(C);
        for (std::size_t c = 0; c < C; ++c)
          sig[c] = spec.jitter_sigma[static_cast<int>(layout.kinds[c])];
        for (std::size_t i = 0; i < T_; ++i)
          for (std::size_t c = 0; c < C; ++c)
            x[i * C + c] = static_cast<T>(x[i * C + c] + sig[c] * buf[i * C + c]);
        break;
      }
    }
  }
}

void check(const StdaSpec& spec, const ChannelLayout& layout, std::size_t values,
           const BatchShape& shape) {
  spec.validate();
  if (values != shape.size()) {
    throw Error(fmt::format("{}: batch of {} values for shape ({}, {}, {})", to_string(spec.method),
                            values, shape.windows, shape.samples, shape.channels));
  }
  if (shape.samples == 0 && shape.windows > 0) throw Error("STDA: windows of 0 samples");
  layout.validate(shape.channels);
}

template <class T>
void apply_impl(const StdaSpec& spec, const ChannelLayout& layout, std::span<T> batch,
                const BatchShape& shape, Rng* rng, StdaDraws* log, const StdaDraws* replay) {
  check(spec, layout, batch.size(), shape);
  const std::size_t per = draws_per_window(spec, shape);
  if (replay != nullptr) {
    if (replay->method != spec.method || replay->per_window != per ||
        replay->values.size() != per * shape.windows) {
      // Both sides in windows x draws per window (the first figure was the total count).
      const std::size_t windows =
          replay->per_window ? replay->values.size() / replay->per_window : 0;
      throw Error(fmt::format(
          "{}: replayed draws ({} windows x {} draws of {}) do not fit {} windows x {} draws",
          to_string(spec.method), windows, replay->per_window, to_string(replay->method),
          shape.windows, per));
    }
  }
  if (log != nullptr) {
    log->method = spec.method;
    log->per_window = per;
    log->values.clear();
    log->values.reserve(per * shape.windows);
  }
  DrawSource src(rng, log, replay);
  run(spec, layout, batch, shape, src);
}

}  // namespace

std::string_view to_string(StdaMethod method) { return kMethodNames[static_cast<int>(method)]; }

StdaMethod parse_stda_method(std::string_view name) {
  for (std::size_t i = 0; i < kMethodNames.size(); ++i)
    if (kMethodNames[i] == name) return static_cast<StdaMethod>(i);
  std::string known;
  for (std::string_view n : kMethodNames) known += (known.empty() ? "" : ", ") + std::string(n);
  throw Error(fmt::format("unknown STDA method '{}' (known: {})", name, known));
}

void StdaSpec::validate() const {
  const auto bad = [&](const char* field, double v, const char* want) {
    throw Error(fmt::format("{}: {} = {} (must be {})", to_string(method), field, v, want));
  };
  if (!(std::isfinite(sigma) && sigma >= 0.0)) bad("sigma", sigma, "finite and >= 0");
  if (knots < 0 || knots > 1000) bad("knots", knots, "in [0, 1000]");
  if (!(std::isfinite(lo) && lo > 0.0 && std::isfinite(hi) && hi >= lo))
    bad("lo", lo, "positive with lo <= hi finite");
  if (!(std::isfinite(ratio) && ratio >= 1.0)) bad("ratio", ratio, ">= 1");
  for (double a : max_angle_rad)
    if (!(std::isfinite(a) && a >= 0.0)) bad("max_angle_rad", a, "finite and >= 0");
  for (double s : jitter_sigma)
    if (!(std::isfinite(s) && s >= 0.0)) bad("jitter_sigma", s, "finite and >= 0");
}

std::string StdaSpec::describe() const {
  const std::string name(to_string(method));
  switch (method) {
    case StdaMethod::identity:
      return name;
    case StdaMethod::magnitude_scaling:
      return fmt::format("{}(sigma={:g}{})", name, sigma, per_channel ? ", per channel" : "");
    case StdaMethod::magnitude_warping:
      return fmt::format("{}(sigma={:g}, K={}{})", name, sigma, knots,
                         per_channel ? ", per channel" : "");
    case StdaMethod::time_scaling:
      return fmt::format("{}(b in [{:g}, {:g}])", name, lo, hi);
    case StdaMethod::time_warping:
      return fmt::format("{}(K={}, r={:g})", name, knots, ratio);
    case StdaMethod::rotation:
      return fmt::format("{}(+-[{:g}, {:g}, {:g}] deg)", name, max_angle_rad[0] * kDegPerRad,
                         max_angle_rad[1] * kDegPerRad, max_angle_rad[2] * kDegPerRad);
    case StdaMethod::jittering:
      return fmt::format("{}(sigma accel={:g} gyro={:g} mag={:g} other={:g})", name,
                         jitter_sigma[0], jitter_sigma[1], jitter_sigma[2], jitter_sigma[3]);
  }
  return name;
}

void apply_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<float> batch,
                const BatchShape& shape, Rng& rng, StdaDraws* log) {
  apply_impl(spec, layout, batch, shape, &rng, log, nullptr);
}
void apply_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<double> batch,
                const BatchShape& shape, Rng& rng, StdaDraws* log) {
  apply_impl(spec, layout, batch, shape, &rng, log, nullptr);
}
void replay_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<float> batch,
                 const BatchShape& shape, const StdaDraws& draws) {
  apply_impl(spec, layout, batch, shape, nullptr, nullptr, &draws);
}
void replay_stda(const StdaSpec& spec, const ChannelLayout& layout, std::span<double> batch,
                 const BatchShape& shape, const StdaDraws& draws) {
  apply_impl(spec, layout, batch, shape, nullptr, nullptr, &draws);
}

std::vector<double> time_warp_speeds(std::span<const double> u, double ratio) {
  std::vector<double> v(u.begin(), u.end());
  if (u.empty()) return v;
  const auto [mn, mx] = std::minmax_element(u.begin(), u.end());
  // ratio 1, or all u equal (probability 0): every segment at the same speed.
  if (ratio == 1.0 || *mx == *mn) {
    std::fill(v.begin(), v.end(), 1.0);
    return v;
  }
  // tsaug: v = u - (max u - r min u) / (1 - r), so v(min u) = (max - min)/(r - 1) and
  // v(max u) = r (max - min)/(r - 1): max v / min v = r.
  const double shift = (*mx - ratio * *mn) / (1.0 - ratio);
  for (double& x : v) x -= shift;
  return v;
}

Interpolant time_warp_interpolant(std::span<const double> u, double ratio, std::size_t samples) {
  const double last = samples > 1 ? static_cast<double>(samples - 1) : 1.0;
  const std::vector<double> v = time_warp_speeds(u, ratio);
  const std::size_t n = std::max<std::size_t>(v.size() + 1, 2);  // K + 2 anchors
  double total = 0.0;
  for (double x : v) total += x;
  std::vector<double> anchors(n), knots(n);
  double acc = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    anchors[k] = last * static_cast<double>(k) / static_cast<double>(n - 1);
    if (k > 0 && k - 1 < v.size()) acc += v[k - 1];
    // The cumulative share of the span, with the last knot pinned to the end exactly.
    knots[k] = k + 1 == n ? last : (v.empty() ? anchors[k] : acc / total * last);
  }
  const Eigen::Map<const Eigen::RowVectorXd> y(knots.data(), static_cast<Eigen::Index>(n));
  return Interpolant::pchip(anchors, y);
}

std::vector<double> time_warp_positions(std::span<const double> u, double ratio,
                                        std::size_t samples) {
  std::vector<double> pos(samples);
  for (std::size_t i = 0; i < samples; ++i) pos[i] = static_cast<double>(i);
  if (samples < 2 || u.empty()) return pos;
  const Interpolant warp = time_warp_interpolant(u, ratio, samples);
  std::vector<double> out(samples);
  Eigen::Map<Eigen::RowVectorXd> m(out.data(), static_cast<Eigen::Index>(samples));
  warp.evaluate(pos, m);
  return out;
}

Interpolant warp_curve_interpolant(std::span<const double> knot_values, std::size_t samples) {
  std::vector<double> kv(knot_values.begin(), knot_values.end());
  if (kv.empty()) kv.push_back(1.0);
  if (kv.size() == 1) kv.push_back(kv[0]);
  const std::size_t n = kv.size();
  const double last = samples > 1 ? static_cast<double>(samples - 1) : 1.0;
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k)
    x[k] = last * static_cast<double>(k) / static_cast<double>(n - 1);
  const Eigen::Map<const Eigen::RowVectorXd> y(kv.data(), static_cast<Eigen::Index>(n));
  return Interpolant::cubic_spline(x, y);
}

std::vector<double> warp_curve(std::span<const double> knot_values, std::size_t samples) {
  std::vector<double> q(samples), curve(samples);
  for (std::size_t i = 0; i < samples; ++i) q[i] = static_cast<double>(i);
  const Interpolant spline = warp_curve_interpolant(knot_values, samples);
  Eigen::Map<Eigen::RowVectorXd> out(curve.data(), static_cast<Eigen::Index>(samples));
  spline.evaluate(q, out);
  return curve;
}

}  // namespace imukit::augment
